"""nonholo.run(model, ...) for a model built in code: the scenes' run (its checks, outputs and
checkpoints), checked against the low-level steps, the scene run of the same model, the files it
writes read back, and its refusals."""
import numpy as np
import pytest

import nonholo
from support import chain_builder, without_timings


def chain(n, thrust=None):
    """n sleighs hitched body by body, built in code (no Python callables)."""
    return chain_builder(n, thrust).build()


def chain_start(n, turn=0.3):
    q0 = np.zeros(3 * n)
    q0[0::3] = -1.0 * np.arange(n)  # hitches closed: x_{i+1} = x_i - d - f
    v0 = np.tile([1.0, 0.0, 0.0], n)
    v0[2] = turn
    return q0, v0


def test_a_model_runs_the_steps_the_library_takes():
    # The run's trajectory is the one step() gives from start_from_velocity's state with the
    # run's options (order 2, holonomic hitches, restarts "auto"): its frames to the last bit.
    model = chain(5)
    q0, v0 = chain_start(5)
    r = nonholo.run(model, q0=q0, v0=v0, dt=0.01, t_end=1.0, every=10)
    assert r.status == "ok", r.summary["message"]
    assert r.summary["scene"] == "model" and r.summary["bodies"] == 5
    assert r.coordinates == model.coordinate_names
    ws = nonholo.Workspace(model)
    state = nonholo.start_from_velocity(model, ws, 0.0, q0, v0)
    options = nonholo.RattleOptions(0.01, hitch="holonomic", restart="auto")
    assert np.array_equal(r.q[0], state.q)
    for frame in range(1, 11):
        assert nonholo.steps(model, ws, state, options, 10) == nonholo.Status.Ok
        assert np.array_equal(r.q[frame], state.q), frame
        assert np.array_equal(r.p[frame], state.p), frame


def test_a_scenes_model_runs_as_the_scene():
    scene = nonholo.build_scene("sleigh_chain", {"bodies": 6})
    a = nonholo.run("sleigh_chain", set={"bodies": 6}, t_end=2, every=5)
    b = nonholo.run(scene.model, q0=scene.q0, v0=scene.v0, dt=scene.dt, t_end=2, every=5, name="sleigh_chain")
    assert without_timings(a.line) == without_timings(b.line)
    for x, y in ((a.t, b.t), (a.q, b.q), (a.p, b.p), (a.energy, b.energy), (a.residual, b.residual)):
        assert np.array_equal(x, y)
    assert np.array_equal(a.energy_post, b.energy_post, equal_nan=True)


def test_a_start_from_a_state_and_a_later_start_time():
    model = chain(4)
    q0, v0 = chain_start(4)
    ws = nonholo.Workspace(model)
    state = nonholo.start_from_velocity(model, ws, 0.0, q0, v0)
    a = nonholo.run(model, q0=q0, v0=v0, dt=0.02, t_end=1.0)
    b = nonholo.run(model, state=state, dt=0.02, t_end=1.0)
    assert without_timings(a.line) == without_timings(b.line)
    assert np.array_equal(a.q, b.q)
    later = nonholo.run(model, q0=q0, v0=v0, t0=5.0, dt=0.02, t_end=6.0)
    assert later.summary["steps"] == 50 and later.t[0] == 5.0 and later.t[-1] == pytest.approx(6.0, abs=1e-12)
    assert np.array_equal(later.q, a.q)  # the chain has no time in it


