"""The paper's nonholonomic particle built from Python: R^3, M = I, one constraint
zdot - y xdot = 0. Integrates it, checks it against the exact solution and plots the energies
and the trajectory.

    PYTHONPATH=build/python /usr/bin/python3 examples/python/particle.py [out.png]
"""
import math
import sys

import matplotlib

matplotlib.use("Agg")  # no display needed
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

import nonholo  # noqa: E402

# The model: one body of unit mass, one one-form row mu(q) = (-y, 0, 1) on columns x and z.
b = nonholo.ModelBuilder()
b.add_body(["x", "y", "z"], np.eye(3))
b.add_one_form([0, 2])
b.one_form_values(lambda q: np.array([-q[1], 1.0]))       # mu's entries in pattern order
b.one_form_bias(lambda q, v: np.array([-v[1] * v[0]]))    # (d/dt mu) qdot; optional
model = b.build()

# A start with the velocity guess projected onto the constraint, then steps of h.
h, t_end = 0.05, 20.0
ws = nonholo.Workspace(model)
state = nonholo.start_from_velocity(model, ws, 0.0, q0=[0.0, -1.0, 0.0], v0=[1.0, 0.2, 0.0])
options = nonholo.RattleOptions(h)
q0, v0 = state.q, state.p  # arrays are copies (M = I: p~ is the velocity)

t, q, energy, energy_post = [], [], [], []
for k in range(round(t_end / h) + 1):
    if k > 0:
        status = nonholo.step(model, ws, state, options)
        if status != nonholo.Status.Ok:  # a step never raises; the workspace says why
            sys.exit(f"step failed at t = {state.t}: {status.text}: {ws.message}")
    d = nonholo.diagnose(model, ws, state, h)
    t.append(state.t)
    q.append(state.q)
    energy.append(d.energy)
    energy_post.append(d.energy_post)
t, q, energy, energy_post = map(np.array, (t, q, energy, energy_post))

# The exact solution (docs/design.md section 6) from the projected start: y = y0 + ydot0 t and
# xdot sqrt(1 + y^2) = K.
(x0, y0, z0), (xd0, yd0, _) = q0, v0
k = xd0 * math.sqrt(1.0 + y0 * y0)
y = y0 + yd0 * t
exact = np.column_stack([x0 + k / yd0 * (np.arcsinh(y) - math.asinh(y0)), y,
                         z0 + k / yd0 * (np.sqrt(1.0 + y * y) - math.sqrt(1.0 + y0 * y0))])
print(f"{len(t) - 1} steps of h = {h}: max |q - q_exact| = {np.abs(q - exact).max():.3g}, "
      f"energy of p~ varies by {np.ptp(energy):.3g}, post-momentum energy by {np.ptp(energy_post):.3g}")

fig, (ax_e, ax_q) = plt.subplots(1, 2, figsize=(11, 4.2))
ax_e.plot(t, energy - energy[0], label="energy of p~ (order 2)")
ax_e.plot(t, energy_post - energy_post[0], label="post-momentum energy (exact)")
ax_e.set(xlabel="t", ylabel="E(t) - E(0)", title="Energies")
ax_e.legend()
ax_q.plot(exact[:, 0], exact[:, 2], "k-", lw=3, alpha=0.3, label="exact")
ax_q.plot(q[::8, 0], q[::8, 2], ".", label=f"nonholo, h = {h}")
ax_q.set(xlabel="x", ylabel="z", title="Trajectory (x, z)")
ax_q.legend()
fig.tight_layout()
out = sys.argv[1] if len(sys.argv) > 1 else "/tmp/nonholo_particle.png"
fig.savefig(out, dpi=100)
print(f"wrote {out}")
