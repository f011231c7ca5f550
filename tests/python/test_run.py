"""nonholo.run / batch / scenes against the command-line tool (NONHOLO_CLI, set by CTest): the
same numbers to the last digit, the same messages, the same failures."""
import os
import pathlib
import signal
import re
import threading

import numpy as np
import pytest

import nonholo
from support import cli, read_csv, without_timings


def test_run_gives_the_clis_csv_to_the_last_digit(tmp_path):
    path = tmp_path / "train.csv"
    args = ["wheeled_train", "--set", "bodies=7", "--t-end", "2", "--every", "3", "--out", str(path)]
    done = cli("run", *args)
    assert done.returncode == 0, done.stderr
    r = nonholo.run("wheeled_train", set={"bodies": 7}, t_end=2, every=3)
    header, rows = read_csv(path)
    assert header == ["t"] + r.coordinates + ["energy", "energy_post", "residual"]
    table = np.array([[float(x) for x in row] for row in rows])  # shortest round trip: exact
    n = len(r.coordinates)
    assert table.shape == (r.t.shape[0], n + 4)
    assert np.array_equal(table[:, 0], r.t)
    assert np.array_equal(table[:, 1:n + 1], r.q)
    assert np.array_equal(table[:, n + 1], r.energy)
    assert np.array_equal(table[:, n + 2], r.energy_post, equal_nan=True)
    assert np.array_equal(table[:, n + 3], r.residual)
    assert without_timings(r.line) == without_timings(done.stdout.strip())


def test_arrays_have_the_documented_shapes_and_types():
    r = nonholo.run("sleigh_chain", set={"bodies": 4}, t_end=1, every=10)
    frames = 1 + 100 // 10  # t_0, every 10th step (the last among them)
    assert r.t.shape == (frames,) and r.t.dtype == np.float64
    assert r.q.shape == (frames, 12) and r.q.dtype == np.float64
    for a in (r.energy, r.energy_post, r.residual):
        assert a.shape == (frames,) and a.dtype == np.float64
    assert r.coordinates[:3] == ["x0", "y0", "theta0"]
    assert r.t[0] == 0.0 and r.t[-1] == pytest.approx(1.0, abs=1e-12)
    s = r.summary
    assert s["status"] == "ok" and s["steps"] == 100 and isinstance(s["steps"], int)
    assert isinstance(s["energy_rel_err_max"], float) and s["bodies"] == 4
    # The summary's numbers are the line's before rounding to 6 digits.
    assert "energy_rel_err_max=%s" % format(s["energy_rel_err_max"], ".6g") in r.line


def test_threads_split_a_chain_as_the_tool_does():
    done = cli("run", "sleigh_chain", "--set", "bodies=30", "--hitch", "oneform", "--threads", "3", "--t-end", "1")
    assert done.returncode == 0, done.stderr
    r = nonholo.run("sleigh_chain", set={"bodies": 30}, hitch="oneform", threads=3, t_end=1)
    assert r.summary["threads"] == 3
    assert without_timings(r.line) == without_timings(done.stdout.strip())
    one = nonholo.run("sleigh_chain", set={"bodies": 30}, hitch="oneform", threads=1, t_end=1)
    assert one.summary["threads"] == 1
    assert np.allclose(r.q, one.q, rtol=0, atol=1e-12)  # round-off: another elimination order
    # Holonomic hitches (the default) too: gaps closed to gap_tolerance by either solve.
    h3 = nonholo.run("sleigh_chain", set={"bodies": 30}, threads=3, t_end=1)
    h1 = nonholo.run("sleigh_chain", set={"bodies": 30}, threads=1, t_end=1)
    assert (h3.summary["threads"], h3.summary["status"]) == (3, "ok")
    assert h3.summary["gap_max"] <= 1e-12
    assert np.allclose(h3.q, h1.q, rtol=0, atol=1e-10)
    with pytest.raises(ValueError) as e:
        nonholo.run("sleigh_chain", set={"bodies": 30}, hitch="oneform", threads=16)
    assert "threads=16 for 30 bodies: each thread needs at least 2 bodies, so at most 15" in str(e.value)