@pytest.mark.filterwarnings("ignore::nonholo.RunWarning")  # its companion fails at 2 dt: expected
def test_a_too_large_step_is_inaccurate_and_check_raises():
    model = chain(5)
    q0, v0 = chain_start(5, turn=5.0)
    r = nonholo.run(model, q0=q0, v0=v0, dt=0.1, t_end=20)
    assert r.status == "inaccurate", r.line
    assert r.summary["error_estimate"] > 0.1 * r.summary["extent"]
    with pytest.raises(nonholo.RunError, match="status=inaccurate"):
        nonholo.run(model, q0=q0, v0=v0, dt=0.1, t_end=20, check=True)
    # And it is: off the run of steps 100 times shorter, at the same times, by more than the
    # tolerance (measured: 2.68 for a tolerance of 1.21).
    fine = nonholo.run(model, q0=q0, v0=v0, dt=0.001, t_end=20, every=100, accuracy=0)
    assert np.array_equal(fine.t.shape, r.t.shape)
    assert np.max(np.abs(fine.q - r.q)) > 0.1 * r.summary["extent"]


def test_hdf5_output_and_a_checkpoint_continued(tmp_path):
    model = chain(5, thrust=1.0)
    q0, v0 = chain_start(5)
    whole = nonholo.run(model, q0=q0, v0=v0, dt=0.01, t_end=2.0, out=str(tmp_path / "whole.h5"), name="pulled")
    assert whole.status == "ok", whole.summary["message"]
    back = nonholo.load(str(tmp_path / "whole.h5"))
    assert np.array_equal(back.q, whole.q) and np.array_equal(back.t, whole.t)
    assert back.summary["scene"] == "pulled" and back.coordinates == whole.coordinates
    # The viewer's page and an animation, from the file.
    from nonholo import _viewer
    page = _viewer.build_page(back, str(tmp_path / "whole.h5"))
    assert "pulled" in page and "x4" in page
    gif = tmp_path / "pulled.gif"
    nonholo.animate(str(tmp_path / "whole.h5"), gif, width=160)
    assert gif.stat().st_size > 1000
    # To t = 1 with a checkpoint, then on to 2 from it: the run to 2, bit for bit.
    ck = str(tmp_path / "ck.h5")
    half = nonholo.run(model, q0=q0, v0=v0, dt=0.01, t_end=1.0, checkpoint=ck, name="pulled")
    assert half.status == "ok"
    rest = nonholo.run(model, resume=ck, t_end=2.0)
    assert np.array_equal(rest.q[-1], whole.q[-1]) and np.array_equal(rest.p[-1], whole.p[-1])
    assert without_timings(rest.line) == without_timings(whole.line)
    with pytest.raises(ValueError, match="the model is not the one the checkpoint was written with"):
        nonholo.run(chain(5), resume=ck, t_end=3.0)  # no thrust: another model
    with pytest.raises(ValueError, match=r"a model built in code \(pulled\)"):
        nonholo.run(resume=ck, t_end=3.0)


def test_python_callables_run_and_a_raising_one_fails_its_step():
    b = nonholo.ModelBuilder()  # the paper's nonholonomic particle, its row in Python
    b.add_body(["x", "y", "z"], np.eye(3))
    b.add_one_form([0, 2])
    calls = []

    def row(q):
        calls.append(1)
        if len(calls) > 500:
            raise RuntimeError("enough")
        return np.array([-q[1], 1.0])

    b.one_form_values(row)
    b.one_form_bias(lambda q, v: np.array([-v[1] * v[0]]))
    model = b.build()
    r = nonholo.run(model, q0=[0, -1, 0], v0=[1, 0.2, 0], dt=0.05, t_end=100, accuracy=0)
    assert r.status == "callback-failed"
    assert "one_form_values(q) raised RuntimeError: enough" in r.summary["message"]
    assert r.t.shape[0] > 10  # the frames up to the failed step are kept


