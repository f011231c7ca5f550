#!/usr/bin/python3
"""Draws a wheeled_train trajectory (nonholo run wheeled_train --out FILE.csv or FILE.h5): the
whole train at a few times, and the paths of the lead and of every 10th body near the front.

Usage: /usr/bin/python3 tools/plot_train.py FILE.csv|FILE.h5 OUT.png   (HDF5 needs python3-h5py)
"""
import csv
import sys

import matplotlib
matplotlib.use("Agg")
import matplotlib.pyplot as plt


def read(path):
    """The CSV's header and rows (t, the coordinates, ...), from either format."""
    if path.endswith((".h5", ".hdf5")):
        import h5py
        with h5py.File(path, "r") as f:
            names = [c.decode() if isinstance(c, bytes) else c for c in f["coordinates"][:]]
            return ["t"] + names, [[t, *q] for t, q in zip(f["t"][:].tolist(), f["q"][:].tolist())]
    with open(path) as f:
        reader = csv.reader(f)
        header = next(reader)
        return header, [[float(x) for x in row] for row in reader]


def main():
    if len(sys.argv) != 3:
        sys.exit("usage: plot_train.py FILE.csv|FILE.h5 OUT.png")
    header, rows = read(sys.argv[1])
    if not rows:
        sys.exit("plot_train.py: %s has no rows" % sys.argv[1])
    bodies = sum(1 for name in header if name.startswith("x") and name[1:].isdigit())
    col = {name: i for i, name in enumerate(header)}
    xs = [col["x%d" % b] for b in range(bodies)]
    ys = [col["y%d" % b] for b in range(bodies)]

    fig, (whole, front) = plt.subplots(2, 1, figsize=(10, 8), gridspec_kw={"height_ratios": [1, 2]})
    picks = sorted({0, len(rows) // 2, len(rows) - 1})
    for k in picks:
        row = rows[k]
        whole.plot([row[i] for i in xs], [row[i] for i in ys], lw=0.8, label="t = %.3g" % row[0])
    whole.set_title("wheeled_train, %d bodies: the whole train" % bodies)
    whole.set_xlabel("x")
    whole.set_ylabel("y")
    whole.legend(fontsize=8)

    shown = list(range(0, min(bodies, 101), 10))
    for b in shown:
        front.plot([r[xs[b]] for r in rows], [r[ys[b]] for r in rows], lw=1.2 if b == 0 else 0.7,
                   color="C3" if b == 0 else "0.5")
    last = rows[-1]
    front.plot([last[xs[b]] for b in range(min(bodies, 101))], [last[ys[b]] for b in range(min(bodies, 101))],
               "o-", ms=2, lw=0.8, color="C0", label="bodies 0-100 at t = %.3g" % last[0])
    front.set_aspect("equal", adjustable="datalim")
    front.set_title("the front: path of the lead (red) and of every 10th body (grey)")
    front.set_xlabel("x")
    front.set_ylabel("y")
    front.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(sys.argv[2], dpi=90)


if __name__ == "__main__":
    main()
