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
xvfb-run -a -s "-screen 0 1280x800x24" "$nucleon" view "$scene" --frames 10 --size 640x480 \
  --screenshot "$work/view.png"
"$check" "$work/view.png" 0.10 0.03
# A scene without the cloth (a grey collider alone): the check must fail on it.
printf '{"name": "empty", "objects": [{"type": "collider", "name": "floor", "shape": {"grid": {"resolution": [2, 2], "size": [1, 1], "center": [0, 0, 0]}}}]}\n' > "$work/empty.json"
xvfb-run -a -s "-screen 0 1280x800x24" "$nucleon" view "$work/empty.json" --frames 1 \
  --size 320x240 --screenshot "$work/empty.png"
if "$check" "$work/empty.png" 0.10 0.03; then
  echo "FAIL: the coverage check passed an empty frame" >&2
  exit 1
fi
echo "viewer screenshot: ok"
