"""3-D rigid bodies from Python (python/src/bind_model.cpp): models built with add_rigid_body and
the elements on rigid bodies, checked against invariants (the post-momentum energy, the
constraints, unit quaternions, a declared symmetry's momentum map), independent solutions
(RK4 of the Suslov top's equations, motions exact for the scheme) and the same model written
with Python callables; then the failures (h |Omega| too large, set-up mistakes, callbacks of
the wrong size) and the rotation option."""
import math
import os
import subprocess

import numpy as np
import pytest

import nonholo

# The Suslov top (README "3-D bodies"): a non-diagonal inertia, <Omega, e3> = 0.
# Its principal moments 0.869 + 1.830 < 3.301 break the triangle inequality: any_inertia=True.
SUSLOV_INERTIA = np.array([[1.0, 0.0, 0.5], [0.0, 2.0, 0.5], [0.5, 0.5, 3.0]])
SUSLOV_Q0, SUSLOV_V0 = np.array([1.0, 0.0, 0.0, 0.0]), np.array([1.0, 0.6, 0.0])


def qmul(a, b):
    """The Hamilton product a (x) b of quaternions (w, x, y, z), written out here."""
    w1, x1, y1, z1 = a
    w2, x2, y2, z2 = b
    return np.array([w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2, w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2,
                     w1 * y2 - x1 * z2 + y1 * w2 + z1 * x2, w1 * z2 + x1 * y2 - y1 * x2 + z1 * w2])


def suslov_model(python_row=False):
    b = nonholo.ModelBuilder()
    body = b.add_rigid_body(inertia=SUSLOV_INERTIA, any_inertia=True)
    if python_row:  # the same row as the element, from Python: (0, 0, 1) on the Omega columns
        b.add_one_form([0, 1, 2])
        b.one_form_values(lambda q: np.array([0.0, 0.0, 1.0]))
        b.one_form_bias(lambda q, v: np.zeros(1))
    else:
        assert b.add_body_axis_constraint(body, axis=(0, 0, 1)) == 0
    return b.build()


def suslov_start(model):
    ws = nonholo.Workspace(model)
    return ws, nonholo.start_from_velocity(model, ws, 0.0, SUSLOV_Q0, SUSLOV_V0)


def test_suslov_top_keeps_its_energy_its_constraint_and_a_unit_quaternion():
    model = suslov_model()
    assert (model.num_configuration, model.num_velocities, model.num_coordinates) == (4, 3, 3)
    assert model.has_rigid_bodies and model.has_elements and not model.calls_python
    ws, s = suslov_start(model)
    h = 0.01
    options = nonholo.RattleOptions(h)
    first = nonholo.diagnose(model, ws, s, h)
    energy_err = residual = norm_err = 0.0
    for _ in range(2000):
        assert nonholo.step(model, ws, s, options) == nonholo.Status.Ok, ws.message
        d = nonholo.diagnose(model, ws, s, h)
        energy_err = max(energy_err, abs(d.energy_post - first.energy_post) / first.energy_post)
        residual = max(residual, d.residual)
        norm_err = max(norm_err, abs(np.linalg.norm(s.q) - 1.0))
    print(f"Suslov top, 2000 steps: energy_post drift {energy_err:.3g}, residual {residual:.3g}, "
          f"|q| - 1 {norm_err:.3g}, restarts {s.restarts}, Legendre iterations {ws.legendre_iterations}")
    assert energy_err <= 1e-13
    assert residual <= 1e-14
    assert norm_err <= 1e-14
    # The constraint itself, from the state: <Omega, e3> = 0 with Omega = I^-1 p~.
    assert abs(np.linalg.solve(SUSLOV_INERTIA, s.p)[2]) <= 1e-14
    # A non-diagonal inertia: the Moser-Veselov transform is solved by Newton.
    assert 1 <= ws.legendre_iterations <= 40


def suslov_rk4(t_end, n):
    """The Suslov top's equations, I Omega' = (I Omega) x Omega + lambda e3 with lambda keeping
    Omega_3 = 0, and q' = q (x) (0, Omega) / 2, by classical RK4 (an independent solution)."""
    inverse = np.linalg.inv(SUSLOV_INERTIA)
    a = np.array([0.0, 0.0, 1.0])

    def rhs(y):
        q, w = y[:4], y[4:]
        free = inverse @ np.cross(SUSLOV_INERTIA @ w, w)
        lam = -(a @ free) / (a @ inverse @ a)
        return np.concatenate([0.5 * qmul(q, np.concatenate([[0.0], w])), free + lam * (inverse @ a)])
    y = np.concatenate([SUSLOV_Q0, SUSLOV_V0])
    h = t_end / n
    for _ in range(n):
        k1 = rhs(y)
        k2 = rhs(y + 0.5 * h * k1)
        k3 = rhs(y + 0.5 * h * k2)
        k4 = rhs(y + h * k3)
        y = y + (h / 6.0) * (k1 + 2.0 * k2 + 2.0 * k3 + k4)
    return y


