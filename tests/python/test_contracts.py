"""Python's side of the contracts (issue 23): one call at a time on a Workspace (a second thread
and a callback re-entering its own step get Status.WorkspaceBusy), Ctrl-C during batch(), and
arguments the command line would cut (NUL bytes) or answer with its own help."""
import json
import os
import signal
import subprocess
import sys
import textwrap
import threading

import numpy as np
import pytest

import nonholo
from test_core import chain_builder, chain_start

Q0, V0 = np.array([0.0, -0.5, 0.0]), np.array([1.0, 0.3, -0.5])


def hooked_particle(hook):
    """The paper's particle with a Python force that runs hook[0]() first (when set)."""
    b = nonholo.ModelBuilder()
    b.add_body(["x", "y", "z"], np.eye(3))
    b.add_one_form([0, 2])
    b.one_form_values(lambda q: np.array([-q[1], 1.0]))

    def force(t, q):
        if hook:
            hook[0]()
        return np.array([-q[0], -q[1], 0.0])

    b.external_force(force)
    return b.build()


def stepped(model, ws, s, n=200):
    for _ in range(n):
        status = nonholo.step(model, ws, s, nonholo.RattleOptions(0.01))
        if status != nonholo.Status.Ok:
            return status
    return nonholo.Status.Ok


def test_callback_stepping_its_own_workspace_is_refused_and_the_step_unaffected():
    # Before: the inner step ran on the outer step's buffers; the outer returned Ok 1.7 off.
    hook = []
    model = hooked_particle(hook)
    ws, plain_ws = nonholo.Workspace(model), nonholo.Workspace(model)
    s = nonholo.start_from_velocity(model, ws, 0.0, Q0, V0)
    plain = s.copy()
    other = nonholo.start_from_velocity(model, plain_ws, 0.0, np.array([3.0, 2.0, 1.0]), np.array([-5.0, 4.0, 9.0]))
    inner, errors = [], []

    def reenter():
        inner.append(nonholo.step(model, ws, other, nonholo.RattleOptions(0.37)))
        inner.append(nonholo.steps(model, ws, other, nonholo.RattleOptions(0.37), 3))
        for call in (lambda: nonholo.start_from_velocity(model, ws, 0.0, Q0, V0),
                     lambda: nonholo.diagnose(model, ws, other, 0.01)):
            with pytest.raises(ValueError) as e:
                call()
            errors.append(str(e.value))

    hook.append(reenter)
    assert stepped(model, ws, s) == nonholo.Status.Ok, ws.message
    hook.clear()
    assert stepped(model, plain_ws, plain) == nonholo.Status.Ok
    assert len(inner) >= 400 and set(inner) == {nonholo.Status.WorkspaceBusy}
    assert nonholo.Status.WorkspaceBusy.text == "workspace-busy"
    assert all(e.startswith("workspace-busy: ") for e in errors), errors[:2]
    np.testing.assert_array_equal(s.q, plain.q)
    np.testing.assert_array_equal(s.p, plain.p)


def test_a_busy_error_escaping_the_callback_fails_the_step():
    hook = []
    model = hooked_particle(hook)
    ws = nonholo.Workspace(model)
    s = nonholo.start_from_velocity(model, ws, 0.0, Q0, V0)
    q = s.q.copy()
    hook.append(lambda: nonholo.start_from_velocity(model, ws, 0.0, Q0, V0))
    assert nonholo.step(model, ws, s, nonholo.RattleOptions(0.01)) == nonholo.Status.CallbackFailed
    assert "workspace-busy: start_from_velocity" in ws.message
    np.testing.assert_array_equal(s.q, q)


def test_a_second_thread_is_refused_while_a_step_runs():
    # The first step waits inside its callback (the GIL released by the wait) while the main
    # thread tries the same workspace.
    inside, go = threading.Event(), threading.Event()
    hook = []
    model = hooked_particle(hook)
    ws = nonholo.Workspace(model)
    s = nonholo.start_from_velocity(model, ws, 0.0, Q0, V0)
    other = s.copy()

    def hold():
        hook.clear()
        inside.set()
        go.wait(30)

    hook.append(hold)
    result = []
    worker = threading.Thread(target=lambda: result.append(nonholo.step(model, ws, s, nonholo.RattleOptions(0.01))))
    worker.start()
    assert inside.wait(30)
    assert nonholo.step(model, ws, other, nonholo.RattleOptions(0.01)) == nonholo.Status.WorkspaceBusy
    assert nonholo.steps(model, ws, other, nonholo.RattleOptions(0.01), 5) == nonholo.Status.WorkspaceBusy
    go.set()
    worker.join()
    assert result == [nonholo.Status.Ok] and other.steps == 0
    assert nonholo.step(model, ws, other, nonholo.RattleOptions(0.01)) == nonholo.Status.Ok  # free again


