#!/usr/bin/python3
"""Set-up and memory against N (issue 35): runs `nonholo run sleigh_chain --set bodies=N` in a
fresh process for each N, hitch mode and accuracy setting (20 steps, the defaults otherwise),
and records the summary's setup_s and ns_per_step with the process's peak resident memory
(/usr/bin/time's maximum RSS). Beside them, bench_setup's Setup_FirstTouch: what touching fresh
memory costs this machine (on a virtual machine most of a large set-up), in the same session.
Writes NAME.md and NAME.json into --out.

Usage: /usr/bin/python3 tools/setup_scaling.py [--nonholo build/nonholo]
           [--bench build/benchmarks/bench_setup] [--sizes 1000,10000,100000,1000000]
           [--repetitions 3] [--out docs/results] [--name setup]
Times are the minimum over the repetitions; the peak memory the largest.
"""
import argparse
import json
import os
import platform
import subprocess
import sys
import tempfile

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def run_once(nonholo, n, hitch, accuracy):
    with tempfile.NamedTemporaryFile(mode="r") as rss:
        cmd = ["/usr/bin/time", "-f", "%M", "-o", rss.name, nonholo, "run", "sleigh_chain", "--set",
               "bodies=%d" % n, "--hitch", hitch, "--t-end", "0.2"] + ([] if accuracy else ["--accuracy", "0"])
        done = subprocess.run(cmd, check=True, capture_output=True, text=True)
        peak_kb = int(rss.read().split()[-1])
    summary = dict(w.split("=", 1) for w in done.stdout.strip().splitlines()[-1].split())
    if summary["status"] != "ok":
        sys.exit("not ok: " + " ".join(cmd) + "\n" + done.stdout)
    return {"setup_s": float(summary["setup_s"]), "step_s": float(summary["ns_per_step"]) * 1e-9,
            "peak_MB": peak_kb / 1024.0, "threads": int(summary["threads"])}


def first_touch(bench):
    done = subprocess.run([bench, "--benchmark_filter=Setup_FirstTouch", "--benchmark_format=json"], check=True,
                          capture_output=True, text=True)
    rows = json.loads(done.stdout)["benchmarks"]
    return {("huge" if "/1/" in r["name"] else "4k"): (r["first_s_per_GB"], r["again_s_per_GB"]) for r in rows}


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--nonholo", default=os.path.join(ROOT, "build", "nonholo"))
    ap.add_argument("--bench", default=os.path.join(ROOT, "build", "benchmarks", "bench_setup"))
    ap.add_argument("--sizes", default="1000,10000,100000,1000000")
    ap.add_argument("--repetitions", type=int, default=3)
    ap.add_argument("--out", default=os.path.join(ROOT, "docs", "results"))
    ap.add_argument("--name", default="setup")
    args = ap.parse_args()
    sizes = [int(s) for s in args.sizes.split(",")]
    cases = [(h, a) for h in ("oneform", "holonomic") for a in (True, False)]
    results = {}
    for rep in range(args.repetitions):  # interleaved: each repetition runs every case once
        for n in sizes:
            for hitch, accuracy in cases:
                r = run_once(args.nonholo, n, hitch, accuracy)
                key = "%s/%s/%d" % (hitch, "accuracy" if accuracy else "accuracy0", n)
                best = results.setdefault(key, dict(r))
                best["setup_s"] = min(best["setup_s"], r["setup_s"])
                best["step_s"] = min(best["step_s"], r["step_s"])
                best["peak_MB"] = max(best["peak_MB"], r["peak_MB"])
                print(key, r, file=sys.stderr)
    touch = first_touch(args.bench)
    lines = ["# Set-up and memory against N", "",
             "Written by `tools/setup_scaling.py` (%s, %d processors; %d repetitions: minimum time, largest "
             "peak). `nonholo run sleigh_chain --set bodies=N --hitch H --t-end 0.2`, 20 steps, each in a "
             "fresh process: `setup_s` from its summary (to the first step: model, workspace, start, the "
             "accuracy check's shadow, outputs), the step from its `ns_per_step` (the mean of the 20 steps, "
             "with the accuracy check's dense first samples), the peak resident memory from `/usr/bin/time`." % (platform.processor() or platform.machine(), os.cpu_count(), args.repetitions),
             "",
             "| hitch | accuracy check | N | set-up s | step s | set-up / step | peak MB | bytes per body | threads |",
             "| --- | --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: |"]
    for hitch, accuracy in cases:
        for n in sizes:
            r = results["%s/%s/%d" % (hitch, "accuracy" if accuracy else "accuracy0", n)]
            lines.append("| %s | %s | %d | %.3g | %.3g | %.1f | %.0f | %.0f | %d |" % (
                hitch, "on" if accuracy else "off (`--accuracy 0`)", n, r["setup_s"], r["step_s"],
                r["setup_s"] / r["step_s"], r["peak_MB"], r["peak_MB"] * 1048576.0 / n, r["threads"]))
    lines += ["", "Fresh memory on this machine (`bench_setup`'s `Setup_FirstTouch`, the same session): "
              "%.2f s per GB written for the first time with 4 kB pages, %.2f s with huge pages asked for; "
              "%.3f s per GB written again." % (touch["4k"][0], touch["huge"][0], touch["huge"][1]), ""]
    os.makedirs(args.out, exist_ok=True)
    with open(os.path.join(args.out, args.name + ".md"), "w") as f:
        f.write("\n".join(lines))
    with open(os.path.join(args.out, args.name + ".json"), "w") as f:
        json.dump({"runs": results, "first_touch_s_per_GB": touch}, f, indent=1)
    print("\n".join(lines))


if __name__ == "__main__":
    main()