def test_refusals_name_the_keywords():
    model = chain(2)
    q0, v0 = chain_start(2)
    cases = [
        (dict(q0=q0), r"q0 and v0 \(or state=\)"),
        (dict(q0=q0, v0=v0), r"dt=0.000000: give the step"),
        (dict(q0=q0, v0=v0, dt=0.01), r"t_end: give the end time"),
        (dict(q0=q0, v0=v0, dt=0.01, t_end=1, set={"bodies": 3}), r"set: the parameters of a scene"),
        (dict(q0=q0[:4], v0=v0, dt=0.01, t_end=1), r"start: expected 6 entries in q0"),
        (dict(q0=q0, v0=v0, dt=0.01, t_end=1, t0=2), r"t_end=1 is before the start's t0 = 2"),
        (dict(q0=[[1.0]], v0=v0, dt=0.01, t_end=1), r"q0: expected a 1-D array"),
        (dict(resume="x.h5", q0=q0), r"q0 with resume"),
    ]
    for keywords, message in cases:
        with pytest.raises(ValueError, match=message):
            nonholo.run(model, **keywords)
    with pytest.raises(ValueError, match=r"q0: the start of a model built in code"):
        nonholo.run("sleigh", q0=q0)


def test_stop_conditions_find_the_exact_crossing():
    # The particle's y moves uniformly (y = t from its default start): a condition on it first
    # holds at an exact time, which the bisection on the interpolant finds, as text or callable.
    p = nonholo.build_scene("particle")
    as_text = nonholo.run(p.model, q0=p.q0, v0=p.v0, dt=0.01, t_end=10, stop="y>0.3217")
    assert as_text.status == "stopped", as_text.summary["message"]
    assert as_text.summary["stopped_by"] == "y>0.3217"
    assert abs(as_text.summary["t_stop"] - 0.3217) < 1e-13
    assert as_text.summary["steps"] == 33 and as_text.t[-1] == pytest.approx(0.33)

    def past(t, q):
        return q[1] > 0.3217

    as_call = nonholo.run(p.model, q0=p.q0, v0=p.v0, dt=0.01, t_end=10, stop=past, every=5)
    assert as_call.summary["stopped_by"] == "past"
    assert as_call.summary["t_stop"] == as_text.summary["t_stop"]  # the same bisection
    assert np.array_equal(as_call.q[-1], as_text.q[-1])  # the step that saw it is kept, whatever every
    scene = nonholo.run("particle", stop=["y>5", past])  # the scenes take them too
    assert scene.summary["stopped_by"] == "past"


def test_a_raising_stop_condition_ends_the_run_with_its_name():
    model = chain(3)
    q0, v0 = chain_start(3)

    def fussy(t, q):
        if t > 0.2:
            raise ArithmeticError("too late")
        return False

    r = nonholo.run(model, q0=q0, v0=v0, dt=0.01, t_end=1, stop=fussy)
    assert r.status == "callback-failed"
    assert "the stop condition fussy failed at t = 0.21" in r.summary["message"]
    assert "fussy(t, q) raised ArithmeticError: too late" in r.summary["message"]
    assert r.t[-1] == pytest.approx(0.21)
    r = nonholo.run(model, q0=q0, v0=v0, dt=0.01, t_end=1, stop=lambda t, q: q > 0)  # an array: no truth value
    assert r.status == "callback-failed" and "ValueError" in r.summary["message"]
    with pytest.raises(ValueError, match="stop_every: it spaces the checks of callables"):
        nonholo.run(model, q0=q0, v0=v0, dt=0.01, t_end=1, stop="x0>1", stop_every=3)
    with pytest.raises(ValueError, match="no coordinate 'x9' in the model"):
        nonholo.run(model, q0=q0, v0=v0, dt=0.01, t_end=1, stop="x9>1")


def test_progress_reports_the_time_and_fraction_and_its_exception_stops_the_run():
    calls = []
    r = nonholo.run("sleigh_chain", set={"bodies": 50}, t_end=5, every=100,
                    progress=lambda t, f: calls.append((t, f)))
    assert r.status == "ok"
    assert calls[-1] == (r.t[-1], 1.0)  # the last call: the run's end
    assert all(0.0 <= f <= 1.0 for _, f in calls)
    assert [f for _, f in calls] == sorted(f for _, f in calls)

    def tired(t, f):
        raise ZeroDivisionError("tired at %g" % t)

    with pytest.raises(ZeroDivisionError, match="tired at") as raised:
        nonholo.run("sleigh", t_end=1, progress=tired)
    assert raised.value.result.t.shape[0] >= 1  # the frames so far
    with pytest.raises(ValueError, match="progress: expected a callable"):
        nonholo.run("sleigh", progress=3)


