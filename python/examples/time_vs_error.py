"""Render a scene with three algorithms, score each against a ray-traced reference, and plot host
time against ꟻLIP and against MAE (time_vs_error.png).

    python python/examples/time_vs_error.py scenes/stanford-bunny.toml --width 480 --height 360
"""

import argparse
import time

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

import sism  # noqa: E402

parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
parser.add_argument("scene")
parser.add_argument("--width", type=int, default=480)
parser.add_argument("--height", type=int, default=360)
parser.add_argument("--algos", default="pcss,sism-sampled,rsmss")
parser.add_argument("--reference-spp", type=int, default=256)
parser.add_argument("--out", default="time_vs_error.png")
args = parser.parse_args()

scene = sism.load_scene(args.scene, width=args.width, height=args.height)
reference = sism.render(scene, "reference", params={"spp": args.reference_spp}, progress=True)

rows = []
for algo in args.algos.split(","):
    sism.render(scene, algo)  # warm-up: per-process first-touch costs are not the method's
    t0 = time.perf_counter()
    r = sism.render(scene, algo)
    ms = (time.perf_counter() - t0) * 1e3
    e = sism.compare(reference, r, scene=scene)
    rows.append((algo, ms, e["flip"], e["mae"]))
    print(f"{algo:<14} {ms:9.1f} ms   ꟻLIP {e['flip']:.5f}   MAE {e['mae']:.5f}")

fig, axes = plt.subplots(1, 2, figsize=(10, 4), constrained_layout=True)
for ax, k, label in [(axes[0], 2, "mean ꟻLIP (LDR, 67 ppd)"), (axes[1], 3, "MAE of V")]:
    for row in rows:
        ax.scatter(row[1], row[k], s=40)
        ax.annotate(row[0], (row[1], row[k]), textcoords="offset points", xytext=(5, 4))
    ax.set_xlabel("host time per frame, ms")
    ax.set_ylabel(label)
    ax.set_xscale("log")
    ax.grid(alpha=0.3)
fig.suptitle(f"{scene.path} at {scene.width}x{scene.height}, {sism.simd_backend()}")
fig.savefig(args.out, dpi=120)
print(f"wrote {args.out}")
