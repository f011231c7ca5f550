"""Survey how well nonholo's built-in accuracy check judges hard runs.

Draws random "hard" cases (fast chaotic sleigh chains, light sleighs, snakeboards, ball chains),
runs each with the reflection method (default --accuracy check), runs a reference at the same
output times (ARKODE Verner 6(5), tol 1e-12, projected; if that fails: our method at --order 6
and dt/8 with --accuracy 0), and compares: true error = max over common output times of
max |q - q_ref| over the configuration columns (quaternions compared up to sign).
Each case gets a verdict: ok-right, SILENT-WRONG, caught, false-alarm or failed.

    /usr/bin/python3 tools/accuracy_survey.py --jobs 2
    /usr/bin/python3 tools/accuracy_survey.py --seeds 1 --count 3 --extra "--accuracy 0.05" --json out.json
    /usr/bin/python3 tools/accuracy_survey.py --companion 2 4 --json raw.json   # designs beside the tool's
    /usr/bin/python3 tools/accuracy_survey.py --reuse raw.json --verbose        # judged again, no runs

The tool's own check is what the runs report (status, error_estimate; --extra "--accuracy-check
sampled" surveys the sampled check). --companion K [K ...] measures designs that are not built in,
each from a companion run of the case at K dt (--accuracy 0) to the same output times and its
largest difference D from our run (the runs are of order 2): Richardson's D / (K^2 - 1); GCI's
3 D / (K^2 - 1) (Roache's factor of safety for two levels); "switch", Richardson while the
companion's own error is within THRESHOLD x extent and GCI's beyond (the tool's companion rule);
and with K = 2 and 4 together the observed-order estimate of three levels. Each is judged
against THRESHOLD x extent as the tool's check is, alone and together with the tool's check.
"""
import argparse
import concurrent.futures
import json
import math
import os
import random
import shlex
import subprocess
import tempfile

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
OUTPUT_INTERVAL = 0.1  # the reference's output interval (rounded to a whole number of our steps)
THRESHOLD = 0.1        # true error / extent above this is "wrong"


def make_cases(seed, count):
    """count random hard cases: dicts with label, scene, sets ("k=v"), dt, t_end, hitch (or None)."""
    rng = random.Random(seed)
    cases = []
    for i in range(count):
        family = i % 4
        hitch, t_end = None, 10.0
        if family == 0:  # fast chaotic chains
            scene, dt = "sleigh_chain", rng.choice([0.002, 0.001, 0.0005])
            sets = {"bodies": rng.choice([5, 10, 20, 30]), "omega0": rng.uniform(10, 60), "v0": rng.uniform(1, 10)}
            hitch = rng.choice(["oneform", "holonomic"])
        elif family == 1 and rng.random() < 0.5:  # light sleigh chains
            scene, dt = "sleigh_chain", rng.choice([0.01, 0.005])
            sets = {"bodies": rng.choice([2, 3, 5]), "a": 0, "I": 10 ** rng.uniform(-8, -3)}
        elif family == 1:  # plain sleighs, fast
            scene, dt = "sleigh", rng.choice([0.01, 0.05, 0.1])
            sets = {"v0": rng.uniform(1, 50), "omega0": rng.uniform(0, 20)}
        elif family == 2:  # snakeboards
            scene, dt = "snakeboard", rng.choice([0.01, 0.02, 0.05])
            sets = {"u_psi_amp": rng.uniform(0, 2), "u_phi_amp": rng.uniform(0, 1), "psi_dot0": rng.uniform(0, 5)}
        else:  # ball chains: no velocity parameters; the centres' speed is r |Omega|, so r (1 to 5x) is
            # the speed-like one, and uneven inertia (within the triangle inequality) makes the spins tumble
            scene, dt = "ball_chain", rng.choice([0.01, 0.02, 0.05])
            sets = {"bodies": rng.choice([3, 5, 10]), "r": rng.uniform(1, 5),
                    "I1": rng.uniform(0.3, 0.5), "I2": rng.uniform(0.3, 0.5), "I3": rng.uniform(0.3, 0.5)}
        sets = [f"{k}={v:.4g}" if isinstance(v, float) else f"{k}={v}" for k, v in sets.items()]
        label = f"s{seed}#{i} {scene} " + " ".join(sets) + f" dt={dt:g}" + (f" {hitch}" if hitch else "")
        cases.append({"label": label, "scene": scene, "sets": sets, "dt": dt, "t_end": t_end, "hitch": hitch})
    return cases