@pytest.mark.parametrize("rotation", ["moser-veselov", "moser-veselov-f", "exponential"])
def test_suslov_top_is_second_order_against_rk4(rotation):
    # RK4 with h = 0.002 is exact to ~1e-13 here; the method's error at T = 5 must fall by 4
    # when h is halved, whatever the rotation's Lagrangian.
    reference = suslov_rk4(5.0, 2500)
    model = suslov_model()
    errors = []
    for h in (0.01, 0.005):
        ws, s = suslov_start(model)
        assert nonholo.steps(model, ws, s, nonholo.RattleOptions(h, rotation=rotation), round(5.0 / h)) == \
            nonholo.Status.Ok, ws.message
        assert s.t == pytest.approx(5.0, abs=1e-12)
        omega = np.linalg.solve(SUSLOV_INERTIA, s.p)
        errors.append(max(np.abs(s.q - reference[:4]).max(), np.abs(omega - reference[4:]).max()))
    order = math.log2(errors[0] / errors[1])
    print(f"Suslov top ({rotation}) against RK4 at T = 5: error {errors[0]:.4g} (h = 0.01), "
          f"{errors[1]:.4g} (h = 0.005), observed order {order:.4f}")
    assert 1.95 <= order <= 2.05
    assert errors[0] < 1e-4


def test_a_python_row_gives_the_elements_trajectory_to_the_bit():
    # The element's row is the axis itself, (0, 0, 1), with bias 0: the same numbers through
    # the same step, so the same floating-point operations (only where they come from differs).
    element, python = suslov_model(), suslov_model(python_row=True)
    assert python.calls_python and not element.calls_python
    assert python.one_form_columns() == element.one_form_columns() == [[0, 1, 2]]
    (ws1, s1), (ws2, s2) = suslov_start(element), suslov_start(python)
    options = nonholo.RattleOptions(0.01)
    for k in range(2000):
        assert nonholo.step(element, ws1, s1, options) == nonholo.Status.Ok, ws1.message
        assert nonholo.step(python, ws2, s2, options) == nonholo.Status.Ok, ws2.message
        for name in ("q", "p", "lam", "force"):
            np.testing.assert_array_equal(getattr(s1, name), getattr(s2, name), err_msg=f"{name} at step {k + 1}")
    assert s1.restarts == s2.restarts and s1.t == s2.t


def spin_generator(q):
    """The ball's spin about the vertical through its centre: Omega = gamma = R^T e3 (the third
    row of R), the centre at rest. It lies in D: the rolling rows vanish on it."""
    return np.concatenate([nonholo.quaternion_matrix(q[:4])[2], [0.0, 0.0]])


def chaplygin_ball(symmetry=True, generator=spin_generator):
    b = nonholo.ModelBuilder()
    body = b.add_rigid_body(mass=1.0, inertia=[0.3, 0.4, 0.5], translation=2)
    assert b.add_rolling_ball(body, radius=1.0) == 0
    if symmetry:
        b.symmetry("spin", generator)
    return b.build()


def ball_start(model):
    ws = nonholo.Workspace(model)
    q0 = np.concatenate([nonholo.axis_angle_quaternion([1.0, 2.0, 3.0], 0.7), [0.0, 0.0]])
    return ws, nonholo.start_from_velocity(model, ws, 0.0, q0, [1.0, 0.5, 2.0, 0.0, 0.0])


def spin_momentum(s):
    """p_Omega . gamma, computed here from the state."""
    return s.p[:3] @ nonholo.quaternion_matrix(s.q[:4])[2]


def ball_run(model, steps=2000):
    ws, s = ball_start(model)
    h = 0.01
    # Auto restarts with a tolerance below the mode's amplitude here (about 1.4e-7): every step
    # restarts, rescaling p~, which must keep the declared map.
    options = nonholo.RattleOptions(h, restart="auto", restart_tolerance=1e-9)
    j0, e0 = spin_momentum(s), nonholo.diagnose(model, ws, s, h).energy_post
    drift = energy_err = 0.0
    for _ in range(steps):
        assert nonholo.step(model, ws, s, options) == nonholo.Status.Ok, ws.message
        drift = max(drift, abs(spin_momentum(s) - j0))
        energy_err = max(energy_err, abs(nonholo.diagnose(model, ws, s, h).energy_post - e0) / e0)
    return s, j0, drift, energy_err


def test_chaplygin_ball_keeps_its_declared_spin_momentum_through_restarts():
    model = chaplygin_ball()
    assert (model.num_configuration, model.num_velocities) == (6, 5)
    assert model.velocity_names == ["wx0", "wy0", "wz0", "vx0", "vy0"]
    assert model.momentum_map_names == ["spin"] and model.calls_python
    s, j0, drift, energy_err = ball_run(model)
    print(f"Chaplygin ball, 2000 steps, {s.restarts} restarts: J = {j0:.17g}, drift {drift:.3g}, "
          f"energy_post drift {energy_err:.3g}")
    assert s.restarts >= 1000
    assert drift <= 1e-12
    assert energy_err <= 1e-13
    # The library's J = <xi(q), p~> is the same number.
    assert nonholo.momentum_maps(model, s)[0] == pytest.approx(spin_momentum(s), rel=0, abs=1e-15)
    # The ball rolls: its centre moved, the rows held.
    assert np.linalg.norm(s.q[4:]) > 1.0
    ws = nonholo.Workspace(model)
    assert nonholo.diagnose(model, ws, s, 0.01).residual <= 1e-14


