#!/usr/bin/python3
"""One chain on several threads (issue 34): runs benchmarks/bench_chain's
ChainStep_OneForm_Threads (default options: the period-2 mode measured, restarts as they come),
ChainStep_OneForm_Plain_Threads (the bare step) and ChainStep_Holonomic_Threads (holonomic
hitches, default options: the gap corrections' passes too) for N = 10^2 ... 10^6 bodies and
P = 1, 2, 4, ... threads up to the processors present, then writes a strong-scaling table
(ns per body-step, speed-up against P = 1 in the same run) and a plot.

Usage: /usr/bin/python3 tools/thread_scaling.py [--bench BUILD/benchmarks/bench_chain]
           [--json FILE (reuse a run)] [--repetitions 5] [--out docs/results] [--name threads]
Times are the minimum over the repetitions (interleaved at random): on a shared machine the
least disturbed estimate of a ratio. Threads need free cores: measure with nothing else running.
"""
import argparse
import json
import os
import subprocess
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
SERIES = [("ChainStep_OneForm_Threads", "one-form step, default options"),
          ("ChainStep_OneForm_Plain_Threads", "one-form step, bare (--restart 0 --monitor-every 0)"),
          ("ChainStep_Holonomic_Threads", "holonomic step, default options")]


def run(bench, repetitions, out):
    cmd = [bench, "--benchmark_filter=Threads", "--benchmark_format=json", "--benchmark_out=" + out,
           "--benchmark_repetitions=%d" % repetitions, "--benchmark_enable_random_interleaving=true",
           "--benchmark_report_aggregates_only=true"]
    print("running", " ".join(cmd), file=sys.stderr)
    subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL)


def load(path):
    """{family: {(N, P): ns per body-step}} from the minima."""
    data = json.load(open(path))
    table = {}
    for b in data["benchmarks"]:
        if b.get("run_type") == "aggregate" and b.get("aggregate_name") != "min":
            continue
        family, n, p = b["name"].split("/")[:3]
        scale = {"ns": 1.0, "us": 1e3, "ms": 1e6, "s": 1e9}[b["time_unit"]]
        table.setdefault(family, {})[(int(n), int(p))] = b["real_time"] * scale / int(n)
    return data.get("context", {}), table


def break_even(cells, sizes):
    """Where 2 threads start to pay: the N at which the speed-up crosses 1, interpolated in
    log N between the measured sizes."""
    points = [(n, cells[(n, 1)] / cells[(n, 2)]) for n in sizes if (n, 1) in cells and (n, 2) in cells]
    if not points:
        return "Break-even: not measured (no P = 2)."
    if points[0][1] >= 1.0:
        return "Break-even: 2 threads already pay at N = %d (%.2f×), the smallest size measured." % points[0]
    for (n0, s0), (n1, s1) in zip(points, points[1:]):
        if s0 < 1.0 <= s1:
            import math
            x = math.log(n0) + (math.log(n1) - math.log(n0)) * (1.0 - s0) / (s1 - s0)
            return "Break-even: 2 threads pay from about N = %d (%.2f× at %d, %.2f× at %d)." % (
                round(math.exp(x), -2), s0, n0, s1, n1)
    return "Break-even: 2 threads did not pay up to N = %d (%.2f×)." % points[-1]


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--bench", default=os.path.join(ROOT, "build", "benchmarks", "bench_chain"))
    ap.add_argument("--json", help="reuse this Google Benchmark JSON instead of running")
    ap.add_argument("--repetitions", type=int, default=5)
    ap.add_argument("--out", default=os.path.join(ROOT, "docs", "results"))
    ap.add_argument("--name", default="threads", help="the files' stem: NAME.md, NAME.json, NAME.png")
    args = ap.parse_args()
    os.makedirs(args.out, exist_ok=True)
    path = args.json or os.path.join(args.out, args.name + ".json")
    if not args.json:
        run(args.bench, args.repetitions, path)
    context, t = load(path)
    lines = []
    for family, label in SERIES:
        if family not in t:
            continue
        cells = t[family]
        sizes = sorted({n for n, _ in cells})
        threads = sorted({p for _, p in cells})
        lines += ["%s: ns per body-step (speed-up against 1 thread)" % label, "",
                  "| N | " + " | ".join("P = %d" % p for p in threads) + " |",
                  "| ---: |" + " ---: |" * len(threads)]
        for n in sizes:
            one = cells.get((n, 1))
            row = []
            for p in threads:
                x = cells.get((n, p))
                row.append("" if x is None else "%.1f" % x if one is None or p == 1 else "%.1f (%.2f×)" % (x, one / x))
            lines.append("| %d | " % n + " | ".join(row) + " |")
        lines += ["", break_even(cells, sizes), ""]
    lines.append("Minimum of %d repetitions; %s, %s CPUs at %s MHz (%s)." % (
        args.repetitions, context.get("date", "?"), context.get("num_cpus", "?"), context.get("mhz_per_cpu", "?"),
        context.get("host_name", "?")))
    md = "\n".join(lines) + "\n"
    open(os.path.join(args.out, args.name + ".md"), "w").write(md)
    print(md)

    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, axes = plt.subplots(1, 2, figsize=(10, 4))
    for (family, label), style in zip(SERIES, ["-", ":", "--"]):
        cells = t.get(family, {})
        for n, marker in zip(sorted({n for n, _ in cells}), "osD^"):
            ps = sorted(p for m, p in cells if m == n)
            axes[0].plot(ps, [cells[(n, p)] for p in ps], marker + style, label="N = %d, %s" % (n, label.split(" (")[0]))
            if (n, 1) in cells:
                axes[1].plot(ps, [cells[(n, 1)] / cells[(n, p)] for p in ps], marker + style)
    top = max((p for cells in t.values() for _, p in cells), default=2)
    axes[1].plot([1, top], [1, top], "k--", lw=0.8, label="ideal")
    axes[0].set_xlabel("threads P")
    axes[0].set_ylabel("ns per body-step")
    axes[1].set_xlabel("threads P")
    axes[1].set_ylabel("speed-up against P = 1")
    for ax in axes:
        ax.set_xscale("log", base=2)
        ax.grid(True, which="both", alpha=0.3)
    axes[0].legend(fontsize=7)
    axes[1].legend(fontsize=7)
    fig.suptitle("sleigh_chain, one chain on P threads")
    fig.tight_layout()
    fig.savefig(os.path.join(args.out, args.name + ".png"), dpi=110)


if __name__ == "__main__":
    main()