@pytest.mark.parametrize("kwargs, cli_args, cli_message, message", [
    ({"dt": -1.0}, ["--dt", "-1.0"], "--dt -1.000000: the step must be positive",
     "dt=-1.000000: the step must be positive"),
    ({"set": {"nope": 1}}, ["--set", "nope=1"], "unknown parameter 'nope' for scene 'sleigh' (parameters: m, I, a, "
     "v0, omega0, x0, y0, theta0)", None),
    ({"tol": 2.0}, ["--tol", "2.0"], "tolerance = 2 must lie in [1e-15, 1)", None),
    ({"order": 3}, ["--order", "3"], "--order/--composition: order = 3 must be 2, 4, 6 or 8",
     "order/composition: order = 3 must be 2, 4, 6 or 8"),
    ({"hitch": "rigid"}, ["--hitch", "rigid"], "unknown hitch mode 'rigid' (valid: oneform, holonomic)", None),
    ({"restart": "sometimes"}, ["--restart", "sometimes"],
     "--restart 'sometimes': expected auto, 0 (never) or a number of steps K from 1 to 1e9",
     "restart 'sometimes': expected auto, 0 (never) or a number of steps K from 1 to 1e9"),
    ({"every": 0}, ["--every", "0"], "--every 0: must be at least 1", "every=0: must be at least 1"),
    ({"restart_tol": 1e-3, "restart": 0}, ["--restart-tol", "1e-3", "--restart", "0"],
     "--restart-tol applies to --restart auto", "restart_tol applies to restart auto"),
])
def test_bad_options_raise_value_error_with_the_clis_message_in_keywords(kwargs, cli_args, cli_message, message):
    # The tool's own check and message; from Python it names the keywords (None: no flag in it).
    done = cli("run", "sleigh", *cli_args)
    assert done.returncode == 1
    assert done.stderr.strip() == "nonholo run: " + cli_message
    with pytest.raises(ValueError) as e:
        nonholo.run("sleigh", **kwargs)
    assert str(e.value) == (message or cli_message)


def test_batch_messages_name_the_keywords():
    with pytest.raises(ValueError) as e:
        nonholo.batch("sleigh", count=2, threads=0)
    assert str(e.value) == "threads=0: must be at least 1"  # the tool: --threads 0: ...
    with pytest.raises(ValueError) as e:
        nonholo.batch("sleigh", count=2, states="s.csv")
    assert str(e.value) == "states s.csv: the states are written as HDF5: name the file .h5"


def test_the_summarys_messages_name_the_keywords_and_the_line_stays_the_tools():
    # The quoted value is the caller's: kept as given, even when it looks like a flag.
    with pytest.raises(ValueError, match="^unknown method '--dt' "):
        nonholo.run("sleigh", method="--dt")
    r = nonholo.run("sleigh", dt=2.0)  # inaccurate, with a warning
    message = r.summary["message"]
    assert re.search(r"use dt=0\.[0-9]+ or smaller", message) and "accuracy=0 turns the check off" in message
    assert "reduce dt " in r.summary["warning"]
    assert not any("--" in r.summary[key] for key in ("message", "warning"))
    assert "status=inaccurate" in r.line and "--" not in r.line


def test_python_values_that_are_not_numbers_are_refused():
    with pytest.raises(ValueError, match="^dt: expected a number"):
        nonholo.run("sleigh", dt="fast")
    with pytest.raises(ValueError, match="^every: expected an integer"):  # the keyword, not the flag
        nonholo.run("sleigh", every=2.5)
    with pytest.raises(ValueError, match="unknown scene 'nope'"):
        nonholo.run("nope")


JAM = {"phi0": 1.5607963267948966, "phi_dot0": 1, "v0": 0}  # the axles align after one step


def test_a_failed_step_is_reported_in_the_summary_and_raised_on_request():
    r = nonholo.run("snakeboard", dt=0.01, set=JAM)
    assert r.status == "dependent-one-forms"
    assert "step 1 from t = 0 failed" in r.summary["message"]
    assert r.t.shape == (1,) and r.q.shape == (1, 5)  # the initial frame, kept
    with pytest.raises(nonholo.RunError, match="status=dependent-one-forms") as e:
        nonholo.run("snakeboard", dt=0.01, set=JAM, check=True)
    assert e.value.result.t.shape == (1,)