def test_two_threads_stepping_one_workspace_never_both_succeed_wrongly():
    # Without the GIL (C++ callbacks only). Before: both threads ran on one workspace and ended
    # about 190 off (or failed with a gap the mixed buffers made). Now a thread either finishes
    # with exactly the serial result or is refused.
    model = chain_builder(8).build()
    n, options = 20000, nonholo.RattleOptions(0.01)
    ref_ws = nonholo.Workspace(model)
    ref = chain_start(model, ref_ws)
    assert nonholo.steps(model, ref_ws, ref, options, n) == nonholo.Status.Ok
    ws = nonholo.Workspace(model)
    states, results = [chain_start(model, ws), chain_start(model, ws)], [None, None]
    threads = [threading.Thread(target=lambda i=i: results.__setitem__(i, nonholo.steps(model, ws, states[i], options, n)))
               for i in range(2)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert set(results) <= {nonholo.Status.Ok, nonholo.Status.WorkspaceBusy}, results
    for status, s in zip(results, states):
        if status == nonholo.Status.Ok:
            np.testing.assert_array_equal(s.q, ref.q)


# --- Ctrl-C during batch() -------------------------------------------------------------------

CHILD = textwrap.dedent("""
    import json, sys, nonholo
    print("ready", flush=True)
    try:
        r = nonholo.batch("sleigh", count=4000, threads=2, t_end=2000.0)
        print(json.dumps({"returned": r.status}))
    except KeyboardInterrupt as e:
        r = e.result
        print(json.dumps({"status": r.status, "rows": list(r.columns["status"]), "t_final": list(r.columns["t_final"]),
                          "messages": r.messages, "line": r.line}))
""")


def test_ctrl_c_stops_a_batch_between_steps_and_keeps_the_finished_rows():
    # Before: the batch ran to its end (minutes here) and then raised KeyboardInterrupt without
    # any result.
    child = subprocess.Popen([sys.executable, "-c", CHILD], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                             text=True, env=os.environ.copy())
    try:
        assert child.stdout.readline().strip() == "ready"
        threading.Event().wait(3.0)  # some trajectories finish (each takes some 0.1 s)
        child.send_signal(signal.SIGINT)
        out, err = child.communicate(timeout=60)
    finally:
        if child.poll() is None:
            child.kill()
    assert child.returncode == 0, err
    d = json.loads(out.strip().splitlines()[-1])
    assert d.get("status") == "interrupted", d.get("returned")
    rows = d["rows"]
    assert len(rows) == 4000
    assert set(rows) == {"ok", "interrupted"}, set(rows)
    finished = [i for i, r in enumerate(rows) if r == "ok"]
    assert 0 < len(finished) < 4000
    assert all(d["t_final"][i] == pytest.approx(2000.0) for i in finished)
    assert all(d["messages"][i] == "" for i in finished)
    stopped = [m for r, m in zip(rows, d["messages"]) if r == "interrupted"]
    assert all("interrupted" in m for m in stopped), stopped[:2]
    assert "status=interrupted" in d["line"]


# --- arguments ---------------------------------------------------------------------------------

@pytest.mark.parametrize("call, keyword", [
    (lambda: nonholo.run("sleigh\0x"), "scene"),
    (lambda: nonholo.run("sleigh", method="reflection\0"), "method"),
    (lambda: nonholo.run("sleigh", set={"v0\0": 1.0}), "set"),
    (lambda: nonholo.run("sleigh", set=["v0=1\x002"]), "set"),
    (lambda: nonholo.run("sleigh", out="/tmp/nonholo\0.csv"), "out"),
    (lambda: nonholo.batch("sleigh", count=2, vary={"v0\0": (0.0, 1.0)}), "vary"),
])
def test_nul_bytes_are_refused_naming_the_argument(call, keyword):
    # Before: the argument was cut at the NUL and the run went on with what was left.
    with pytest.raises(ValueError, match="NUL byte") as e:
        call()
    assert str(e.value).startswith(keyword + ":"), str(e.value)


def test_nul_bytes_in_the_raw_arguments_are_refused():
    with pytest.raises(ValueError, match="NUL byte"):
        nonholo._core._run(["sleigh\0x"])


@pytest.mark.parametrize("scene", ["--help", "-h", "--help-all", "--version", "-x"])
def test_options_in_place_of_the_scene_point_to_pythons_help(scene):
    # Before: CLI11's internal text "This should be caught in your main function, see examples".
    for call, name in ((lambda: nonholo.run(scene), "run"), (lambda: nonholo.batch(scene, count=1), "batch")):
        with pytest.raises(ValueError) as e:
            call()
        assert "help(nonholo.%s)" % name in str(e.value), str(e.value)
    for raw in (nonholo._core._run, nonholo._core._batch):
        with pytest.raises(ValueError) as e:
            raw([scene] if raw is nonholo._core._run else [scene, "--count", "1"])
        assert "caught in your main" not in str(e.value)


def test_keyword_errors_name_the_keyword():
    with pytest.raises(ValueError, match="^t_end: expected a number"):
        nonholo.run("sleigh", t_end="10")
    with pytest.raises(ValueError, match="^count: expected an integer"):
        nonholo.batch("sleigh", count=1.5)
