"""The low-level API from Python (python/src/bind_*.cpp): models built from Python against
exact solutions and the C++ scenes, errors, failed steps, references and the GIL."""
import _thread
import csv
import gc
import math
import os
import pathlib
import subprocess
import sys
import threading
import tracemalloc

import numpy as np
import pytest

import nonholo
from support import chain_builder

# The paper's nonholonomic particle (docs/design.md section 5): R^3, M = I, zdot - y xdot = 0, with
# a velocity already in D (vz0 = y0 vx0) so that the exact solution's data hold as given.
X0, Y0, Z0, VX0, VY0 = 0.0, -0.5, 0.0, 1.0, 0.3
Q0, V0 = np.array([X0, Y0, Z0]), np.array([VX0, VY0, Y0 * VX0])


def particle_builder():
    b = nonholo.ModelBuilder()
    b.add_body(["x", "y", "z"], np.eye(3))
    b.add_one_form([0, 2])  # -y xdot + zdot
    b.one_form_values(lambda q: np.array([-q[1], 1.0]))
    b.one_form_bias(lambda q, v: np.array([-v[1] * v[0]]))
    return b


def particle_exact(t):
    """(q, qdot) of docs/design.md section 6: y linear, xdot sqrt(1 + y^2) = K."""
    k = VX0 * math.sqrt(1.0 + Y0 * Y0)
    y = Y0 + VY0 * t
    q = [X0 + k / VY0 * (math.asinh(y) - math.asinh(Y0)), y,
         Z0 + k / VY0 * (math.sqrt(1.0 + y * y) - math.sqrt(1.0 + Y0 * Y0))]
    xd = k / math.sqrt(1.0 + y * y)
    return np.array(q), np.array([xd, VY0, y * xd])


def started(model, **start):
    ws = nonholo.Workspace(model)
    return ws, nonholo.start_from_velocity(model, ws, 0.0, Q0, V0, **start)


def particle_error(h, t_end=10.0):
    model = particle_builder().build()
    ws, s = started(model)
    options = nonholo.RattleOptions(h)
    err = 0.0
    for _ in range(round(t_end / h)):
        assert nonholo.step(model, ws, s, options) == nonholo.Status.Ok, ws.message
        q, v = particle_exact(s.t)
        err = max(err, np.linalg.norm(s.q - q), np.linalg.norm(s.p - v))  # p = M v, M = I
    return err


def test_particle_is_second_order_against_its_exact_solution():
    # The global error of a second-order method is C h^2: halving h divides it by 4.
    e1, e2 = particle_error(0.01), particle_error(0.005)
    order = math.log2(e1 / e2)
    print(f"particle T=10: error(h=0.01) = {e1:.6g}, error(h=0.005) = {e2:.6g}, observed order {order:.4f}")
    assert 1.9 <= order <= 2.1
    assert e1 < 1e-3


def test_particle_post_momentum_energy_is_exact():
    # f = 0: the post-momentum's energy is an invariant of the scheme (to round-off), the energy
    # of the average momentum p~ only converges at order 2; the constraint on p~ holds exactly.
    model = particle_builder().build()
    ws, s = started(model)
    h = 0.01
    options = nonholo.RattleOptions(h)
    first = nonholo.diagnose(model, ws, s, h)
    post_err = energy_err = residual = 0.0
    for _ in range(2000):
        assert nonholo.step(model, ws, s, options) == nonholo.Status.Ok, ws.message
        d = nonholo.diagnose(model, ws, s, h)
        post_err = max(post_err, abs(d.energy_post - first.energy_post) / first.energy_post)
        energy_err = max(energy_err, abs(d.energy - first.energy) / first.energy)
        residual = max(residual, d.residual)
    assert post_err <= 1e-14
    assert residual <= 1e-14
    assert d.gap == 0.0
    assert 1e-8 < energy_err < 1e-4


def cli():
    path = os.environ.get("NONHOLO_CLI") or pathlib.Path(nonholo.__file__).parents[2] / "nonholo"
    if not pathlib.Path(path).is_file():
        pytest.skip("the command-line tool is not built (set NONHOLO_CLI)")
    return str(path)