def test_an_inaccurate_run_keeps_its_frames_and_says_so():
    # A step of 2 on the sleigh: 1.8 off at t = 10 (ARKODE at 1e-12); the accuracy check's
    # estimate is above 10 % of the motion's extent.
    r = nonholo.run("sleigh", dt=2.0)
    assert r.status == "inaccurate"
    assert r.summary["error_estimate"] > 0.1 * r.summary["extent"]
    assert r.t.shape == (6,)  # every frame kept
    assert "the estimated error in q" in r.summary["message"]
    with pytest.raises(nonholo.RunError, match="status=inaccurate"):
        nonholo.run("sleigh", dt=2.0, check=True)
    assert nonholo.run("sleigh", dt=2.0, accuracy=0).status == "ok"
    assert nonholo.run("sleigh").summary["error_estimate"] < 1e-3


def test_tol_with_a_composed_order_takes_adaptive_steps_that_land_on_the_frames():
    # Against ARKODE's Fehlberg 8(7) at 1e-14 (another method): within 10 tol at every frame.
    r = nonholo.run("sleigh", order=6, tol=1e-9, dt=0.5, t_end=10)
    ref = nonholo.run("sleigh", method="arkode-fehlberg8", tol=1e-14, dt=0.5, t_end=10)
    assert r.status == "ok" and r.summary["tol"] == 1e-9
    assert r.summary["steps"] == 20 and r.summary["adaptive_steps"] > 20 and r.summary["rejected"] >= 0
    assert np.array_equal(r.t, ref.t)
    error = np.abs(r.q - ref.q).max()
    assert 1e-10 < error < 1e-8


def test_batch_gives_the_clis_table(tmp_path):
    path = tmp_path / "batch.csv"
    # m drawn in [-0.5, 1.5]: some trajectories are refused at set-up (negative mass).
    done = cli("batch", "sleigh", "--count", "12", "--vary", "m=-0.5:1.5", "--seed", "7", "--t-end", "1",
               "--threads", "2", "--out", str(path))
    assert done.returncode == 2, done.stderr
    b = nonholo.batch("sleigh", count=12, vary={"m": (-0.5, 1.5)}, seed=7, t_end=1, threads=2)
    header, rows = read_csv(path)
    assert header == list(b.columns)
    for j, name in enumerate(header):
        column = b.columns[name]
        assert column.shape == (12,)
        if name == "status":
            assert list(column) == [row[j] for row in rows]
        else:
            assert np.array_equal(column, np.array([float(row[j]) for row in rows]), equal_nan=True), name
    failed = [i for i, s in enumerate(b.columns["status"]) if s != "ok"]
    assert 0 < len(failed) < 12 and b.summary["failed"] == len(failed)
    assert all(b.messages[i] for i in failed) and not any(b.messages[i] for i in range(12) if i not in failed)
    assert without_timings(b.line) == without_timings(done.stdout.strip())
    with pytest.raises(nonholo.RunError, match="trajectory"):
        nonholo.batch("sleigh", count=12, vary={"m": (-0.5, 1.5)}, seed=7, t_end=1, check=True)


def test_scenes_lists_what_nonholo_list_prints():
    listed = cli("list").stdout
    for scene in nonholo.scenes():
        assert "%s: %s" % (scene["name"], scene["description"]) in listed
        for p in scene["parameters"]:
            assert "  %s = " % p["name"] in listed
    assert [s["name"] for s in nonholo.scenes()][:2] == ["particle", "sleigh"]


def test_ctrl_c_raises_keyboard_interrupt_with_the_frames_so_far():
    timer = threading.Timer(0.3, lambda: os.kill(os.getpid(), signal.SIGINT))
    timer.start()
    try:
        with pytest.raises(KeyboardInterrupt) as e:
            nonholo.run("sleigh_chain", set={"bodies": 2000}, t_end=1e4, every=100)
    finally:
        timer.cancel()
    r = e.value.result
    assert r.status == "interrupted"
    assert "interrupted by the caller" in r.summary["message"]
    assert 0 < r.summary["steps"] < 10**6
    assert r.t.shape[0] == r.q.shape[0] >= 1