def test_without_the_symmetry_the_restarts_change_the_spin_momentum():
    # The control: the same run without the declaration rescales all of p~ at each restart.
    s, j0, drift, _ = ball_run(chaplygin_ball(symmetry=False), steps=500)
    print(f"Chaplygin ball without the symmetry, 500 steps, {s.restarts} restarts: J drift {drift:.3g}")
    assert s.restarts >= 250 and drift > 1e-9


@pytest.mark.parametrize("constrained", [False, True])
def test_h_omega_beyond_one_fails_with_legendre_not_solved_and_leaves_the_state(constrained):
    b = nonholo.ModelBuilder()
    body = b.add_rigid_body(inertia=1.0)  # isotropic: the closed form, no Newton
    if constrained:
        b.add_body_axis_constraint(body, axis=(1, 0, 0))
    model = b.build()
    ws = nonholo.Workspace(model)
    s = nonholo.start_from_velocity(model, ws, 0.0, [1.0, 0.0, 0.0, 0.0], [0.0, 0.0, 150.0])
    before = (s.t, s.q, s.p, s.lam, s.force, s.steps, s.restarts)
    assert nonholo.step(model, ws, s, nonholo.RattleOptions(0.01)) == nonholo.Status.LegendreNotSolved
    assert nonholo.Status.LegendreNotSolved.text == "legendre-not-solved"
    assert "h |Omega| = 1.5 (h = 0.01, |Omega| = 150)" in ws.message
    assert "moser-veselov" in ws.message and "rigid body 0" in ws.message
    for x, y in zip(before, (s.t, s.q, s.p, s.lam, s.force, s.steps, s.restarts)):
        np.testing.assert_array_equal(x, y)
    assert nonholo.steps(model, ws, s, nonholo.RattleOptions(0.01), 10) == nonholo.Status.LegendreNotSolved
    assert s.steps == 0
    # A smaller step goes: about e3 at 150 rad/s, by asin(h |Omega|) a step (the closed form).
    h = 0.005
    assert nonholo.steps(model, ws, s, nonholo.RattleOptions(h), 4) == nonholo.Status.Ok, ws.message
    np.testing.assert_allclose(s.q, nonholo.axis_angle_quaternion([0, 0, 1], 4 * math.asin(150 * h)),
                               rtol=0, atol=1e-14)
    assert ws.legendre_iterations == 0


@pytest.mark.parametrize("build, message", [
    (lambda b: b.add_rigid_body(inertia=[[1.0, 2.0, 0.0], [2.0, 1.0, 0.0], [0.0, 0.0, 1.0]]),
     "rigid body 0: inertia is not positive definite (principal moments -1"),
    (lambda b: b.add_rigid_body(inertia=[[1.0, 0.1, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]], name="top"),
     "rigid body 0 ('top'): inertia is not symmetric"),
    (lambda b: b.add_rigid_body(inertia=[1.0, 10.0, 100.0]),
     "rigid body 0: principal moments 1, 10, 100 break the triangle inequality (1 + 10 < 100)"),
    (lambda b: b.add_rigid_body(inertia=[1.0, 2.0]),
     "add_rigid_body: inertia must be a 3x3 matrix, 3 principal moments or one number, got an array of shape (2,)"),
    (lambda b: b.add_rigid_body(inertia="heavy"),
     "add_rigid_body: inertia must be a 3x3 matrix, 3 principal moments or one number, got str"),
    (lambda b: b.add_rigid_body(translation=1),
     "rigid body 0: translation = 1 must be 0 (a fixed point), 2 (the centre moves in a horizontal plane) or 3"),
    (lambda b: b.add_rigid_body(mass=0.0, translation=3), "rigid body 0: mass m = 0 must be positive and finite"),
    (lambda b: b.add_rolling_disk(b.add_rigid_body(translation=2)),
     "rolling disk: body 0 has translation 2; a rolling disk's centre rises and falls as it tilts (translation 3)"),
    (lambda b: b.add_rolling_ball(b.add_rigid_body()), "rolling ball: body 0 has translation 0"),
    (lambda b: b.add_rolling_ball(b.add_rigid_body(translation=3), radius=-1.0),
     "rolling ball: radius = -1 must be positive and finite"),
    (lambda b: b.add_body_axis_constraint(b.add_rigid_body(), axis=(0, 0, 0)),
     "body-axis constraint: axis (0 0 0) must be finite and nonzero"),
    (lambda b: b.add_space_axis_constraint(b.add_rigid_body(), axis=(1, 0)),
     "add_space_axis_constraint: axis: expected 3 numbers, got an array of 2 in 1 dimension(s)"),
    (lambda b: b.add_body_axis_constraint(b.add_planar_body(["x", "y", "th"], 1.0, 1.0)),
     "body-axis constraint: body 0 is not a 3-D rigid body (add it with add_rigid_body)"),
    (lambda b: b.add_knife_edge(b.add_rigid_body(translation=2)), "body 0 is a 3-D rigid body"),
    (lambda b: b.add_rod(b.add_rigid_body(translation=2), b.add_rigid_body(translation=3), 1.0),
     "rod: body 0's centre moves in 2-D, body 1's in 3-D"),
    (lambda b: b.add_body_force(b.add_rigid_body(), (1.0, 0.0, 0.0)),
     "body force on body 0: its centre is fixed (translation 0)"),
    (lambda b: b.add_body_torque(b.add_rigid_body(), "spin"),
     "add_body_torque: body torque: expected 3 numbers, got str"),
    (lambda b: b.add_body_torque(3, lambda t: (0.0, 0.0, 1.0)), "body torque: body 3 is out of range"),
    (lambda b: (b.add_rigid_body(translation=2), b.add_gravity(), b.build()),
     "gravity: no rigid body of the model moves in 3-D (translation 3): it would act on nothing"),
])
def test_rigid_set_up_mistakes_raise_value_error_with_the_message(build, message):
    b = nonholo.ModelBuilder()
    with pytest.raises(ValueError) as error:
        build(b)
    assert message in str(error.value)
    assert not b.calls_python  # a refused callable is not kept