def test_particle_from_python_matches_the_cpp_scene_to_the_last_digit(tmp_path):
    # The same model, options and start through the scene and the CLI: the same floating-point
    # operations, so the CSV's 17 digits agree exactly.
    out = tmp_path / "particle.csv"
    sets = [f"--set={k}={v!r}" for k, v in dict(x0=X0, y0=Y0, z0=Z0, vx0=VX0, vy0=VY0, vz0=V0[2]).items()]
    subprocess.run([cli(), "run", "particle", "--dt", "0.01", "--t-end", "2", "--out", str(out), *sets],
                   check=True, capture_output=True)
    with open(out) as f:
        rows = [{k: float(v) for k, v in row.items()} for row in csv.DictReader(f)]
    model = particle_builder().build()
    ws, s = started(model)
    options = nonholo.RattleOptions(0.01)
    assert len(rows) == 201
    for k, row in enumerate(rows):
        if k > 0:
            assert nonholo.step(model, ws, s, options) == nonholo.Status.Ok, ws.message
        d = nonholo.diagnose(model, ws, s, 0.01)
        assert [s.t, *s.q, d.energy, d.energy_post] == \
            [row[c] for c in ("t", "x", "y", "z", "energy", "energy_post")], f"row {k}"


def test_state_arrays_are_fresh_read_only_float64_copies():
    model = particle_builder().build()
    assert (model.num_coordinates, model.num_one_forms, model.num_one_form_values) == (3, 1, 2)
    assert model.coordinate_names == ["x", "y", "z"]
    assert model.one_form_columns() == [[0, 2]]
    assert model.calls_python and model.has_analytic_bias and not model.has_elements
    np.testing.assert_array_equal(model.mass_block(0), np.eye(3))
    np.testing.assert_array_equal(model.one_form_values(np.array([0.0, 2.0, 0.0])), [-2.0, 1.0])
    ws, s = started(model)
    for name, size in (("q", 3), ("p", 3), ("lam", 1), ("force", 3)):
        a = getattr(s, name)
        assert isinstance(a, np.ndarray) and a.dtype == np.float64 and a.shape == (size,), name
        assert not a.flags.writeable
        assert getattr(s, name) is not a
    assert isinstance(s.t, float) and s.steps == 0 and s.restarts == 0
    with pytest.raises(ValueError):
        s.q[0] = 1.0  # read-only: the write would be lost
    before = s.q
    assert nonholo.step(model, ws, s, nonholo.RattleOptions(0.1)) == nonholo.Status.Ok
    np.testing.assert_array_equal(before, Q0)  # a copy taken before the step is not changed by it
    assert not np.array_equal(s.q, before)
    assert s.steps == 1 and s.t == 0.1
    np.testing.assert_array_equal(s.post_momentum(0.1), s.p + 0.05 * s.force)
    # Whole arrays are copied in; copies of the state are independent.
    saved = s.copy()
    s.q = [1.0, 2.0, 3.0]
    np.testing.assert_array_equal(s.q, [1.0, 2.0, 3.0])
    assert not np.array_equal(saved.q, s.q) and saved.steps == 1
    with pytest.raises(ValueError, match="expected a 1-D array of 3 values"):
        s.p = np.zeros(4)
    assert math.isnan(s.target_energy)


def test_a_pickled_state_steps_on_as_the_original():
    # Every field goes through pickle (the time grid and the restart schedule too): 30 steps,
    # pickle, 30 more, against 60 without; bit for bit, q, p, lam, force, t and the counters.
    import pickle
    model = particle_builder().build()
    options = nonholo.RattleOptions(0.05)
    ws, s = started(model)
    for _ in range(30):
        assert nonholo.step(model, ws, s, options) == nonholo.Status.Ok
    back = pickle.loads(pickle.dumps(s))
    ws2 = nonholo.Workspace(model)
    for _ in range(30):
        assert nonholo.step(model, ws, s, options) == nonholo.Status.Ok
        assert nonholo.step(model, ws2, back, options) == nonholo.Status.Ok
    for name in ("q", "p", "lam", "force"):
        assert np.array_equal(getattr(s, name).view(np.uint64), getattr(back, name).view(np.uint64)), name
    assert (back.t, back.steps, back.restarts) == (s.t, s.steps, s.restarts)
    with pytest.raises(ValueError, match="not a pickled nonholo.State"):
        nonholo.State.__new__(nonholo.State).__setstate__((2,))


