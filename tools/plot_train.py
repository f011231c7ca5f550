#!/usr/bin/python3
"""Draws a wheeled_train trajectory (nonholo run wheeled_train --out FILE.csv or FILE.h5), so that
one sees the train and what it does: on top, the path of the lead (body 0) with the front of the
train at a few times; below, close-ups that follow the front at those times, each body drawn as a
sleigh with its blade. All panels have equal aspect (a long train is a line on the scale of its
length: its rear half does not move much in 20 time units).

Usage: /usr/bin/python3 tools/plot_train.py FILE.csv|FILE.h5 OUT.png   (HDF5 needs python3-h5py)
"""
import csv
import sys

import matplotlib
matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
from matplotlib.collections import LineCollection, PolyCollection

FRONT = 40  # bodies drawn in the top panel


def read(path):
    """The header (t, the coordinates, ...), the rows as an array, and the scene's parameters
    (an HDF5 file's /parameters; {} for a CSV)."""
    if path.endswith((".h5", ".hdf5")):
        import h5py
        with h5py.File(path, "r") as f:
            names = [c.decode() if isinstance(c, bytes) else c for c in f["coordinates"][:]]
            params = {k: float(v) for k, v in f["parameters"].attrs.items()} if "parameters" in f else {}
            return ["t"] + names, np.column_stack([f["t"][:], f["q"][:]]), params
    with open(path) as f:
        reader = csv.reader(f)
        header = next(reader)
        return header, np.array([[float(x) for x in row] for row in reader]).reshape(-1, len(header)), {}


def sleighs(x, y, theta, p, lead=True):
    """Body outlines (rear hitch to front hitch) and blade lines of bodies at x, y, theta."""
    d, f, a = p.get("d", 0.5), p.get("f", 0.5), p.get("a", 0.2)
    w = 0.18 * (d + f)
    shape = np.array([[-d, -w], [f - w, -w], [f, 0], [f - w, w], [-d, w]])
    c, s = np.cos(theta)[:, None], np.sin(theta)[:, None]
    vx = x[:, None] + c * shape[:, 0] - s * shape[:, 1]
    vy = y[:, None] + s * shape[:, 0] + c * shape[:, 1]
    bx, by = x - a * c[:, 0], y - a * s[:, 0]
    blades = np.stack([np.column_stack([bx + 1.6 * w * s[:, 0], by - 1.6 * w * c[:, 0]]),
                       np.column_stack([bx - 1.6 * w * s[:, 0], by + 1.6 * w * c[:, 0]])], axis=1)
    colours = ["#d62728" if lead and i == 0 else "#1f77b4" for i in range(len(x))]
    return (PolyCollection(np.stack([vx, vy], axis=2), facecolors=colours, edgecolors="k", linewidths=0.4, zorder=3),
            LineCollection(blades, colors="k", linewidths=1.0, zorder=4))