def test_bad_vectors_for_start_and_state():
    b = nonholo.ModelBuilder()
    b.add_planar_body(["x", "y", "th"], 1.0, 1.0)
    body = b.add_rigid_body(inertia=[1.0, 2.0, 3.0], translation=2, name="B")
    model = b.build()
    assert (model.num_configuration, model.num_velocities, model.num_bodies) == (9, 8, 2)
    assert model.coordinate_names == ["x", "y", "th", "qwB", "qxB", "qyB", "qzB", "xB", "yB"]
    assert model.velocity_names == ["x", "y", "th", "wxB", "wyB", "wzB", "vxB", "vyB"]
    assert (model.body(body), model.body_configuration(body)) == ((3, 5), (3, 6))
    np.testing.assert_array_equal(model.mass_block(body), np.diag([1.0, 2.0, 3.0, 1.0, 1.0]))
    assert "9 coordinates, 8 velocities" in repr(model)
    ws = nonholo.Workspace(model)
    q0 = np.array([0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 0.0])
    with pytest.raises(ValueError, match=r"start: expected 9 entries in q0 \(one per configuration entry\), got 8"):
        nonholo.start_from_velocity(model, ws, 0.0, q0[:8], np.zeros(8))
    with pytest.raises(ValueError, match=r"expected 8 entries in the velocity guess \(one per velocity entry\)"):
        nonholo.start_from_velocity(model, ws, 0.0, q0, np.zeros(9))
    with pytest.raises(ValueError, match=r"the quaternion of rigid body 1 \(qwB, qxB, qyB, qzB\) has norm 2"):
        nonholo.start_from_velocity(model, ws, 0.0, q0 * 2.0, np.zeros(8))
    s = nonholo.start_from_velocity(model, ws, 0.0, q0, np.arange(8.0))
    assert (s.q.shape, s.p.shape, s.force.shape) == ((9,), (8,), (8,))
    with pytest.raises(ValueError, match="State.q: expected a 1-D array of 9 values, got 8"):
        s.q = np.zeros(8)
    with pytest.raises(ValueError, match="State.p: expected a 1-D array of 8 values, got 9"):
        s.p = np.zeros(9)
    other = suslov_model()
    other_ws, other_state = suslov_start(other)
    with pytest.raises(ValueError, match=r"does not have the model's sizes \(9 configuration entries, 8 velocities, "
                                         r"0 one-forms\)"):
        nonholo.diagnose(model, ws, other_state, 0.01)
    assert nonholo.step(other, other_ws, s, nonholo.RattleOptions()) == nonholo.Status.SizeMismatch
    assert "state sizes q 9, p 8, force 8, lambda 0; the model needs 4, 3, 3, 1" in other_ws.message
    with pytest.raises(ValueError, match="one_form_values: expected 4 coordinates, got 3"):
        other.one_form_values(np.zeros(3))
    np.testing.assert_array_equal(other.one_form_values(SUSLOV_Q0), [0.0, 0.0, 1.0])


def test_a_generator_of_the_wrong_size_is_reported():
    message = ("symmetry 'spin' generator(q) returned an array of shape (3,), expected 5 values (one per velocity "
               "coordinate: a rigid body's Omega, then its centre's velocity)")
    # The start evaluates every generator at q0 ...
    with pytest.raises(ValueError) as error:
        ball_start(chaplygin_ball(generator=lambda q: spin_generator(q)[:3]))  # gamma alone: 3 of 5 values
    assert str(error.value) == message
    # ... and one that goes wrong later (here past q0, whose qw is 0.9394) fails the step with the state kept.
    model = chaplygin_ball(generator=lambda q: spin_generator(q)[:3] if q[0] < 0.938 else spin_generator(q))
    ws, s = ball_start(model)
    before = (s.q, s.p, s.lam, s.force)
    assert nonholo.step(model, ws, s, nonholo.RattleOptions(0.01, restart="1")) == nonholo.Status.CallbackFailed
    assert ws.message == "a model callback threw: " + message
    for x, y in zip(before, (s.q, s.p, s.lam, s.force)):
        np.testing.assert_array_equal(x, y)
    assert s.steps == 0
    with pytest.raises(ValueError) as error:
        nonholo.momentum_maps(model, nonholo.start_from_velocity(model, ws, 0.0, np.concatenate(
            [nonholo.axis_angle_quaternion([1.0, 2.0, 3.0], 1.0), [0.0, 0.0]]), [0.0, 0.0, 0.0, 0.0, 0.0]))
    assert str(error.value) == message