def cpu_seconds(pid):
    """User and system CPU time a process has used (Linux /proc)."""
    fields = open("/proc/%d/stat" % pid).read().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def signal_when_ready(proc, ready, sig):
    """Polls ready() (no wall-clock wait; 120 s at most), sends sig, returns (stdout, stderr)."""
    import time
    try:
        deadline = time.monotonic() + 120
        while not ready():
            assert proc.poll() is None and time.monotonic() < deadline, proc.communicate()
            time.sleep(0.01)
        proc.send_signal(sig)
        return proc.communicate(timeout=120)
    finally:
        proc.kill()


def test_ctrl_c_stops_an_adaptive_run_inside_an_output_interval_and_it_resumes(tmp_path):
    # One output interval of a few thousand adaptive pairs (seconds here): Ctrl-C was read only
    # between intervals (a run with dt = t_end = 1e300 never stopped); now between pairs, so the
    # run stops during step 1, its state at the last pair. Its final checkpoint resumes to the
    # uninterrupted run's file, bit for bit. No wall-clock wait: SIGINT once the run has used
    # 0.2 s of CPU (its set-up takes milliseconds: it is inside the interval).
    import re
    import subprocess
    from support import CLI
    args = ["run", "sleigh_chain", "--set", "bodies=300", "--tol", "1e-4", "--dt", "100", "--t-end", "100"]
    assert cli(*args, "--out", str(tmp_path / "whole.csv")).returncode == 0
    out, checkpoint = tmp_path / "cut.csv", tmp_path / "ck.h5"
    proc = subprocess.Popen([CLI, *args, "--out", str(out), "--checkpoint", str(checkpoint)],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    stdout, stderr = signal_when_ready(proc, lambda: cpu_seconds(proc.pid) >= 0.2, signal.SIGINT)
    assert proc.returncode == 130, stdout + stderr
    assert re.search(r"interrupted \(SIGINT\) during step 1 at t = \d", stderr), stderr
    assert "status=interrupted" in stdout
    done = cli("run", "--resume", str(checkpoint))
    assert done.returncode == 0, done.stderr
    assert out.read_bytes() == (tmp_path / "whole.csv").read_bytes()


def test_a_standard_output_that_cannot_be_written_is_an_error(tmp_path):
    # stdout on /dev/full or closed: run, batch and list exited 0 with nothing said.
    import subprocess
    from support import CLI
    for args in (["list"], ["run", "sleigh", "--t-end", "0.5"], ["batch", "sleigh", "--count", "2", "--t-end", "0.5"]):
        with open("/dev/full", "w") as full:
            done = subprocess.run([CLI, *args], stdout=full, stderr=subprocess.PIPE, text=True)
        assert done.returncode == 1, (args, done.stderr)
        assert "could not write to standard output (closed, full or cut)" in done.stderr, done.stderr
        closed = subprocess.run([CLI, *args], stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True,
                                preexec_fn=lambda: os.close(1))
        assert closed.returncode == 1 and "could not write to standard output" in closed.stderr, (args, closed.stderr)


def test_sighup_ends_a_run_as_sigterm_does_with_whole_rows(tmp_path):
    # The terminal closing (SIGHUP) killed the run mid-row; now it stops between steps as on
    # SIGTERM: status interrupted, exit 130, every row of the CSV whole.
    import subprocess
    from support import CLI
    out = tmp_path / "hup.csv"
    # SIGHUP as a terminal sends it: not ignored (under nohup, as CI may run, the child would
    # inherit SIG_IGN, which the tool keeps)
    proc = subprocess.Popen([CLI, "run", "sleigh_chain", "--set", "bodies=200", "--t-end", "1e6", "--out", str(out)],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            preexec_fn=lambda: signal.signal(signal.SIGHUP, signal.SIG_DFL))
    # rows are on disk: the run is in its loop
    stdout, stderr = signal_when_ready(proc, lambda: out.exists() and out.stat().st_size > 100000, signal.SIGHUP)
    assert proc.returncode == 130, stdout + stderr
    assert "interrupted (SIGHUP)" in stderr and "status=interrupted" in stdout
    header, rows = read_csv(out)
    assert rows and all(len(r) == len(header) for r in rows)
    assert out.read_text().endswith("\n")


def test_outputs_that_would_overwrite_each_other_or_an_input_are_refused(tmp_path):
    # Compared as files, not as names: links (soft and hard) followed. Before: --out through a link
    # to the scene file overwrote it; --out b.h5 --states b.h5 lost the table.
    import shutil
    scene = tmp_path / "s.json"
    shutil.copy(pathlib.Path(__file__).parents[2] / "examples" / "scenes" / "towed_pair.json", scene)
    original = scene.read_bytes()
    os.symlink(scene, tmp_path / "soft.csv")
    os.link(scene, tmp_path / "hard.csv")
    (tmp_path / "b.h5").write_bytes(b"someone's table")
    cases = [
        (["run", str(scene), "--out", str(tmp_path / "soft.csv")], "is the scene file"),
        (["run", str(scene), "--out", str(tmp_path / "hard.csv")], "is the scene file"),
        (["run", "sleigh", "--out", str(tmp_path / "x.h5"), "--checkpoint", str(tmp_path / "." / "x.h5")],
         "are the same file"),
        (["batch", "sleigh", "--count", "2", "--out", str(tmp_path / "b.h5"), "--states", str(tmp_path / "b.h5")],
         "--out %s and --states %s are the same file" % (tmp_path / "b.h5", tmp_path / "b.h5")),
        (["batch", str(scene), "--count", "2", "--out", str(tmp_path / "soft.csv")], "is the scene file"),
    ]
    for args, words in cases:
        done = cli(*args)
        assert done.returncode == 1 and words in done.stderr, (args, done.stderr)
    assert scene.read_bytes() == original and (tmp_path / "b.h5").read_bytes() == b"someone's table"
    # nonholo view writing its page over its own input, through a link
    assert cli("run", "sleigh", "--t-end", "0.5", "--out", str(tmp_path / "in.h5")).returncode == 0
    before = (tmp_path / "in.h5").read_bytes()
    os.symlink(tmp_path / "in.h5", tmp_path / "page.html")
    done = cli("view", str(tmp_path / "in.h5"), "-o", str(tmp_path / "page.html"))
    assert done.returncode == 1 and "is the input" in done.stderr, done.stderr
    assert (tmp_path / "in.h5").read_bytes() == before


def test_an_adaptive_interval_that_could_not_end_is_refused():
    # dt = t_end = 1e300 at --tol 1e-6: 1e303 pairs at the step the tolerance asks for. It ran for
    # ever; now the first pair shows it (the fixed-step runs refuse t_end / dt above 1e12 up front).
    done = cli("run", "sleigh", "--tol", "1e-6", "--dt", "1e300", "--t-end", "1e300")
    assert done.returncode == 2
    assert "step-size-too-small" in done.stderr and "more than the 1e+12 a run may take: raise --tol" in done.stderr


def test_one_version_everywhere(tmp_path):
    # nonholo.__version__ is the library's, the tool's (--version) and the output files'.
    import re
    import h5py
    assert re.fullmatch(r"\d+\.\d+\.\d+", nonholo.__version__)
    done = cli("--version")
    assert done.returncode == 0 and done.stdout.startswith("nonholo %s (git " % nonholo.__version__)
    assert done.stdout.endswith(", %s)\n" % nonholo.__target_arch__)  # the same build's target CPU
    nonholo.run("sleigh", t_end=0.1, out=tmp_path / "v.h5")
    with h5py.File(tmp_path / "v.h5", "r") as f:
        version = f.attrs["nonholo_version"]
        assert (version.decode() if isinstance(version, bytes) else version) == nonholo.__version__



def test_the_accuracy_check_is_chosen_by_keyword():
    assert nonholo.run("sleigh").summary["accuracy_check"] == "companion"
    assert nonholo.run("sleigh", accuracy_check="sampled").summary["accuracy_check"] == "sampled"
    # a fast chaotic chain that the sampled check let through (docs/guide/methods.md "Accuracy check")
    fast = dict(set={"bodies": 20, "omega0": 50, "v0": 10}, dt=0.001, every=1000)
    assert nonholo.run("sleigh_chain", **fast).status == "inaccurate"
    assert nonholo.run("sleigh_chain", accuracy_check="sampled", **fast).status == "ok"
    with pytest.raises(ValueError, match="^accuracy_check both: auto, companion or sampled"):
        nonholo.run("sleigh", accuracy_check="both")
    b = nonholo.batch("sleigh", count=2, accuracy_check="sampled")
    assert list(b.columns["status"]) == ["ok", "ok"]
