#!/usr/bin/python3
"""Write throughput of `nonholo run --out` as CSV and as HDF5 (issue 14): a 10^5-body chain
(one-form hitches, every step written), the same run without output alternating with the
two formats. The output's cost is the wall time over the run without it (medians of
--repeat); MB/s is the file's size over that time, and also the data the file holds, as
8-byte doubles, over it (the HDF5 file holds p and the gap besides the CSV's columns).

Usage: /usr/bin/python3 benchmarks/output_throughput.py [--cli build/nonholo] [--bodies 100000]
"""
import argparse
import os
import statistics
import subprocess
import tempfile

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def wall(cli, args):
    out = subprocess.run([cli, "run", *args], capture_output=True, text=True, check=True).stdout
    return float(dict(w.split("=", 1) for w in out.split())["wall_s"])


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--cli", default=os.path.join(ROOT, "build", "nonholo"))
    ap.add_argument("--bodies", type=int, default=100000)
    ap.add_argument("--steps", type=int, default=20)
    ap.add_argument("--repeat", type=int, default=5)
    a = ap.parse_args()
    base = ["sleigh_chain", "--set", "bodies=%d" % a.bodies, "--hitch", "oneform", "--t-end", repr(0.01 * a.steps)]
    with tempfile.TemporaryDirectory() as tmp:
        files = {fmt: os.path.join(tmp, "out." + fmt) for fmt in ("csv", "h5")}
        times = {"none": [], "csv": [], "h5": []}
        for _ in range(a.repeat):
            times["none"].append(wall(a.cli, base))
            for fmt, path in files.items():
                times[fmt].append(wall(a.cli, base + ["--out", path]))
        sizes = {fmt: os.path.getsize(path) for fmt, path in files.items()}
    frames, n = a.steps + 1, 3 * a.bodies
    # What each format holds, as doubles: the CSV t, q, energy, energy_post, residual; the
    # HDF5 file p and gap too.
    state_mb = {"csv": frames * (n + 4) * 8 / 1e6, "h5": frames * (2 * n + 5) * 8 / 1e6}
    none = statistics.median(times["none"])
    print("sleigh_chain, %d bodies, %d frames of %d coordinates; medians of %d" % (a.bodies, frames, n, a.repeat))
    print("  run without output: %.3f s" % none)
    for fmt in ("csv", "h5"):
        cost = statistics.median(times[fmt]) - none
        print("  %-4s file %7.1f MB, output %.3f s: %6.1f MB/s of file, %6.1f MB/s of the %.1f MB it holds" % (
            fmt, sizes[fmt] / 1e6, cost, sizes[fmt] / 1e6 / cost, state_mb[fmt] / cost, state_mb[fmt]))


if __name__ == "__main__":
    main()
