"""How much more `meshgaze.saliency` costs from Python than the command line's whole process.

For each method, alternately (so drift in the machine's load hits both alike):
  cli     `meshgaze saliency MESH --method M --seed 1 -o OUT --quiet`, the whole process;
  python  a fresh `python -c` process that imports meshgaze, reads the mesh and computes the
          map (the whole process: interpreter start, numpy import, saving the map), and
          inside it the time of read_mesh + saliency alone: what calling saliency costs
          from a running notebook or script.
Prints the median of --repeat runs and the ratios; checks the maps are equal.

    python python/benchmarks/saliency_overhead.py [--mesh ../shared/data/meshes/classic/stanford_bunny/bun_zipper.ply] [--methods sms,mc] [--repeat 5]
"""
import argparse
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import pandas as pd

import meshgaze

def read_csv(path, **options):
    """pandas' CSV reader with the parser that reads float64 text back exactly."""
    return pd.read_csv(path, **meshgaze.exact_floats(), **options)


REPO = Path(__file__).resolve().parents[2]
CHILD = """
import sys, time, numpy as np
import meshgaze
t0 = time.perf_counter()
mesh = meshgaze.read_mesh(sys.argv[1])
values = meshgaze.saliency(mesh, sys.argv[2], seed=1)
print(time.perf_counter() - t0)
np.save(sys.argv[3], values)
"""


def timed(cmd):
    t = time.perf_counter()
    r = subprocess.run(cmd, capture_output=True, text=True)
    elapsed = time.perf_counter() - t
    if r.returncode != 0:
        sys.exit(f"{' '.join(map(str, cmd))} failed:\n{r.stderr}")
    return elapsed, r.stdout


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--mesh", default=str(REPO.parent / "shared/data/meshes/classic/stanford_bunny/bun_zipper.ply"))
    ap.add_argument("--methods", default="sms,mc")
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--bin", default=os.environ.get("MESHGAZE_BIN", str(REPO / "target/release/meshgaze")))
    a = ap.parse_args()
    if not Path(a.mesh).exists():
        sys.exit(f"{a.mesh}: not found (the 35,947-vertex bunny is in ../shared/data)")
    print(f"mesh {a.mesh}, {a.repeat} runs each, median seconds")
    print("| method | CLI process | Python process | Python call | process ratio | call ratio |")
    print("|---|---:|---:|---:|---:|---:|")
    with tempfile.TemporaryDirectory() as tmp:
        for method in a.methods.split(","):
            cli, proc, call = [], [], []
            for i in range(a.repeat):
                out = Path(tmp) / f"{method}"
                t, _ = timed([a.bin, "saliency", a.mesh, "--method", method, "--seed", "1",
                              "-o", out, "--quiet"])
                cli.append(t)
                npy = Path(tmp) / f"{method}.npy"
                t, stdout = timed([sys.executable, "-c", CHILD, a.mesh, method, npy])
                proc.append(t)
                call.append(float(stdout.strip().splitlines()[-1]))
            ours = np.load(npy)
            theirs = read_csv(Path(tmp) / f"{method}.csv")["saliency"].to_numpy()
            same = "equal" if np.array_equal(ours, theirs) else f"DIFFER (max {np.abs(ours - theirs).max()})"
            c, p, k = (statistics.median(x) for x in (cli, proc, call))
            print(f"| {method} | {c:.3f} | {p:.3f} | {k:.3f} | {p / c:.3f} | {k / c:.3f} |  maps {same}")


if __name__ == "__main__":
    main()