def case_args(case, dt):
    """The scene, its --set arguments and the times: --dt dt and the case's --t-end."""
    args = [case["scene"]]
    for s in case["sets"]:
        args += ["--set", s]
    return args + ["--dt", repr(dt), "--t-end", repr(case["t_end"])]


def run(cli, args, timeout):
    """Run the CLI; returns (exit code or None on timeout, summary dict, last lines of output)."""
    try:
        p = subprocess.run([cli, "run"] + args, capture_output=True, text=True, timeout=timeout)
    except subprocess.TimeoutExpired:
        return None, {"status": "timeout"}, ""
    lines = (p.stdout + "\n" + p.stderr).splitlines()
    summary = {}
    for line in lines:  # the summary line: key=value pairs, including status=
        if "status=" in line and line.split()[0].startswith("scene="):
            summary = dict(kv.split("=", 1) for kv in line.split() if "=" in kv)
    return p.returncode, summary, "\n".join(lines[-3:])


def read_q(path):
    """(times, q column names, q values) of a CSV: the columns between t and energy."""
    with open(path) as f:
        names = f.readline().strip().split(",")
    data = np.loadtxt(path, delimiter=",", skiprows=1, ndmin=2)
    last = names.index("energy")
    return data[:, 0], names[1:last], data[:, 1:last]


def true_error(ours, ref):
    """max over rows with equal t of max |q - q_ref|; quaternions (qw.. qz) up to sign. Also the row count."""
    (t, names, q), (tr, names_r, qr) = ours, ref
    assert names == names_r, (names, names_r)
    rows = []
    for i, ti in enumerate(t):
        j = int(np.argmin(np.abs(tr - ti)))
        if abs(tr[j] - ti) <= 1e-9 * max(1.0, abs(ti)):
            rows.append((i, j))
    if not rows:
        return float("nan"), 0
    i, j = map(list, zip(*rows))
    diff = np.abs(q[i] - qr[j])
    for c, name in enumerate(names):  # a quaternion and its negative are the same rotation
        if name.startswith("qw") and names[c + 1:c + 4] == ["qx" + name[2:], "qy" + name[2:], "qz" + name[2:]]:
            flip = np.abs(q[i][:, c:c + 4] + qr[j][:, c:c + 4]).max(axis=1)
            diff[:, c:c + 4] = np.minimum(diff[:, c:c + 4].max(axis=1), flip)[:, None]
    return float(diff.max()), len(rows)


