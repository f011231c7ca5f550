"""Draws the 3-D scenes from the HDF5 files tools/rigid.sh writes (docs/guide/rigid-bodies.md):
the Chaplygin ball's contact path, the rolling disk's contact path, the Suslov top's angular
velocity against its closed form, and its error with the default restarts and with the
plain method (the period-2 mode's bursts).

usage: /usr/bin/python3 tools/plot_rigid.py DIR OUT.png   (DIR holds ball.h5, disk.h5,
       suslov.h5, suslov_plain.h5)
"""
import math
import sys

import h5py
import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402


def read(path):
    with h5py.File(path, "r") as f:
        names = [n.decode() if isinstance(n, bytes) else n for n in f["coordinates"][()]]
        return f["t"][()], f["q"][()], f["p"][()], names, dict(f["parameters"].attrs)


def rotation(q):
    """Rotation matrices of the quaternions q (frames x 4: w, x, y, z)."""
    q = q / np.linalg.norm(q, axis=1)[:, None]
    w, x, y, z = q.T
    return np.stack([
        np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)], axis=-1),
        np.stack([2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)], axis=-1),
        np.stack([2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)], axis=-1)], axis=1)


def suslov_exact(t, inertia, omega0):
    """The closed form (a = e3, I12 = 0): Omega1 = c1 cos(phi), Omega2 = c2 sin(phi)."""
    i1, i2, i13, i23 = inertia[0][0], inertia[1][1], inertia[0][2], inertia[1][2]
    energy = 0.5 * (i1 * omega0[0] ** 2 + i2 * omega0[1] ** 2)
    c1, c2 = math.sqrt(2 * energy / i1), math.sqrt(2 * energy / i2)
    phi0 = math.atan2(i23 * c2, i13 * c1)
    kappa = math.hypot(i13 * c1, i23 * c2) / math.sqrt(i1 * i2)
    s0 = math.sin(math.atan2(omega0[1] / c2, omega0[0] / c1) - phi0)
    phi = np.arcsin(np.tanh(kappa * t + math.atanh(s0))) + phi0
    return c1 * np.cos(phi), c2 * np.sin(phi), kappa


def main(directory, out):
    fig, ax = plt.subplots(2, 2, figsize=(12, 9.5))

    t, q, _, names, par = read(directory + "/ball.h5")
    x, y = q[:, names.index("x0")], q[:, names.index("y0")]
    # The ball rolls along the horizontal part of its constant contact angular momentum R K,
    # wobbling sideways by a few percent of its radius: drawn along that line, sideways stretched.
    d = np.array([x[-1] - x[0], y[-1] - y[0]])
    d /= np.linalg.norm(d)
    along = (x - x[0]) * d[0] + (y - y[0]) * d[1]
    sideways = -(x - x[0]) * d[1] + (y - y[0]) * d[0]
    a = ax[0, 0]
    pts = a.scatter(along, sideways, c=t, s=1.5, cmap="viridis")
    a.set_title("Chaplygin ball (I = diag(.3, .4, .5), m = r = 1): contact path\n"
                "along its mean direction, sideways stretched %.0fx" % (0.5 * along[-1] / max(1e-300, np.ptp(sideways))))
    a.set_xlabel("distance along the mean direction")
    a.set_ylabel("sideways")
    fig.colorbar(pts, ax=a, label="t")

    t, q, _, names, par = read(directory + "/disk.h5")
    r = par.get("r", 1.0)
    rot = rotation(q[:, 0:4])
    n = rot[:, :, 2]
    w = np.array([0.0, 0.0, 1.0])[None, :] - n[:, 2:3] * n
    u = -w / np.linalg.norm(w, axis=1)[:, None]
    contact = q[:, 4:7] + r * u
    tilt = np.degrees(np.arccos(np.clip(n[:, 2], -1, 1)))
    a = ax[0, 1]
    pts = a.scatter(contact[:, 0], contact[:, 1], c=t, s=1.5, cmap="viridis")
    a.set_aspect("equal", adjustable="datalim")
    a.set_title("rolling disk (m = 15, r = 1, g = 9.81): contact path\n"
                "axis tilt from the vertical %.0f..%.0f degrees" % (tilt.min(), tilt.max()))
    a.set_xlabel("x")
    a.set_ylabel("y")
    fig.colorbar(pts, ax=a, label="t")

    t, q, p, names, par = read(directory + "/suslov.h5")
    inertia = [[par["I11"], par["I12"], par["I13"]], [par["I12"], par["I22"], par["I23"]],
               [par["I13"], par["I23"], par["I33"]]]
    omega = np.linalg.solve(np.array(inertia), p.T).T
    o1, o2, kappa = suslov_exact(t, inertia, [par["Omega1"], par["Omega2"], par["Omega3"]])
    a = ax[1, 0]
    step = max(1, len(t) // 60)
    for i, (exact, label) in enumerate(((o1, "Omega1"), (o2, "Omega2"))):
        a.plot(t, exact, color="C%d" % i, lw=1.0, label=label + ", closed form")
        a.plot(t[::step], omega[::step, i], "o", ms=3, color="C%d" % i, label=label + ", reflection (h = 0.01)")
    a.set_title("Suslov top: angular velocity (body frame), kappa = %.5f" % kappa)
    a.set_xlabel("t")
    a.legend(fontsize=8)

    a = ax[1, 1]
    for path, label in ((directory + "/suslov.h5", "defaults (energy-exact restarts)"),
                        (directory + "/suslov_plain.h5", "plain method (--restart 0)")):
        t, q, p, names, par = read(path)
        omega = np.linalg.solve(np.array(inertia), p.T).T
        o1, o2, _ = suslov_exact(t, inertia, [par["Omega1"], par["Omega2"], par["Omega3"]])
        error = np.hypot(omega[:, 0] - o1, omega[:, 1] - o2)
        a.semilogy(t, np.maximum(error, 1e-17), lw=0.8, label=label)
    a.set_title("Suslov top: |Omega - Omega_exact|, h = 0.01")
    a.set_xlabel("t")
    a.legend(fontsize=8)

    fig.tight_layout()
    fig.savefig(out, dpi=90)


if __name__ == "__main__":
    if len(sys.argv) != 3:
        sys.exit(__doc__)
    main(sys.argv[1], sys.argv[2])
