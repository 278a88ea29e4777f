#!/usr/bin/env bash
# `nucleon view --frames N --screenshot` under Xvfb (software OpenGL): the picture must show the
# cloth (a tenth of the pixels differ from the background, 3% in the cloth's colour). And the
# check itself must refuse a frame without the cloth.
set -euo pipefail
nucleon=$1
check=$2
scene=$3
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
# Runs the viewer under a virtual X server, with the server's own errors shown. An X server that
# fails to start (xvfb-run waits a few seconds for it; a loaded machine can take longer) is
# retried once and said so; a viewer that fails is not.
view() {
  local log="$work/xvfb.log" errors="$work/view.err"
  for attempt in 1 2; do
    if xvfb-run -a -e "$log" -s "-screen 0 1280x800x24" "$nucleon" view "$@" 2>"$errors"; then
      cat "$errors" >&2
      return 0
    fi
    cat "$errors" "$log" >&2 2>/dev/null || true
    if [ "$attempt" = 1 ] && grep -q "Xvfb failed to start" "$errors"; then
      echo "the X server did not start; retrying once" >&2
      continue
    fi
    return 1
  done
}
view "$scene" --frames 10 --size 640x480 --screenshot "$work/view.png"
"$check" "$work/view.png" 0.10 0.03
# A scene without the cloth (a grey collider alone): the check must fail on it.
printf '{"name": "empty", "objects": [{"type": "collider", "name": "floor", "shape": {"grid": {"resolution": [2, 2], "size": [1, 1], "center": [0, 0, 0]}}}]}\n' > "$work/empty.json"
view "$work/empty.json" --frames 1 --size 320x240 --screenshot "$work/empty.png"
if "$check" "$work/empty.png" 0.10 0.03; then
  echo "FAIL: the coverage check passed an empty frame" >&2
  exit 1
fi
echo "viewer screenshot: ok"