def test_warnings_are_raised_by_kind():
    # The stiff train at dt 0.15 ends ok with a stability, an accuracy and a method warning.
    with pytest.warns(nonholo.RunWarning) as caught:
        r = nonholo.run("wheeled_train", set={"bodies": 5, "k": 50}, dt=0.15, t_end=6)
    assert r.status == "ok" and r.summary["warnings"] == "stability,accuracy,method"
    kinds = [w["kind"] for w in r.summary["warning_list"]]
    assert kinds == ["stability", "accuracy", "method"]
    assert [type(w.message) for w in caught] == [nonholo.StabilityWarning, nonholo.AccuracyWarning,
                                                 nonholo.MethodWarning]
    assert "use dt=0.0588 for accuracy" in str(caught[0].message)  # the keyword, not --dt
    assert caught[0].filename == __file__  # the caller's line
    import warnings
    with warnings.catch_warnings():
        warnings.simplefilter("error", nonholo.PerformanceWarning)
        warnings.simplefilter("ignore", nonholo.RunWarning)
        nonholo.run("wheeled_train", set={"bodies": 5, "k": 50}, dt=0.15, t_end=6)  # no performance warning


def test_a_batch_of_a_factory_is_its_trajectories_run_one_by_one():
    made = []

    def factory(params):
        made.append(params)
        q0, v0 = chain_start(3, turn=params["turn"])
        return chain(3), q0, v0

    kwargs = dict(count=5, vary={"turn": (0.0, 2.0)}, seed=7, dt=0.01, t_end=1.0, states=True, name="chains")
    one = nonholo.batch(factory, threads=1, **kwargs)
    two = nonholo.batch(factory, threads=2, **kwargs)
    assert one.summary["failed"] == 0 and one.summary["scene"] == "chains"
    assert np.array_equal(one.q, two.q) and np.array_equal(one.p, two.p)
    assert [p["turn"] for p in made[:5]] == list(one.columns["turn"])  # called with the rows' draws
    for i in range(5):
        q0, v0 = chain_start(3, turn=one.columns["turn"][i])
        r = nonholo.run(chain(3), q0=q0, v0=v0, dt=0.01, t_end=1.0, threads=1)
        assert np.array_equal(r.q[-1], one.q[i]) and np.array_equal(r.p[-1], one.p[i]), i
    with pytest.raises(ValueError, match=r"factory: trajectory 0: expected \(model, q0, v0\)"):
        nonholo.batch(lambda params: "a model", count=2, dt=0.01, t_end=1.0)
    with pytest.raises(ValueError, match="set: the parameters of a scene"):
        nonholo.batch(factory, count=2, dt=0.01, t_end=1.0, set={"bodies": 3})
    with pytest.raises(ValueError, match="t_end: give the end time"):
        nonholo.batch(factory, count=2, dt=0.01, vary={"turn": (0.0, 1.0)})


def test_the_python_guide_leads_with_a_program_that_runs(tmp_path, monkeypatch):
    # docs/guide/python.md's first block: build a model, run it, look at it.
    import pathlib
    import re
    guide = (pathlib.Path(__file__).resolve().parents[2] / "docs" / "guide" / "python.md").read_text()
    program = re.search(r"```python\n(.*?)```", guide, re.S).group(1)
    assert "nonholo.run(model" in program and len(program.splitlines()) <= 20
    monkeypatch.chdir(tmp_path)
    scope = {}
    exec(compile(program, "python.md", "exec"), scope)
    assert scope["r"].status == "ok" and scope["r"].summary["scene"] == "my_chain"
    assert (tmp_path / "chain.gif").stat().st_size > 1000