def two_balls(kind, wrong=False):
    """Two Chaplygin balls (inertias 0.3:0.4:0.5 and 0.5:0.3:0.4) on the plane, each with its spin
    declared: globally (kind "global": n_v entries), or local to its body (body=) returning the
    body's 5 entries ("local"), all 10 with zeros elsewhere ("padded"), or with J given directly
    ("value"). `wrong`: ball 1's padded generator leaks into ball 0's entries."""
    b = nonholo.ModelBuilder()
    for i, inertia in enumerate(([0.3, 0.4, 0.5], [0.5, 0.3, 0.4])):
        b.add_rigid_body(mass=1.0, inertia=inertia, translation=2)
        b.add_rolling_ball(i, radius=1.0)
    for i in range(2):
        own = lambda q, i=i: spin_generator(q[6 * i:6 * i + 6])
        def padded(q, i=i):
            xi = np.zeros(10)
            xi[5 * i:5 * i + 5] = spin_generator(q[6 * i:6 * i + 6])
            if wrong and i == 1:
                xi[0] = 0.25
            return xi
        if kind == "global":
            b.symmetry("spin%d" % i, padded)
        elif kind == "local":
            b.symmetry("spin%d" % i, own, body=i)
        elif kind == "padded":
            b.symmetry("spin%d" % i, padded, body=i)
        else:
            b.symmetry("spin%d" % i, own, body=i,
                       value=lambda q, p, i=i: p[5 * i:5 * i + 3] @ nonholo.quaternion_matrix(q[6 * i:6 * i + 4])[2])
    return b.build()


def test_a_symmetry_local_to_one_body_is_kept_through_restarts():
    q0 = np.concatenate([nonholo.axis_angle_quaternion([1.0, 2.0, 3.0], 0.7), [0.0, 0.0],
                         nonholo.axis_angle_quaternion([2.0, -1.0, 0.5], 0.4), [4.0, 0.0]])
    v0 = [1.0, 0.5, 2.0, 0.0, 0.0, -0.5, 1.5, 0.8, 0.0, 0.0]
    options = nonholo.RattleOptions(0.01, restart="auto", restart_tolerance=1e-9)  # restarts at most steps
    finals = {}
    for kind in ("global", "local", "padded", "value"):
        model = two_balls(kind)
        ws = nonholo.Workspace(model)
        s = nonholo.start_from_velocity(model, ws, 0.0, q0, v0)
        j0 = np.array([s.p[5 * i:5 * i + 3] @ nonholo.quaternion_matrix(s.q[6 * i:6 * i + 4])[2] for i in range(2)])
        np.testing.assert_allclose(nonholo.momentum_maps(model, s), j0, rtol=0, atol=1e-15)
        drift = 0.0
        for _ in range(500):
            assert nonholo.step(model, ws, s, options) == nonholo.Status.Ok, ws.message
            j = [s.p[5 * i:5 * i + 3] @ nonholo.quaternion_matrix(s.q[6 * i:6 * i + 4])[2] for i in range(2)]
            drift = max(drift, np.abs(np.array(j) - j0).max())
        print(f"two balls, spins declared {kind}: {s.restarts} restarts in 500 steps, J drift {drift:.3g}")
        assert s.restarts >= 250 and drift <= 1e-12
        finals[kind] = s.q
    # Local or global, the same restarts: the same trajectory within round-off.
    for kind in ("local", "padded", "value"):
        np.testing.assert_allclose(finals[kind], finals["global"], rtol=0, atol=1e-12)


def test_a_local_symmetry_is_checked():
    q0 = np.concatenate([nonholo.axis_angle_quaternion([1.0, 2.0, 3.0], 0.7), [0.0, 0.0],
                         nonholo.axis_angle_quaternion([2.0, -1.0, 0.5], 0.4), [4.0, 0.0]])
    model = two_balls("padded", wrong=True)
    with pytest.raises(ValueError, match=r"symmetry 'spin1' generator\(q\) returned 0.25.* at entry 0, outside body 1"):
        nonholo.start_from_velocity(model, nonholo.Workspace(model), 0.0, q0, np.zeros(10))
    b = nonholo.ModelBuilder()
    b.add_rigid_body(mass=1.0, inertia=[0.3, 0.4, 0.5], translation=2)
    with pytest.raises(TypeError, match="body must be an int"):
        b.symmetry("spin", spin_generator, body="0")
    with pytest.raises(ValueError, match="body 3 does not exist"):
        b.symmetry("spin", spin_generator, body=3)
    b.add_rolling_ball(0, radius=1.0)
    b.symmetry("spin", lambda q: spin_generator(q)[:3], body=0)  # 3 of the body's 5 entries
    model = b.build()
    with pytest.raises(ValueError, match=r"returned an array of shape \(3,\), expected 5 values \(body 0's velocity "
                                         r"entries 0..4, or all n_v with zeros elsewhere\)"):
        ball_start(model)