def companion_differences(case, opts, every, hitch, tmp):
    """Our run again (--accuracy 0) and a companion at each K dt of --companion: {K: max over the
    output times of |q_dt - q_Kdt|}, and "2-4": that between the companions at 2 and 4 dt where
    both ran (the third level of an observed-order check); NaN where a run fails or no output
    times are common."""
    ours = os.path.join(tmp, "plain.csv")
    rc, _, _ = run(opts.cli, case_args(case, case["dt"]) + hitch + ["--accuracy", "0", "--out", ours,
                                                                   "--every", str(every)], opts.timeout)
    out, q = {}, {}
    for k in opts.companion:
        comp = os.path.join(tmp, f"companion{k}.csv")
        rck, _, _ = run(opts.cli, case_args(case, k * case["dt"]) + hitch + ["--accuracy", "0", "--out", comp,
                                                                            "--every", str(max(1, every // k))],
                        opts.timeout)
        out[k] = float("nan")
        if rc == 0 and rck == 0 and os.path.exists(comp):
            q[k] = read_q(comp)
            difference, rows = true_error(read_q(ours), q[k])
            out[k] = difference if rows else float("nan")
    if 2 in q and 4 in q:
        difference, rows = true_error(q[2], q[4])
        out["2-4"] = difference if rows else float("nan")
    return out


COMPANION_RULES = {  # a companion's difference D (our run against K dt; order p = 2) to an error estimate
    "richardson": lambda d, k, d24, ext: d / (k * k - 1),
    "gci3": lambda d, k, d24, ext: 3 * d / (k * k - 1),  # Roache's two-level factor of safety 3
    # Richardson while the companion's own error (K^p D / (K^p - 1)) is within the threshold, else GCI's 3
    "switch": lambda d, k, d24, ext: d / (k * k - 1) * (1 if k * k * d / (k * k - 1) <= THRESHOLD * ext else 3),
}


def observed_order_estimate(d12, d24):
    """Three levels (dt, 2 dt, 4 dt), Roache's GCI: the observed order from D(2,4) / D(1,2); within 0.5
    of the formal order 2, 1.25 D / (2^2 - 1); otherwise 3 D / (2^p' - 1) with p' the observed order
    capped at 2 (and at least 0.1: no convergence seen)."""
    if not (d12 > 0 and d24 > 0):
        return d12 / 3
    p_obs = math.log2(d24 / d12)
    if abs(p_obs - 2) <= 0.5:
        return 1.25 * d12 / 3
    p_use = min(2.0, max(0.1, p_obs))
    return 3 * d12 / (2 ** p_use - 1)


def survey(case, opts):
    every = max(1, round(OUTPUT_INTERVAL / case["dt"]))
    hitch = ["--hitch", case["hitch"]] if case["hitch"] else []
    res = {"label": case["label"], "case": case, "every": every}
    with tempfile.TemporaryDirectory(prefix="accuracy_survey_") as tmp:
        ours_csv, ref_csv = os.path.join(tmp, "ours.csv"), os.path.join(tmp, "ref.csv")
        rc, summary, tail = run(opts.cli, case_args(case, case["dt"]) + hitch + shlex.split(opts.extra)
                                + ["--out", ours_csv, "--every", str(every)], opts.timeout)
        res.update(rc=rc, status=summary.get("status", f"exit {rc}"), summary=summary, tail=tail)
        res["error_estimate"] = float(summary.get("error_estimate", "nan"))
        res["extent"] = float(summary.get("extent", "nan"))
        ref_ok, res["reference"] = False, "-"
        if rc in (0, 3) and not opts.no_arkode:
            rrc, rsum, rtail = run(opts.cli, case_args(case, case["dt"] * every)  # dt: the output interval
                                   + ["--method", "arkode-verner", "--tol", "1e-12", "--project",
                                      "--out", ref_csv], opts.timeout)
            ref_ok, res["reference"] = rrc == 0 and rsum.get("status") == "ok", "arkode"
            res["ref_tail"] = res["arkode_tail"] = rtail  # kept: why ARKODE failed, if it did
        if rc in (0, 3) and not ref_ok:  # fallback: ours at a small step, composed order 6, no accuracy check
            rrc, rsum, rtail = run(opts.cli, case_args(case, case["dt"] / 8) + hitch
                                   + ["--order", "6", "--accuracy", "0", "--out", ref_csv,
                                      "--every", str(8 * every)], opts.timeout)
            ref_ok, res["reference"] = rrc == 0 and rsum.get("status") == "ok", "order6"
            res["ref_tail"] = rtail
        res["true_error"], res["rows"] = float("nan"), 0
        if ref_ok and os.path.exists(ours_csv):
            res["true_error"], res["rows"] = true_error(read_q(ours_csv), read_q(ref_csv))
        if rc in (0, 3):
            res["companion"] = companion_differences(case, opts, every, hitch, tmp)
    rel = res["true_error"] / res["extent"] if res["extent"] > 0 else float("nan")
    res["rel"] = rel
    if rc not in (0, 3):
        res["verdict"] = f"failed ({res['status']})"
    elif not ref_ok:
        res["verdict"] = "failed (reference)"
    elif math.isnan(rel) or res["rows"] == 0:
        res["verdict"] = f"failed (no common rows: {res['status']})"
    elif rc == 0 and res["status"] == "ok":
        res["verdict"] = "ok-right" if rel <= THRESHOLD else "SILENT-WRONG"
    elif rc == 3 and res["status"] == "inaccurate":
        res["verdict"] = "caught" if rel > THRESHOLD else "false-alarm"
    else:
        res["verdict"] = f"failed ({res['status']})"
    return res


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, nargs="+", default=[1, 2])
    ap.add_argument("--count", type=int, default=20, help="cases per seed")
    ap.add_argument("--cli", default=os.path.join(HERE, "..", "build", "nonholo"))
    ap.add_argument("--extra", default="", help='arguments appended to our run only, e.g. "--accuracy 0.1"')
    ap.add_argument("--jobs", type=int, default=1)
    ap.add_argument("--timeout", type=float, default=300, help="seconds per command")
    ap.add_argument("--json", help="write the raw results to this file")
    ap.add_argument("--no-arkode", action="store_true", help="always use the order-6 reference (tests the fallback)")
    ap.add_argument("--companion", type=int, nargs="+", default=[], metavar="K",
                    help="also judge each case by a companion run at K dt (Richardson; see above)")
    ap.add_argument("--reuse", metavar="JSON", help="judge the raw results of an earlier --json again, running nothing")
    ap.add_argument("--verbose", action="store_true", help="each case's verdict by each companion design")
    opts = ap.parse_args()
    opts.cli = os.path.abspath(opts.cli)
    cases = [c for seed in opts.seeds for c in make_cases(seed, opts.count)]
    if opts.reuse:  # the raw results of an earlier survey, judged again (no runs)
        with open(opts.reuse) as f:
            results = json.load(f)
        for r in results:
            r["companion"] = {(int(k) if k.isdigit() else k): v for k, v in r.get("companion", {}).items()}
        opts.companion = sorted({k for r in results for k in r["companion"] if isinstance(k, int)})
    else:
        with concurrent.futures.ThreadPoolExecutor(max_workers=opts.jobs) as pool:
            results = list(pool.map(lambda c: survey(c, opts), cases))

    width = max(len(r["label"]) for r in results)
    head = f"{'label':<{width}} | {'status':<10} | {'estimate':>9} | {'true err':>9} | {'extent':>9} | " \
           f"{'true/ext':>9} | {'est/true':>9} | {'ref':<6} | verdict"
    print(head + "\n" + "-" * len(head))
    for r in results:
        ratio = r["error_estimate"] / r["true_error"] if r["true_error"] > 0 else float("nan")
        print(f"{r['label']:<{width}} | {r['status']:<10} | {r['error_estimate']:9.3g} | {r['true_error']:9.3g} | "
              f"{r['extent']:9.3g} | {r['rel']:9.3g} | {ratio:9.3g} | {r['reference']:<6} | {r['verdict']}")
    counts = {}
    for r in results:
        counts[r["verdict"]] = counts.get(r["verdict"], 0) + 1
    print("\n" + ", ".join(f"{v}: {n}" for v, n in sorted(counts.items())) + f"  (of {len(results)})")
    refs = {}
    for r in results:
        refs[r["reference"]] = refs.get(r["reference"], 0) + 1
    if opts.companion:
        judged = [r for r in results if r["verdict"].startswith(("ok", "SILENT", "caught", "false"))]

        def verdict(est, r):
            flagged = not (est <= THRESHOLD * r["extent"])  # NaN: the companion failed, which a check would report
            wrong = r["rel"] > THRESHOLD
            return "caught" if flagged and wrong else "false-alarm" if flagged else "SILENT-WRONG" if wrong else "ok-right"

        designs = {}
        for k in opts.companion:
            for name, rule in COMPANION_RULES.items():
                designs[f"{name} at {k} dt"] = lambda r, k=k, rule=rule: rule(
                    r["companion"][k], k, r["companion"].get("2-4", float("nan")), r["extent"])
        if 2 in opts.companion and 4 in opts.companion:
            designs["observed order (dt, 2 dt, 4 dt)"] = lambda r: observed_order_estimate(
                r["companion"][2], r["companion"]["2-4"])
        for name, estimate in designs.items():
            for either in (False, True):
                would = {}
                for r in judged:
                    est = estimate(r)
                    v = verdict(est, r)
                    if either and r["verdict"] in ("caught", "false-alarm"):  # the built-in check flagged it too
                        v = "caught" if r["rel"] > THRESHOLD else "false-alarm"
                    would[v] = would.get(v, 0) + 1
                    if opts.verbose and not either:
                        print(f"  {name}: {r['label']}: estimate/extent {est / r['extent']:.3g}, true/extent "
                              f"{r['rel']:.3g}: {v}")
                print(f"{name}{' or the built-in check' if either else ''}: " +
                      ", ".join(f"{v}: {n}" for v, n in sorted(would.items())))
    print("references: " + ", ".join(f"{k}: {n}" for k, n in sorted(refs.items()))
          + "  (arkode = arkode-verner tol 1e-12 --project; order6 = ours, --order 6, dt/8, --accuracy 0)")
    if opts.json:
        with open(opts.json, "w") as f:
            json.dump(results, f, indent=1, default=str)


if __name__ == "__main__":
    main()