PICKLE_EVERY_PROTOCOL = """
import pickle, sys
import numpy as np
import nonholo
b = nonholo.ModelBuilder()
b.add_planar_body(["x", "y", "theta"], 1.0, 0.5)
b.add_knife_edge(0)
model = b.build()
ws = nonholo.Workspace(model)
s = nonholo.start_from_velocity(model, ws, 0.0, [0.0, 0.0, 0.3], [1.0, 0.0, 0.5])
options = nonholo.RattleOptions(0.02, order=6, composition="blanes-moan6", restart="7", hitch="oneform",
                                gap_tolerance=3e-13, rotation="exponential")
for protocol in range(pickle.HIGHEST_PROTOCOL + 1):
    back = pickle.loads(pickle.dumps(s, protocol))
    assert all(np.array_equal(getattr(s, k).view(np.uint64), getattr(back, k).view(np.uint64))
               for k in ("q", "p", "lam", "force")), protocol
    assert (back.t, back.steps, repr(back)) == (s.t, s.steps, repr(s))
    o = pickle.loads(pickle.dumps(options, protocol))
    assert all(getattr(o, k) == getattr(options, k) for k in ("h",) + nonholo._RATTLE_KEYWORDS), protocol
    assert pickle.loads(pickle.dumps(nonholo.Status.GapNotConverged, protocol)) == nonholo.Status.GapNotConverged
    for thing, words in ((ws, "nonholo.Workspace(model)"), (model, "build it again"), (b, "build the model"),
                         (nonholo.diagnose(model, ws, s, 0.02), "keep its fields")):
        try:
            pickle.dumps(thing, protocol)
            sys.exit("pickled a %s at protocol %d" % (type(thing).__name__, protocol))
        except TypeError as e:
            assert "cannot pickle a nonholo.%s" % type(thing).__name__ in str(e) and words in str(e), str(e)
print("every protocol:", pickle.HIGHEST_PROTOCOL + 1)
"""