def test_a_generator_that_raises_fails_the_step_with_its_text():
    def raising(q):
        raise ArithmeticError(f"no spin at qw = {q[0]:.3f}")
    with pytest.raises(ArithmeticError, match="no spin at qw = 0.939"):  # the start evaluates it at q0
        ball_start(chaplygin_ball(generator=raising))
    def generator(q):  # raises past q0 only
        return raising(q) if q[0] < 0.938 else spin_generator(q)
    model = chaplygin_ball(generator=generator)
    ws, s = ball_start(model)
    assert nonholo.step(model, ws, s, nonholo.RattleOptions(0.01, restart="1")) == nonholo.Status.CallbackFailed
    assert "symmetry 'spin' generator(q) raised ArithmeticError: no spin at qw = 0.937" in ws.message  # at q_1
    with pytest.raises(ArithmeticError, match="no spin"):
        nonholo.momentum_maps(model, nonholo.start_from_velocity(model, ws, 0.0, np.concatenate(
            [nonholo.axis_angle_quaternion([1.0, 2.0, 3.0], 1.0), [0.0, 0.0]]), [0.0, 0.0, 0.0, 0.0, 0.0]))


def free_body(force, torque, gravity=9.81):
    b = nonholo.ModelBuilder()
    body = b.add_rigid_body(mass=2.0, inertia=2.0, translation=3)
    b.add_gravity(gravity)
    b.add_body_force(body, force)
    b.add_body_torque(body, torque)
    return b.build()


def test_gravity_body_force_and_torque_give_the_exact_motion():
    # Constant forces: the kicks are exact, the centre moves on its parabola to round-off, and
    # a torque along the spin's axis adds to the momentum exactly (W turns about that axis).
    constant = free_body((1.0, 0.0, 0.0), (0.0, 0.0, 0.5))
    assert not constant.calls_python and constant.has_external_force
    called = free_body(lambda t: np.array([1.0, 0.0, 0.0]), lambda t: [0.0, 0.0, 0.5])
    assert called.calls_python
    end = []
    for model in (constant, called):
        ws = nonholo.Workspace(model)
        s = nonholo.start_from_velocity(model, ws, 0.0, [1, 0, 0, 0, 0, 0, 10], [0, 0, 1, 0, 0, 3])
        assert nonholo.steps(model, ws, s, nonholo.RattleOptions(0.01), 100) == nonholo.Status.Ok, ws.message
        end.append(s)
    s = end[0]
    t = s.t
    np.testing.assert_allclose(s.q[4:], [0.5 * (1.0 / 2.0) * t * t, 0.0, 10.0 + 3.0 * t - 0.5 * 9.81 * t * t],
                               rtol=0, atol=1e-12)
    np.testing.assert_allclose(s.p, [0.0, 0.0, 2.0 + 0.5 * t, 1.0 * t, 0.0, 2.0 * (3.0 - 9.81 * t)],
                               rtol=0, atol=1e-12)
    for name in ("q", "p", "lam", "force"):  # the callables are the same functions
        np.testing.assert_array_equal(getattr(end[0], name), getattr(end[1], name), err_msg=name)


def test_torque_and_force_callables_fail_clearly():
    model = free_body((0.0, 0.0, 0.0), lambda t: np.zeros(2))
    ws = nonholo.Workspace(model)
    with pytest.raises(ValueError, match=r"body torque\(t\) of body 0 returned an array of shape \(2,\), expected 3 "
                                         r"values \(the torque in the body frame\)"):
        nonholo.start_from_velocity(model, ws, 0.0, [1, 0, 0, 0, 0, 0, 0], np.zeros(6))

    def force(t):
        if t > 0.025:
            raise RuntimeError(f"engine stalled at t = {t:.2f}")
        return (1.0, 0.0, 0.0)
    model = free_body(force, (0.0, 0.0, 0.0))
    ws = nonholo.Workspace(model)
    s = nonholo.start_from_velocity(model, ws, 0.0, [1, 0, 0, 0, 0, 0, 0], np.zeros(6))
    assert nonholo.steps(model, ws, s, nonholo.RattleOptions(0.01), 10) == nonholo.Status.CallbackFailed
    assert s.steps == 2 and "body force(t) of body 0 raised RuntimeError: engine stalled at t = 0.03" in ws.message


def test_an_upright_disk_rolls_straight_as_the_scheme_predicts():
    # Axis horizontal (body e3 along space e1), spinning at w about it: the centre rolls along
    # -e2 at r w, exactly; Moser-Veselov turns about the principal axis e3 by asin(h w) a step.
    r, w, h, n = 0.5, 3.0, 0.01, 200
    b = nonholo.ModelBuilder()
    body = b.add_rigid_body(mass=2.0, inertia=[0.25, 0.25, 0.5], translation=3)
    assert b.add_rolling_disk(body, radius=r, label="disk") == 0
    model = b.build()
    assert (model.num_one_forms, model.holonomic_rows) == (3, [2])
    ws = nonholo.Workspace(model)
    q0 = np.concatenate([nonholo.axis_angle_quaternion([0, 1, 0], math.pi / 2), [0.0, 0.0, r]])
    s = nonholo.start_from_velocity(model, ws, 0.0, q0, [0, 0, w, 0, -r * w, 0])
    assert nonholo.steps(model, ws, s, nonholo.RattleOptions(h), n) == nonholo.Status.Ok, ws.message
    np.testing.assert_allclose(s.q[4:], [0.0, -r * w * s.t, r], rtol=0, atol=1e-13)
    turned = qmul(q0[:4], nonholo.axis_angle_quaternion([0, 0, 1], n * math.asin(h * w)))
    np.testing.assert_allclose(s.q[:4], turned, rtol=0, atol=1e-13)
    d = nonholo.diagnose(model, ws, s, h)
    assert d.residual <= 1e-14 and d.gap <= 1e-14


