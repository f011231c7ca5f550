#!/usr/bin/python3
"""Speed against error (issue 4): runs `nonholo wp` (unless --csv DIR is given) and draws
docs/wp/*.png from its CSV files, plus docs/wp/work_precision.md (a few points per method).

Usage: /usr/bin/python3 tools/work_precision.py [--nonholo build/nonholo] [--csv DIR] [--out docs/wp]
"""
import argparse
import csv
import math
import os
import subprocess
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
STYLE = {  # series -> (label, marker, linestyle, colour): the same colour in every panel
    "reflection": ("reflection (ours, automatic restarts)", "o", "-", "C0"),
    "reflection+plain": ("reflection, plain (--restart 0)", "x", "-", "C9"),
    "reflection-o4": ("reflection order 4 (Blanes-Moan 4)", "o", "-.", "C8"),
    "reflection-o6": ("reflection order 6 (Blanes-Moan 6)", "*", "-", "k"),
    "reflection-o8": ("reflection order 8 (Kahan-Li 17)", "*", "-.", "C0"),
    "reflection-a2": ("adaptive order 2", "o", ":", "C9"),
    "reflection-a4": ("adaptive order 4", "o", ":", "C8"),
    "reflection-a6": ("adaptive order 6", "*", ":", "k"),
    "reflection-a8": ("adaptive order 8", "*", ":", "C0"),
    "dla-midpoint": ("DLA midpoint", "s", "-", "C1"),
    "dla-left": ("DLA left point", "v", "-", "C2"),
    "rk4": ("RK4", "^", "--", "C3"),
    "rk4+project": ("RK4 + projection", "^", ":", "C4"),
    "arkode-dp5": ("ARKODE DP5(4)", "D", "--", "C5"),
    "arkode-dp5+project": ("ARKODE DP5(4) + projection", "D", ":", "C6"),
    "arkode-verner": ("ARKODE Verner 6(5)", "P", "--", "C7"),
    "arkode-fehlberg8": ("ARKODE Fehlberg 8(7)", "X", "--", "navy"),
}


def read(path):
    with open(path) as f:
        return list(csv.DictReader(f))


def series(row):
    return row["method"] + ("+project" if row.get("project") == "1" else "")


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--nonholo", default=os.path.join(ROOT, "build", "nonholo"))
    ap.add_argument("--csv", help="reuse the CSV files in this directory")
    ap.add_argument("--out", default=os.path.join(ROOT, "docs", "wp"))
    args = ap.parse_args()
    os.makedirs(args.out, exist_ok=True)
    src = args.csv or args.out
    if not args.csv:
        print("running", args.nonholo, "wp --out", src, file=sys.stderr)
        subprocess.run([args.nonholo, "wp", "--out", src], check=True)

    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    rows = read(os.path.join(src, "work_precision.csv"))
    scenes = list(dict.fromkeys(r["scene"] for r in rows))
    nrows = (len(scenes) + 1) // 2
    fig, axes = plt.subplots(nrows, 2, figsize=(12, 4.5 * nrows), squeeze=False)
    for ax in axes.flat[len(scenes):]:
        ax.axis("off")
    for ax, scene in zip(axes.flat, scenes):
        for key, (label, marker, ls, colour) in STYLE.items():
            pts = [(float(r["cpu_s"]), float(r["error"])) for r in rows
                   if r["scene"] == scene and series(r) == key and r["status"] == "ok"
                   and float(r["error"]) > 0 and not math.isnan(float(r["error"]))]
            if pts:
                pts.sort()
                ax.loglog([p[0] for p in pts], [p[1] for p in pts], marker=marker, ls=ls, color=colour, label=label)
        ax.set_title(scene.replace("_", " "))
        ax.set_xlabel("CPU time (s), T = 10")
        ax.set_ylabel("max error in q against the oracle")
        ax.grid(True, which="both", alpha=0.3)
    axes.flat[0].legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(os.path.join(args.out, "work_precision.png"), dpi=100)

    rows = read(os.path.join(src, "long_time.csv"))
    runs = list(dict.fromkeys(r["scene"] for r in rows))
    fig, axes = plt.subplots(len(runs), 3, figsize=(17, 4.5 * len(runs)), squeeze=False)
    for i, scene in enumerate(runs):
        for key, (label, marker, ls, colour) in STYLE.items():
            pts = [r for r in rows if r["scene"] == scene and r["method"] == key]
            if not pts:
                continue
            t = [float(r["t"]) for r in pts]
            for j, column in enumerate(["energy_err", "residual", "error"]):
                y = [max(float(r[column]), 1e-17) for r in pts]
                if j == 2 and (t[0] == 0.0):
                    t2, y = t[1:], y[1:]
                else:
                    t2 = t
                if not all(math.isnan(v) for v in y):
                    axes[i][j].semilogy(t2, y, ls=ls, color=colour, label=label)
            if key.startswith("reflection"):
                y = [max(float(r["energy_post_err"]), 1e-17) for r in pts]
                axes[i][0].semilogy(t, y, ls=":", color=colour, alpha=0.7, label=label + ": post-momentum energy")
        name = scene.replace("_", " ")
        axes[i][0].set_title(name + ": relative energy error")
        axes[i][1].set_title(name + ": constraint residual |mu v|")
        axes[i][2].set_title(name + ": error in q against the oracle")
        for ax in axes[i]:
            ax.set_xlabel("t")
            ax.grid(True, which="both", alpha=0.3)
        if all(math.isnan(float(r["error"])) for r in rows if r["scene"] == scene):
            axes[i][2].axis("off")
            axes[i][2].text(0.5, 0.5, "no oracle this long\n(ARKODE at 1e-12 would take minutes)",
                            ha="center", va="center", transform=axes[i][2].transAxes)
    axes[0][0].legend(fontsize=7)
    axes[0][2].legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(os.path.join(args.out, "long_time.png"), dpi=100)

    fig, axes = plt.subplots(1, 3, figsize=(15, 4.2))
    rows = read(os.path.join(src, "paper_particle_energy.csv"))
    for key in ["reflection", "dla-midpoint"]:
        pts = [r for r in rows if r["method"] == key]
        axes[0].plot([float(r["t"]) for r in pts], [float(r["energy"]) for r in pts], color=STYLE[key][3], label=STYLE[key][0])
    axes[0].set_title("particle, h = 0.1: energy")
    axes[0].set_xlabel("t")
    axes[0].legend(fontsize=8)
    rows = read(os.path.join(src, "paper_sleigh_error.csv"))
    for key in ["reflection", "dla-midpoint", "dla-left"]:
        pts = [r for r in rows if r["method"] == key and float(r["t"]) > 0]
        axes[1].semilogy([float(r["t"]) for r in pts], [max(float(r["error"]), 1e-17) for r in pts],
                         color=STYLE[key][3], label=STYLE[key][0])
    axes[1].set_title("sleigh, h = 0.05: error against the exact trajectory")
    axes[1].set_xlabel("t")
    axes[1].legend(fontsize=8)
    rows = read(os.path.join(src, "paper_snakeboard_path.csv"))
    axes[2].plot([float(r["x"]) for r in rows], [float(r["y"]) for r in rows])
    axes[2].set_aspect("equal", adjustable="datalim")
    axes[2].set_title("controlled snakeboard from rest, T = 20")
    axes[2].set_xlabel("x")
    axes[2].set_ylabel("y")
    fig.tight_layout()
    fig.savefig(os.path.join(args.out, "paper.png"), dpi=100)


if __name__ == "__main__":
    main()
