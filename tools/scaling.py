#!/usr/bin/python3
"""Scaling of the chain step (issues 3 and 12): runs benchmarks/bench_chain, then writes
docs/scaling.md (ns per body-step, the target ratios) and docs/scaling.png (log-log plot).

Usage: /usr/bin/python3 tools/scaling.py [--bench BUILD/benchmarks/bench_chain]
                                         [--json FILE (reuse a run)] [--repetitions 3]
Ratios are of medians measured in the same run of the same binary.
"""
import argparse
import json
import os
import subprocess
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
SERIES = [  # benchmark family, label in the table and plot
    ("ChainStep_OneForm", "step, one-form hitches (fused banded sweep)"),
    ("ChainStep_Holonomic", "step, holonomic hitches (fused)"),
    ("ChainStep_OneForm_Cholmod", "step, one-form, separate passes around CHOLMOD"),
    ("ChainStep_Holonomic_Cholmod", "step, holonomic, separate passes around CHOLMOD"),
    ("ChainFactorSolve_Cholmod", "CHOLMOD factor+solve of C"),
    ("ChainFactorSolve_Banded", "banded LDLT factor+solve of C"),
    ("ChainFactorSolve_LapackBanded", "LAPACK dpbtrf+dpbtrs"),
    ("SpringChainStep", "spring chain step (fused)"),
    ("SpringChainStep_BlockDiagonal", "spring chain step, block-diagonal"),
    ("SpringChainStep_Cholmod", "spring chain step, forced CHOLMOD"),
]


def run(bench, repetitions, out):
    cmd = [bench, "--benchmark_format=json", "--benchmark_out=" + out,
           "--benchmark_repetitions=%d" % repetitions,
           "--benchmark_report_aggregates_only=true",
           "--benchmark_filter=-Threads"]  # one chain on threads: tools/thread_scaling.py
    print("running", " ".join(cmd), file=sys.stderr)
    subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL)


def load(path):
    """{family: {N: ns per body-step}} from the medians (or single runs)."""
    data = json.load(open(path))
    table = {}
    for b in data["benchmarks"]:
        if b.get("run_type") == "aggregate" and b.get("aggregate_name") != "median":
            continue
        family, n = b["name"].split("/")[:2]
        scale = {"ns": 1.0, "us": 1e3, "ms": 1e6, "s": 1e9}[b["time_unit"]]
        table.setdefault(family, {})[int(n)] = b["real_time"] * scale / int(n)
    return data.get("context", {}), table


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--bench", default=os.path.join(ROOT, "build", "benchmarks", "bench_chain"))
    ap.add_argument("--json", help="reuse this Google Benchmark JSON instead of running")
    ap.add_argument("--repetitions", type=int, default=3)
    ap.add_argument("--out", default=os.path.join(ROOT, "docs"))
    args = ap.parse_args()
    os.makedirs(args.out, exist_ok=True)
    path = args.json or os.path.join(args.out, "scaling.json")
    if not args.json:
        run(args.bench, args.repetitions, path)
    context, t = load(path)
    sizes = sorted({n for f in t.values() for n in f})

    lines = ["| ns per body-step | " + " | ".join("N = %d" % n for n in sizes) + " |",
             "| --- |" + " ---: |" * len(sizes)]
    for family, label in SERIES:
        if family in t:
            lines.append("| %s | " % label + " | ".join(
                "%.1f" % t[family][n] if n in t[family] else "" for n in sizes) + " |")

    def ratio(a, b, n):
        return t[a][n] / t[b][n]

    checks = []
    for n in (100000, 1000000):
        checks.append(("one-form step / CHOLMOD factor+solve, N = %d" % n,
                       ratio("ChainStep_OneForm", "ChainFactorSolve_Cholmod", n), "<=", 0.5))
        checks.append(("holonomic step / CHOLMOD factor+solve, N = %d" % n,
                       ratio("ChainStep_Holonomic", "ChainFactorSolve_Cholmod", n), "<=", 0.8))
    checks.append(("one-form step per body, N = 10^6 / N = 10^3",
                   t["ChainStep_OneForm"][1000000] / t["ChainStep_OneForm"][1000], "<=", 1.3))
    for n in sizes:
        checks.append(("spring chain: forced CHOLMOD / fused, N = %d" % n,
                       ratio("SpringChainStep_Cholmod", "SpringChainStep", n), ">=", 3.0))
    for n in sizes:
        checks.append(("one-form step: separate passes around CHOLMOD / fused, N = %d" % n,
                       ratio("ChainStep_OneForm_Cholmod", "ChainStep_OneForm", n), ">=", 1.0))
    lines += ["", "| target | measured | goal | met |", "| --- | ---: | ---: | --- |"]
    for name, value, op, goal in checks:
        ok = value <= goal if op == "<=" else value >= goal
        lines.append("| %s | %.2f | %s %.1f | %s |" % (name, value, op, goal, "yes" if ok else "**no**"))
    lines += ["", "Medians of %d repetitions; %s, %s CPUs at %s MHz." % (
        args.repetitions, context.get("date", "?"), context.get("num_cpus", "?"), context.get("mhz_per_cpu", "?"))]
    md = "\n".join(lines) + "\n"
    open(os.path.join(args.out, "scaling.md"), "w").write(md)
    print(md)

    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(figsize=(7, 4.5))
    styles = ["o-", "s-", "o:", "s:", "^--", "v--", "v:", "D-", "x--", "+:"]
    for (family, label), style in zip(SERIES, styles):
        if family in t:
            ns = sorted(t[family])
            ax.loglog(ns, [t[family][n] for n in ns], style, label=label)
    ax.set_xlabel("bodies N")
    ax.set_ylabel("ns per body-step")
    ax.set_title("sleigh_chain: cost per body-step against N")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(os.path.join(args.out, "scaling.png"), dpi=110)


if __name__ == "__main__":
    main()