@pytest.mark.parametrize("hitch", ["holonomic", "oneform"])
def test_a_rod_keeps_two_centres_at_its_length(hitch):
    b = nonholo.ModelBuilder()
    first = b.add_rigid_body(translation=2)
    second = b.add_rigid_body(mass=2.0, translation=2, name="b")
    assert b.add_rod(first, second, 1.0) == 0
    model = b.build()
    assert model.holonomic_rows == [0] and model.velocity_names[5:] == ["wxb", "wyb", "wzb", "vxb", "vyb"]
    ws = nonholo.Workspace(model)
    q0 = [1, 0, 0, 0, 0, 0, 1, 0, 0, 0, 1, 0]
    s = nonholo.start_from_velocity(model, ws, 0.0, q0, [0, 0, 1, 0, 1, 0, 0, 0, 0, -0.5])
    e0 = nonholo.diagnose(model, ws, s, 0.01).energy_post
    options = nonholo.RattleOptions(0.01, hitch=hitch)
    assert nonholo.steps(model, ws, s, options, 1000) == nonholo.Status.Ok, ws.message
    d = nonholo.diagnose(model, ws, s, 0.01)
    if hitch == "holonomic":  # g = 0 at position level
        assert abs(np.linalg.norm(s.q[4:6] - s.q[10:12]) - 1.0) <= 1e-12 and d.gap <= 1e-12
    else:  # the rod's row a plain one-form: the post-momentum energy exact
        assert abs(d.energy_post - e0) <= 1e-13 * e0
    # The pair turned about its centre of mass, which stays where it was (momentum 0).
    np.testing.assert_allclose((s.q[4:6] + 2.0 * s.q[10:12]) / 3.0, [2.0 / 3.0, 0.0], rtol=0, atol=1e-12)
    assert abs(s.q[5]) > 0.1


def test_the_rotation_option():
    o = nonholo.RattleOptions(0.01, rotation="exponential")
    assert o.rotation == "exponential" and "rotation='exponential'" in repr(o)
    assert nonholo.RattleOptions().rotation == "moser-veselov"
    with pytest.raises(ValueError, match=r"unknown rotation Lagrangian 'cayley' \(valid: moser-veselov, "
                                         r"moser-veselov-f, exponential\)"):
        nonholo.RattleOptions(rotation="cayley")
    with pytest.raises(ValueError, match="unknown rotation Lagrangian 'MV'"):
        o.rotation = "MV"
    assert o.rotation == "exponential"
    o.rotation = "moser-veselov-f"
    assert o.rotation == "moser-veselov-f"
    # It reaches the step: the exponential Lagrangian's post-momentum energy is not exact on a
    # non-isotropic body (README "3-D bodies"), Moser-Veselov's is.
    model = suslov_model()
    drift = {}
    for rotation in ("moser-veselov", "exponential"):
        ws, s = suslov_start(model)
        e0 = nonholo.diagnose(model, ws, s, 0.01).energy_post
        assert nonholo.steps(model, ws, s, nonholo.RattleOptions(0.01, rotation=rotation), 1000) == \
            nonholo.Status.Ok, ws.message
        drift[rotation] = abs(nonholo.diagnose(model, ws, s, 0.01).energy_post - e0) / e0
    print(f"Suslov top, 1000 steps: energy_post drift {drift}")
    assert drift["moser-veselov"] <= 1e-13 and drift["exponential"] > 1e-8


@pytest.mark.parametrize("rotation", ["moser-veselov", "moser-veselov-f", "exponential"])
def test_start_from_two_points_lands_on_the_second_orientation(rotation):
    b = nonholo.ModelBuilder()
    b.add_rigid_body(inertia=SUSLOV_INERTIA, any_inertia=True)
    model = b.build()
    h = 0.01
    q0 = nonholo.axis_angle_quaternion([0.3, -1.0, 0.2], 0.4)
    q1 = qmul(q0, nonholo.axis_angle_quaternion([1.0, 0.5, 0.2], 0.05))
    landed = {}
    for step_rotation in ("moser-veselov", "moser-veselov-f", "exponential"):
        ws = nonholo.Workspace(model)
        s = nonholo.start_from_two_points(model, ws, 0.0, q0, q1, h, rotation=rotation)
        assert nonholo.step(model, ws, s, nonholo.RattleOptions(h, rotation=step_rotation)) == nonholo.Status.Ok
        landed[step_rotation] = np.abs(s.q - q1).max()
    assert landed[rotation] <= 1e-15  # the same transform there and back
    assert all(err > 1e-9 for r, err in landed.items() if r != rotation), landed
    with pytest.raises(ValueError, match="unknown rotation Lagrangian 'none'"):
        nonholo.start_from_two_points(model, nonholo.Workspace(model), 0.0, q0, q1, h, rotation="none")