def main():
    if len(sys.argv) != 3:
        sys.exit("usage: plot_train.py FILE.csv|FILE.h5 OUT.png")
    header, rows, params = read(sys.argv[1])
    if rows.shape[0] == 0:
        sys.exit("plot_train.py: %s has no rows" % sys.argv[1])
    col = {name: i for i, name in enumerate(header)}
    bodies = sum(1 for name in header if name.startswith("x") and name[1:].isdigit())
    t = rows[:, 0]
    X = rows[:, [col["x%d" % b] for b in range(bodies)]]
    Y = rows[:, [col["y%d" % b] for b in range(bodies)]]
    TH = rows[:, [col["theta%d" % b] for b in range(bodies)]]
    picks = sorted(set(np.linspace(0, len(t) - 1, 4).round().astype(int).tolist()))
    colours = plt.cm.viridis(np.linspace(0, 0.85, len(picks)))

    fig = plt.figure(figsize=(12, 5.6))
    grid = fig.add_gridspec(2, len(picks), height_ratios=[1, 1.35])
    top = fig.add_subplot(grid[0, :])
    front = min(bodies, FRONT)
    top.plot(X[:, 0], Y[:, 0], color="#d62728", lw=1.8, label="path of the lead (body 0)", zorder=2)
    if bodies > 1:
        last = bodies - 1
        top.plot(X[:, min(front, bodies) - 1], Y[:, min(front, bodies) - 1], color="0.5", lw=1, ls="--", zorder=2,
                 label="path of body %d" % (min(front, bodies) - 1))
    for k, colour in zip(picks, colours):
        top.plot(X[k, :front], Y[k, :front], "-", color=colour, lw=1.2, zorder=3)
        top.plot(X[k, :front], Y[k, :front], "o", color=colour, ms=2.5, zorder=3,
                 label="bodies 0-%d at t = %.3g" % (front - 1, t[k]))
        top.plot(X[k, 0], Y[k, 0], ">", color=colour, ms=7, zorder=4)
    top.set_aspect("equal", adjustable="box")
    ylo, yhi = top.get_ylim()
    top.set_ylim(ylo - 1, yhi + 1)
    top.set_title("wheeled_train, %d bodies: the lead's path and the front %d bodies at %d times (equal aspect)"
                  % (bodies, front, len(picks)), fontsize=10)
    top.legend(fontsize=7, loc="best", ncol=2)
    top.set_xlabel("x")
    top.set_ylabel("y")
    if bodies > front:
        moved = np.hypot(X[-1] - X[0], Y[-1] - Y[0])
        top.text(0.01, 0.03, "not shown: bodies %d-%d, trailing behind along -x to x = %.0f; the rear body moved "
                 "%.2f, the lead %.1f" % (front, bodies - 1, X[-1, -1], moved[-1], moved[0]),
                 transform=top.transAxes, fontsize=7.5, color="0.25")

    # Close-ups following the front: a fixed 16 x 12 window with the lead at its upper right third.
    half_x, half_y = 8.0 * max(params.get("d", 0.5) + params.get("f", 0.5), 0.1), None
    for n, (k, colour) in enumerate(zip(picks, colours)):
        ax = fig.add_subplot(grid[1, n])
        cx, cy = X[k, 0] - 0.35 * half_x * np.cos(TH[k, 0]), Y[k, 0] - 0.35 * half_x * np.sin(TH[k, 0])
        hy = half_x * 0.75 if half_y is None else half_y
        near = np.nonzero((np.abs(X[k] - cx) < 1.2 * half_x) & (np.abs(Y[k] - cy) < 1.2 * hy))[0]
        ax.plot(X[:k + 1, 0], Y[:k + 1, 0], color="#d62728", lw=1.2, zorder=2)
        if near.size:
            links = LineCollection(np.stack([np.column_stack([X[k, near[:-1]], Y[k, near[:-1]]]),
                                             np.column_stack([X[k, near[:-1] + 1], Y[k, near[:-1] + 1]])], axis=1)
                                   if near.size > 1 else [], colors="0.5", linewidths=0.8, zorder=2)
            ax.add_collection(links)
            polys, blades = sleighs(X[k, near], Y[k, near], TH[k, near], params, lead=near[0] == 0)
            ax.add_collection(polys)
            ax.add_collection(blades)
        ax.set_xlim(cx - half_x, cx + half_x)
        ax.set_ylim(cy - hy, cy + hy)
        ax.set_aspect("equal")
        ax.set_title("the front at t = %.3g" % t[k], fontsize=9, color=colour)
        ax.tick_params(labelsize=7)
        ax.grid(True, lw=0.3, alpha=0.5)
    fig.text(0.5, 0.005, "close-ups: each body a sleigh from its rear hitch to its front hitch, its blade (black) "
             "%.2g behind its centre, the lead red; red line: the lead's path so far" % params.get("a", 0.2),
             ha="center", fontsize=8, color="0.25")
    fig.tight_layout(rect=(0, 0.02, 1, 1))
    fig.savefig(sys.argv[2], dpi=90)


if __name__ == "__main__":
    main()
