"""Strain against time for a scene, through the Python bindings.

    PYTHONPATH=build/python python3 examples/strain_plot.py assets/scenes/cloth_hang.json

Prints mean, 99th-percentile and max stretch strain per frame and, when matplotlib is installed
(and --no-plot is not given), saves strain.png beside the current folder."""
import argparse

import nucleon

parser = argparse.ArgumentParser()
parser.add_argument("scene")
parser.add_argument("--frames", type=int, default=120)
parser.add_argument("--set", action="append", default=[], help="KEY=VALUE, as nucleon run --set")
parser.add_argument("--no-plot", action="store_true")
args = parser.parse_args()

world = nucleon.World.from_scene(args.scene, set=args.set)
times, mean, p99, worst = [], [], [], []
for frame in range(1, args.frames + 1):
    world.step()
    m = world.measure()
    times.append(world.time)
    mean.append(m["mean_strain"])
    p99.append(m["strain_p99"])
    worst.append(m["max_strain"])
    print(f"frame {frame:4d}  t {world.time:6.3f} s  mean {m['mean_strain']:.4%}  "
          f"p99 {m['strain_p99']:.4%}  max {m['max_strain']:.4%}")

if not args.no_plot:
    try:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        print("matplotlib is not installed: no plot")
    else:
        plt.semilogy(times, mean, label="mean")
        plt.semilogy(times, p99, label="p99")
        plt.semilogy(times, worst, label="max")
        plt.xlabel("time (s)")
        plt.ylabel("stretch strain")
        plt.legend()
        plt.savefig("strain.png", dpi=120)
        print("saved strain.png")