def test_quaternion_helpers_against_rodrigues():
    axis, angle = np.array([1.0, -2.0, 0.5]), 0.9
    q = nonholo.axis_angle_quaternion(axis, angle)
    assert q.shape == (4,) and abs(np.linalg.norm(q) - 1.0) <= 1e-15
    u = axis / np.linalg.norm(axis)
    k = np.array([[0.0, -u[2], u[1]], [u[2], 0.0, -u[0]], [-u[1], u[0], 0.0]])
    rodrigues = np.eye(3) + math.sin(angle) * k + (1.0 - math.cos(angle)) * (k @ k)
    np.testing.assert_allclose(nonholo.quaternion_matrix(q), rodrigues, rtol=0, atol=1e-15)
    np.testing.assert_allclose(nonholo.quaternion_matrix(3.0 * q), rodrigues, rtol=0, atol=1e-15)  # q / |q|
    np.testing.assert_allclose(nonholo.quaternion_matrix(nonholo.axis_angle_quaternion((0, 0, 2), math.pi / 2)),
                               [[0, -1, 0], [1, 0, 0], [0, 0, 1]], rtol=0, atol=1e-15)
    with pytest.raises(ValueError, match=r"axis_angle_quaternion: axis \(0 0 0\) and angle 1 must be finite"):
        nonholo.axis_angle_quaternion([0, 0, 0], 1.0)
    with pytest.raises(ValueError, match="axis_angle_quaternion: axis: expected 3 numbers"):
        nonholo.axis_angle_quaternion([0, 1], 1.0)
    with pytest.raises(ValueError, match=r"quaternion_matrix: q = \(0.0, 0.0, 0.0, 0.0\) must be finite and nonzero"):
        nonholo.quaternion_matrix([0, 0, 0, 0])
    with pytest.raises(ValueError, match="quaternion_matrix: expected 4 numbers"):
        nonholo.quaternion_matrix(np.eye(2))


# --- the 3-D scenes through run() and batch(), as the command line runs them -----------------

@pytest.mark.parametrize("scene", ["suslov", "veselova", "chaplygin_ball", "ball_chain", "rolling_disk"])
def test_the_three_d_scenes_run_from_python_as_from_the_command_line(scene):
    r = nonholo.run(scene, t_end=1.0, every=10)
    assert r.status == "ok", r.summary["message"]
    assert r.summary["rotation"] == "moser-veselov"
    assert r.summary["legendre_iterations_max"] >= 0
    assert r.coordinates[:4] == ["qw0", "qx0", "qy0", "qz0"]
    # every frame's quaternions are unit (renormalised every step)
    for b in range(r.summary["bodies"]):
        at = r.coordinates.index("qw%d" % b)
        np.testing.assert_allclose(np.linalg.norm(r.q[:, at:at + 4], axis=1), 1.0, rtol=0, atol=4e-16)
    cli = subprocess.run([os.environ["NONHOLO_CLI"], "run", scene, "--t-end", "1"], capture_output=True, text=True)
    assert cli.returncode == 0
    assert "legendre_iterations_max=%d" % r.summary["legendre_iterations_max"] in cli.stdout


def test_rotation_reaches_the_run_and_a_bad_one_is_refused():
    mv = nonholo.run("suslov", t_end=20.0, restart=0)
    ex = nonholo.run("suslov", t_end=20.0, restart=0, rotation="exponential")
    assert ex.summary["rotation"] == "exponential"
    assert mv.summary["energy_post_rel_err_max"] < 1e-13 < 1e-7 < ex.summary["energy_post_rel_err_max"]
    with pytest.raises(ValueError, match="^rotation: unknown rotation Lagrangian 'cayley'"):  # the keyword
        nonholo.run("suslov", rotation="cayley")
    b = nonholo.batch("chaplygin_ball", count=4, vary={"Omega3": (1.0, 3.0)}, t_end=1.0, rotation="moser-veselov-f")
    assert b.summary["rotation"] == "moser-veselov-f" and b.summary["failed"] == 0


def test_a_three_d_run_writes_velocities_apart_from_coordinates_in_hdf5(tmp_path):
    h5py = pytest.importorskip("h5py")
    path = tmp_path / "ball.h5"
    r = nonholo.run("chaplygin_ball", t_end=0.5, every=5, out=path)
    with h5py.File(path, "r") as f:
        names = [n.decode() for n in f["coordinates"][()]]
        velocities = [n.decode() for n in f["velocities"][()]]
        assert names == ["qw0", "qx0", "qy0", "qz0", "x0", "y0"]
        assert velocities == ["wx0", "wy0", "wz0", "vx0", "vy0"]
        assert f["q"].shape == (r.t.shape[0], 6) and f["p"].shape == (r.t.shape[0], 5)
        np.testing.assert_array_equal(f["q"][()], r.q)
        assert f.attrs["rotation"] == "moser-veselov"