def test_pickling_works_or_refuses_at_every_protocol():
    # Protocols 0 and 1 aborted the interpreter (rc 134) on a State or RattleOptions: in a child
    # process, so that an abort fails the test instead of ending the run.
    import subprocess
    import sys
    done = subprocess.run([sys.executable, "-c", PICKLE_EVERY_PROTOCOL], capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stdout + done.stderr
    assert "every protocol: 6" in done.stdout


def test_status_and_options():
    assert nonholo.Status.Ok.text == "ok"
    assert nonholo.Status.CallbackFailed.text == "callback-failed"
    assert nonholo.Status.NearlyDependentOneForms.text == "nearly-dependent-one-forms"
    o = nonholo.RattleOptions(0.05, hitch="oneform", restart="25", order=4, composition="triple-jump",
                              monitor_every=3, restart_tolerance=1e-6)
    assert (o.h, o.hitch, o.restart, o.order, o.composition, o.monitor_every, o.restart_tolerance) == \
        (0.05, "oneform", "25", 4, "triple-jump", 3, 1e-6)
    o.restart = "0"
    o.h = 0.02
    assert (o.restart, o.h) == ("0", 0.02)
    d = nonholo.RattleOptions()
    assert (d.h, d.hitch, d.restart, d.order, d.composition) == (0.01, "holonomic", "auto", 2, "auto")
    assert "RattleOptions(h=0.01" in repr(d)


@pytest.mark.parametrize("kwargs, message", [
    (dict(h=-1.0), "step size h = -1 must be positive and finite"),
    (dict(hitch="rigid"), "rigid"),
    (dict(restart="often"), "restart 'often': expected auto, 0 (never) or a number of steps K"),
    (dict(order=5), "order = 5 must be 2, 4, 6 or 8"),
    (dict(order=4, composition="yoshida7"), "yoshida7"),
    (dict(gap_tolerance=0.0), "gap_tolerance = 0 must be positive and finite"),
    (dict(restart="auto", monitor_every=0), "monitor_every = 0 must be at least 1 with RestartMode::Auto"),
])
def test_bad_options_raise_value_error_with_the_library_message(kwargs, message):
    with pytest.raises(ValueError, match=message.replace("(", r"\(").replace(")", r"\)")):
        nonholo.RattleOptions(**kwargs)


def test_a_bad_assignment_to_an_option_raises_and_changes_nothing():
    o = nonholo.RattleOptions(0.01)
    with pytest.raises(ValueError, match="step size h = 0 must be positive"):
        o.h = 0.0
    with pytest.raises(ValueError, match="monitor_every"):
        o.monitor_every = 0  # with restart 'auto'
    assert (o.h, o.monitor_every) == (0.01, 8)


def test_set_up_errors_raise_value_error_with_the_library_message():
    b = nonholo.ModelBuilder()
    with pytest.raises(ValueError, match=r"body 0 \(a, b\): mass block is not positive definite"):
        b.add_body(["a", "b"], [[1.0, 2.0], [2.0, 1.0]])
    with pytest.raises(ValueError, match=r"mass block is 2x2, expected 3x3"):
        b.add_body(["x", "y", "z"], np.eye(2))
    with pytest.raises(ValueError, match="expected 3 coordinate names"):
        b.add_planar_body(["x", "y"], 1.0, 1.0)
    with pytest.raises(ValueError, match="mass m = -1 must be positive"):
        b.add_planar_body(["x", "y", "theta"], -1.0, 1.0)
    with pytest.raises(TypeError, match="expected a callable"):
        b.one_form_values(3.0)
    b.add_body(["x", "y", "z"], np.eye(3))
    b.add_one_form([0, 7])
    b.one_form_values(lambda q: [0.0, 1.0])
    with pytest.raises(ValueError, match="column 7 is out of range"):
        b.build()
    model = particle_builder().build()
    with pytest.raises(ValueError, match="backend 'fast'"):
        nonholo.Workspace(model, "fast")
    ws = nonholo.Workspace(model)
    with pytest.raises(ValueError, match="start: expected 3 entries in q0"):
        nonholo.start_from_velocity(model, ws, 0.0, [0.0, 1.0], V0)
    with pytest.raises(ValueError, match="another model"):
        nonholo.start_from_velocity(particle_builder().build(), ws, 0.0, Q0, V0)
    # Mismatched pairs: a status from step(), ValueError from the others.
    other = chain_builder(2).build()
    other_ws = nonholo.Workspace(other)
    other_state = chain_start(other, other_ws)
    s = nonholo.start_from_velocity(model, ws, 0.0, Q0, V0)
    assert nonholo.step(model, other_ws, s, nonholo.RattleOptions()) == nonholo.Status.WorkspaceMismatch
    assert nonholo.step(model, ws, other_state, nonholo.RattleOptions()) == nonholo.Status.SizeMismatch
    assert "state sizes" in ws.message
    with pytest.raises(ValueError, match="another model"):
        nonholo.diagnose(model, other_ws, s, 0.01)
    with pytest.raises(ValueError, match="does not have the model's sizes"):
        nonholo.diagnose(model, ws, other_state, 0.01)


def raising_particle(fail):
    """The particle whose one-form callback raises while fail() says so."""
    b = particle_builder()

    def values(q):
        if fail():
            raise ZeroDivisionError(f"no one-forms at y = {q[1]}")
        return np.array([-q[1], 1.0])
    b.one_form_values(values)
    return b.build()


def test_a_python_callback_that_raises_fails_the_step_and_leaves_the_state():
    failing = False
    model = raising_particle(lambda: failing)
    ws, s = started(model)
    options = nonholo.RattleOptions(0.01)
    assert nonholo.step(model, ws, s, options) == nonholo.Status.Ok
    before = (s.t, s.q, s.p, s.lam, s.force, s.steps)
    failing = True
    assert nonholo.step(model, ws, s, options) == nonholo.Status.CallbackFailed
    assert "one_form_values(q) raised ZeroDivisionError: no one-forms at y = -0.49" in ws.message
    after = (s.t, s.q, s.p, s.lam, s.force, s.steps)
    for x, y in zip(before, after):
        np.testing.assert_array_equal(x, y)
    assert nonholo.steps(model, ws, s, options, 5) == nonholo.Status.CallbackFailed and s.steps == 1
    failing = False  # the failed step can be retried
    assert nonholo.step(model, ws, s, options) == nonholo.Status.Ok and s.steps == 2


def test_a_callback_that_raises_in_a_set_up_call_raises_its_own_exception():
    model = raising_particle(lambda: True)
    with pytest.raises(ZeroDivisionError, match="no one-forms"):
        started(model)


@pytest.mark.parametrize("result, message", [
    (lambda q: np.array([-q[1], 1.0, 0.0]), "one_form_values(q) returned an array of shape (3,), expected 2 values"),
    (lambda q: np.array([[-q[1], 1.0]]), "one_form_values(q) returned an array of shape (1, 2), expected 2 values"),
    (lambda q: None, "one_form_values(q) returned None, expected 2 values"),
    (lambda q: "mu", "one_form_values(q) returned str, not an array of numbers"),
])
def test_a_callback_result_of_the_wrong_size_fails_the_step_clearly(result, message):
    ok = True
    b = particle_builder()
    b.one_form_values(lambda q: np.array([-q[1], 1.0]) if ok else result(q))
    model = b.build()
    ws, s = started(model)
    q = s.q
    ok = False
    assert nonholo.step(model, ws, s, nonholo.RattleOptions(0.01)) == nonholo.Status.CallbackFailed
    assert ws.message.startswith("a model callback threw: " + message)
    np.testing.assert_array_equal(s.q, q)
    with pytest.raises(ValueError, match=message.replace("(", r"\(").replace(")", r"\)")):
        started(model)


def test_other_callbacks_report_their_own_name():
    b = particle_builder()
    b.potential(lambda q: "high", lambda q: np.zeros(3))
    model = b.build()
    ws = nonholo.Workspace(model)
    s = nonholo.start_from_velocity(model, ws, 0.0, Q0, V0)  # the gradient alone is needed here
    assert nonholo.step(model, ws, s, nonholo.RattleOptions(0.01)) == nonholo.Status.Ok
    with pytest.raises(ValueError, match="potential value\\(q\\) returned str, not a number"):
        nonholo.diagnose(model, ws, s, 0.01)
    b = particle_builder()
    b.external_force(lambda t, q: np.zeros(2))
    model = b.build()
    ws = nonholo.Workspace(model)
    with pytest.raises(ValueError, match=r"external_force\(t, q\) returned an array of shape \(2,\), expected 3"):
        nonholo.start_from_velocity(model, ws, 0.0, Q0, V0)


def test_potential_force_and_momentum_map_from_python():
    # A particle in R^2 on a spring, pushed along x: no one-forms; its momentum map is p_y.
    b = nonholo.ModelBuilder()
    b.add_body(["x", "y"], 2.0 * np.eye(2))
    b.potential(lambda q: 0.5 * q @ q, lambda q: q)
    b.external_force(lambda t, q: np.array([math.cos(t), 0.0]))
    b.momentum_map("p_y", lambda q, p: p[1])
    model = b.build()
    assert model.has_potential and model.has_external_force and model.momentum_map_names == ["p_y"]
    ws = nonholo.Workspace(model)
    s = nonholo.start_from_velocity(model, ws, 0.0, [1.0, 0.0], [0.0, 0.5])
    np.testing.assert_array_equal(nonholo.momentum_maps(model, s), [1.0])
    assert nonholo.steps(model, ws, s, nonholo.RattleOptions(0.01), 100) == nonholo.Status.Ok
    assert s.t == pytest.approx(1.0)
    # M qdd = -q + F: the y motion is 2 ydd = -y, y = 0.5 sqrt(2) sin(t / sqrt(2)).
    assert s.q[1] == pytest.approx(0.5 * math.sqrt(2.0) * math.sin(1.0 / math.sqrt(2.0)), abs=1e-4)
    assert nonholo.diagnose(model, ws, s, 0.01).energy > 0.0


def test_start_from_two_points_lands_on_the_second_point():
    model = particle_builder().build()
    ws = nonholo.Workspace(model)
    h = 0.01
    q1 = Q0 + h * V0  # (q1 - q0) in D(q0): (q0, q1) is in M0
    s = nonholo.start_from_two_points(model, ws, 0.0, Q0, q1, h)
    assert nonholo.step(model, ws, s, nonholo.RattleOptions(h)) == nonholo.Status.Ok
    np.testing.assert_allclose(s.q, q1, rtol=0, atol=1e-15)
    with pytest.raises(ValueError, match="start"):
        nonholo.start_from_two_points(model, ws, 0.0, Q0, Q0 + [0.01, 0.0, 0.01], h)


def test_no_reference_leaks_over_ten_thousand_steps():
    out = np.zeros(1)  # returned by the bias callback at every call: handed back, not kept

    def bias(q, v):
        out[0] = -v[1] * v[0]
        return out
    values = lambda q: np.array([-q[1], 1.0])  # noqa: E731
    b = nonholo.ModelBuilder()
    b.add_body(["x", "y", "z"], np.eye(3))
    b.add_one_form([0, 2])
    b.one_form_values(values)
    b.one_form_bias(bias)
    model = b.build()
    ws, s = started(model)
    options = nonholo.RattleOptions(0.001)
    refs = lambda: (sys.getrefcount(values), sys.getrefcount(bias), sys.getrefcount(out), sys.getrefcount(model),  # noqa: E731
                    sys.getrefcount(ws), sys.getrefcount(s), sys.getrefcount(options))

    def run(n):
        for _ in range(n):
            assert nonholo.step(model, ws, s, options) == nonholo.Status.Ok
            s.q, s.p  # noqa: B018: the copies handed out are freed
        nonholo.diagnose(model, ws, s, 0.001)

    run(100)
    gc.collect()
    before = refs()
    tracemalloc.start()
    start, _ = tracemalloc.get_traced_memory()
    run(10000)
    gc.collect()
    end, _ = tracemalloc.get_traced_memory()
    tracemalloc.stop()
    assert refs() == before
    assert end - start < 10000  # bytes: nothing kept per step (10^4 steps)


def test_no_leaks_when_callbacks_fail_or_models_go():
    # A failed step keeps nothing of the exception (its traceback holds the callback's frame,
    # and so `payload`), and a model lets go of its callables when it is dropped.
    payload = np.zeros(1000)
    failing = False

    def bias(q, v):
        if failing:
            raise RuntimeError(f"bias of {payload.size}")
        return np.array([-v[1] * v[0]])
    before = sys.getrefcount(bias), sys.getrefcount(payload)
    b = particle_builder()
    b.one_form_bias(bias)
    model = b.build()  # shares the builder's reference
    assert sys.getrefcount(bias) == before[0] + 1
    del b
    ws, s = started(model)
    options = nonholo.RattleOptions(0.01)
    failing = True
    tracemalloc.start()
    start, _ = tracemalloc.get_traced_memory()
    for _ in range(10000):
        assert nonholo.step(model, ws, s, options) == nonholo.Status.CallbackFailed
    gc.collect()
    end, _ = tracemalloc.get_traced_memory()
    tracemalloc.stop()
    assert ws.message == "a model callback threw: one_form_bias(q, qdot) raised RuntimeError: bias of 1000"
    assert end - start < 10000 and s.steps == 0
    assert (sys.getrefcount(bias), sys.getrefcount(payload)) == (before[0] + 1, before[1])
    del model, ws, s
    gc.collect()
    assert (sys.getrefcount(bias), sys.getrefcount(payload)) == before


def chain_start(model, ws):
    n = model.num_bodies
    q0 = np.zeros(3 * n)
    q0[0::3] = -1.0 * np.arange(n)  # hitches closed: x_{i+1} = x_i - d - f
    return nonholo.start_from_velocity(model, ws, 0.0, q0, np.tile([1.0, 0.0, 0.0], n))


def test_an_open_hitch_at_the_start_is_refused():
    # A gap of 6 was accepted, and the first step then advised a smaller step (scene files refuse
    # it). Refused, naming the hitch; max_gap=inf lets the first step close it, as before.
    model = chain_builder(4).build()
    ws = nonholo.Workspace(model)
    q0 = np.zeros(12)
    q0[0::3] = -1.0 * np.arange(4)
    q0[6] -= 6.0  # body 2 six lengths behind its hitch
    v0 = np.tile([1.0, 0.0, 0.0], 4)
    with pytest.raises(ValueError, match=r"open at q0: one-form row 4 \(the hitch with rear body 1 and front body 2, "
                                         r"its x row\) has gap 6,"):
        nonholo.start_from_velocity(model, ws, 0.0, q0, v0)
    q0[6] += 6.0 - 1e-12  # round-off of a placement: accepted
    nonholo.start_from_velocity(model, ws, 0.0, q0, v0)
    q0[6] -= 1e-3
    s = nonholo.start_from_velocity(model, ws, 0.0, q0, v0, max_gap=float("inf"))
    assert nonholo.step(model, ws, s, nonholo.RattleOptions(0.01)) == nonholo.Status.Ok, ws.message


def test_a_model_says_what_makes_its_steps_slow():
    # Knife edges first, then hitches (a natural pair of loops): a chain, but not in the order the
    # fused step reads, so it took the general path (3.4x slower per body-step measured, 2000
    # bodies) and said nothing. Now performance_note names the row and the order; the motion is
    # the same (an independent check that the two are one model). A hub hitched to 130 bodies
    # (260 rows on it: a dense block of C) says its cost.
    n = 12
    b = nonholo.ModelBuilder()
    for i in range(n):
        b.add_planar_body([f"x{i}", f"y{i}", f"theta{i}"], 1.0, 0.1)
    for i in range(n):
        b.add_knife_edge(i, a=0.1)
    for i in range(n - 1):
        b.add_hitch(i, i + 1, 0.5, 0.5)
    b.add_thrust(0, force=1.0, torque=0.2)
    loops, chain = b.build(), chain_builder(n).build()
    assert chain.is_chain and chain.performance_note == ""
    assert not loops.is_chain
    assert ("make a chain, but not in the order the fused chain step reads (the hitch from body 0 comes after "
            "rows of body 11)") in loops.performance_note
    assert "add body b's knife edge, then the hitch with rear body b and front body b + 1" in loops.performance_note
    final = []
    for model in (loops, chain):
        ws = nonholo.Workspace(model)
        s = chain_start(model, ws)
        assert nonholo.steps(model, ws, s, nonholo.RattleOptions(0.01), 300) == nonholo.Status.Ok, ws.message
        final.append(s.q.copy())
    assert np.max(np.abs(final[0] - final[1])) < 1e-11
    star = nonholo.ModelBuilder()
    for i in range(131):
        star.add_planar_body([f"x{i}", f"y{i}", f"theta{i}"], 1.0, 0.1)
    for i in range(1, 131):
        star.add_hitch(i, 0, 0.5, 0.5)
    note = star.build().performance_note
    assert "body 0 is touched by 260 constraint rows" in note and "a dense 260 x 260 block" in note
    assert "make a chain" not in note
    # One hitch fewer on the hub: under the threshold of 256 rows, nothing said.
    star = nonholo.ModelBuilder()
    for i in range(128):
        star.add_planar_body([f"x{i}", f"y{i}", f"theta{i}"], 1.0, 0.1)
    for i in range(1, 128):
        star.add_hitch(i, 0, 0.5, 0.5)
    assert star.build().performance_note == ""


def test_steps_without_the_gil_matches_repeated_step_on_an_element_chain():
    model = chain_builder(8).build()
    assert model.has_elements and model.is_chain and not model.calls_python
    assert (model.num_one_forms, model.num_holonomic) == (8 + 2 * 7, 14)
    ws1, ws2 = nonholo.Workspace(model), nonholo.Workspace(model)
    s1, s2 = chain_start(model, ws1), chain_start(model, ws2)
    assert ws1.backend == "banded"
    options = nonholo.RattleOptions(0.01)
    for _ in range(2000):
        assert nonholo.step(model, ws1, s1, options) == nonholo.Status.Ok, ws1.message
    assert nonholo.steps(model, ws2, s2, options, 2000) == nonholo.Status.Ok, ws2.message
    assert (s1.t, s1.steps, s1.restarts) == (s2.t, s2.steps, s2.restarts)
    for name in ("q", "p", "lam", "force"):
        np.testing.assert_array_equal(getattr(s1, name), getattr(s2, name), err_msg=name)
    d = nonholo.diagnose(model, ws2, s2, 0.01)
    assert d.gap < 1e-12 and d.residual < 1e-12
    # A thrust given as a Python callable makes the same model call Python, with the same steps.
    callable_model = chain_builder(8, thrust=lambda t: 1.0).build()
    assert callable_model.calls_python
    ws3 = nonholo.Workspace(callable_model)
    s3 = chain_start(callable_model, ws3)
    assert nonholo.steps(callable_model, ws3, s3, options, 2000) == nonholo.Status.Ok
    np.testing.assert_array_equal(s3.q, s1.q)


def test_a_chain_built_in_python_steps_on_threads():
    # WorkspaceOptions.threads from Python: an element chain's step on 3 threads is the
    # one-thread step to round-off (another elimination order), in both hitch modes.
    model = chain_builder(12).build()
    ws1, ws3 = nonholo.Workspace(model), nonholo.Workspace(model, threads=3)
    assert (ws1.threads, ws3.threads) == (1, 3)
    s1, s3 = chain_start(model, ws1), chain_start(model, ws3)
    options = nonholo.RattleOptions(0.01, hitch="oneform")
    assert nonholo.steps(model, ws1, s1, options, 500) == nonholo.Status.Ok, ws1.message
    assert nonholo.steps(model, ws3, s3, options, 500) == nonholo.Status.Ok, ws3.message
    np.testing.assert_allclose(s3.q, s1.q, rtol=0, atol=1e-11)
    np.testing.assert_allclose(s3.p, s1.p, rtol=0, atol=1e-11)
    # Holonomic hitches: the gap corrections on the threads too; the gaps closed as on one.
    holonomic = nonholo.RattleOptions(0.01, hitch="holonomic")
    h1, h3 = chain_start(model, ws1), chain_start(model, ws3)
    assert nonholo.steps(model, ws1, h1, holonomic, 500) == nonholo.Status.Ok, ws1.message
    assert nonholo.steps(model, ws3, h3, holonomic, 500) == nonholo.Status.Ok, ws3.message
    np.testing.assert_allclose(h3.q, h1.q, rtol=0, atol=1e-10)
    assert nonholo.diagnose(model, ws3, h3, 0.01).gap <= 1e-12
    with pytest.raises(ValueError, match="at most 6 threads"):
        nonholo.Workspace(model, threads=7)
    # A thrust given as a Python callable: called on the calling thread, before the others start.
    driven = chain_builder(12, thrust=lambda t: 1.0).build()
    wd = nonholo.Workspace(driven, threads=3)
    assert wd.threads == 3
    sd = chain_start(driven, wd)
    assert nonholo.steps(driven, wd, sd, options, 500) == nonholo.Status.Ok, wd.message
    constant = chain_builder(12, thrust=1.0).build()
    wc = nonholo.Workspace(constant)
    sc = chain_start(constant, wc)
    assert nonholo.steps(constant, wc, sc, options, 500) == nonholo.Status.Ok, wc.message
    np.testing.assert_allclose(sd.q, sc.q, rtol=0, atol=1e-11)


def test_steps_lets_other_python_threads_run():
    # With the GIL held for the whole call, the main thread could not count while it runs.
    model = chain_builder(2000).build()
    ws = nonholo.Workspace(model)
    s = chain_start(model, ws)
    result = []
    worker = threading.Thread(target=lambda: result.append(
        nonholo.steps(model, ws, s, nonholo.RattleOptions(0.001), 2000)))
    counted = 0
    worker.start()
    while worker.is_alive():
        counted += 1
    worker.join()
    assert result == [nonholo.Status.Ok] and s.steps == 2000
    assert counted > 1000


def test_ctrl_c_stops_the_loop_without_the_gil():
    # steps() checks for signals every 0.1 s and stops after a whole step.
    model = chain_builder(50, thrust=None).build()
    ws = nonholo.Workspace(model)
    s = chain_start(model, ws)
    timer = threading.Timer(0.3, _thread.interrupt_main)
    timer.start()
    with pytest.raises(KeyboardInterrupt):
        nonholo.steps(model, ws, s, nonholo.RattleOptions(0.01), 10**9)
    timer.join()
    taken = s.steps
    assert 0 < taken < 10**9
    assert nonholo.step(model, ws, s, nonholo.RattleOptions(0.01)) == nonholo.Status.Ok and s.steps == taken + 1


def test_keyboard_interrupt_in_a_callback_is_raised_again():
    def values(q):
        if q[0] > 0.05:
            raise KeyboardInterrupt
        return np.array([-q[1], 1.0])
    b = particle_builder()
    b.one_form_values(values)
    model = b.build()
    ws, s = started(model)
    with pytest.raises(KeyboardInterrupt):
        nonholo.steps(model, ws, s, nonholo.RattleOptions(0.01), 100)
    assert 0 < s.steps < 100 and s.q[0] <= 0.05
    assert "KeyboardInterrupt" in ws.message
