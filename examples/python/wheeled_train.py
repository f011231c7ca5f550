#!/usr/bin/python3
"""Runs a 1000-body wheeled_train from Python, as `nonholo run wheeled_train` would, and reads
its arrays: the summary, the energy of the frames, the whole train at the first and last frame.

Usage: /usr/bin/python3 examples/python/wheeled_train.py [OUT.png]
(with the package from the build tree: PYTHONPATH=build/python)
"""
import sys

import matplotlib
matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

import nonholo

r = nonholo.run("wheeled_train", set={"bodies": 1000}, t_end=5.0, every=10, check=True)
print(r.line)

# Columns by name: the coordinates are x0, y0, theta0, x1, ... as in the CLI's CSV header.
column = {name: i for i, name in enumerate(r.coordinates)}
lead = r.q[:, [column["x0"], column["y0"]]]
print("frames %d, t = %g .. %g, lead moved %.3f, energy from %.6g to %.6g (thrust does work)"
      % (r.t.size, r.t[0], r.t[-1], np.linalg.norm(lead[-1] - lead[0]), r.energy[0], r.energy[-1]))

fig, (path, energy) = plt.subplots(1, 2, figsize=(11, 4))
xs = r.q[:, 0::3]  # every body's x (coordinates x_b, y_b, theta_b body by body)
ys = r.q[:, 1::3]
front = 8  # the whole train is 1000 units long: on that scale the lead's path (2.5 units) is a dot
path.plot(lead[:, 0], lead[:, 1], "k", lw=2, zorder=3, label="path of the lead")
path.plot(xs[0, :front], ys[0, :front], ".-", ms=3, label="bodies 0-%d at t = %g" % (front - 1, r.t[0]))
path.plot(xs[-1, :front], ys[-1, :front], ".-", ms=3, label="bodies 0-%d at t = %g" % (front - 1, r.t[-1]))
path.set_aspect("equal", adjustable="datalim")
path.set_title("the front of the train (the other %d bodies trail along -x)" % (xs.shape[1] - front), fontsize=9)
path.set_xlabel("x")
path.set_ylabel("y")
path.legend(fontsize=8)
energy.plot(r.t, r.energy, label="energy of p~")
energy.plot(r.t, r.energy_post, "--", label="post-momentum energy")
energy.set_xlabel("t")
energy.legend()
fig.tight_layout()
out = sys.argv[1] if len(sys.argv) > 1 else "/tmp/wheeled_train.png"
fig.savefig(out, dpi=100)
print("wrote", out)
