"""A core sweep of one frame on the modelled Larrabee into a pandas DataFrame: frame time and
speedup per core count, and where each phase's cycles go at the largest one.

    python python/examples/core_sweep.py scenes/palm.toml --algo sism-sampled
"""

import argparse

import pandas as pd

import sism

parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
parser.add_argument("scene")
parser.add_argument("--algo", default="sism")
parser.add_argument("--machine", default="larrabee-24")
parser.add_argument("--cores", default="8,16,24,32,48,64")
parser.add_argument("--width", type=int, default=640)
parser.add_argument("--height", type=int, default=480)
parser.add_argument("--csv", default=None, help="also write the rows here")
args = parser.parse_args()

scene = sism.load_scene(args.scene, width=args.width, height=args.height)
cores = [int(c) for c in args.cores.split(",")]
df = pd.DataFrame(sism.study(scene, machine=args.machine, algo=args.algo, cores=cores, progress=True))

frames = df[df.level == "frame"][["cores", "threads", "l2_kb", "ms", "frame_speedup"]]
print(frames.to_string(index=False))

widest = df[(df.level == "phase") & (df.cores == max(cores))]
stack = widest.set_index("phase")[["issue", "memory", "atomics_sync", "imbalance_idle"]]
print(f"\ncycle stacks per phase at {max(cores)} cores (share of the phase's cycles):")
print((stack.div(stack.sum(axis=1), axis=0) * 100).round(1).to_string())
if args.csv:
    df.to_csv(args.csv, index=False)
    print(f"wrote {args.csv}")
