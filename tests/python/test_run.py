"""nonholo.run / batch / scenes against the command-line tool (NONHOLO_CLI, set by CTest): the
same numbers to the last digit, the same messages, the same failures."""
import os
import signal
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
    assert "use dt=0.541 or smaller" in message and "accuracy=0 turns the check off" in message
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

