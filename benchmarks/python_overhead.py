#!/usr/bin/python3
"""What Python costs (issue 13), measured in one process, alternating the two sides:
  run      nonholo.run of a 1000-body wheeled_train against `nonholo run` with the same
           arguments (no CSV): the summary's ns_per_body_step (the steps) and the wall time
           of the call (set-up, steps, frames into arrays) against the process's;
  callback the particle built from Python with Python callbacks against the same scene
           built in C++ (nonholo.build_scene), both through steps() (the loop in C++) and
           through a Python loop of step().
Medians of --repeat alternations. Usage:
  PYTHONPATH=build/python /usr/bin/python3 benchmarks/python_overhead.py [--cli build/nonholo]
"""
import argparse
import os
import statistics
import subprocess
import sys
import time

import numpy as np

import nonholo

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def summary_of(line):
    return {k: v for k, v in (w.split("=", 1) for w in line.split())}


def run_side(cli, bodies, t_end, every):
    args = ["wheeled_train", "--set", "bodies=%d" % bodies, "--t-end", repr(t_end)]
    start = time.perf_counter()
    done = subprocess.run([cli, "run", *args], capture_output=True, text=True, check=True)
    cli_wall = time.perf_counter() - start
    cli_ns = float(summary_of(done.stdout)["ns_per_body_step"])
    start = time.perf_counter()
    r = nonholo.run("wheeled_train", set={"bodies": bodies}, t_end=t_end, every=every)
    py_wall = time.perf_counter() - start
    assert r.status == "ok", r.summary["message"]
    return cli_ns, r.summary["ns_per_body_step"], cli_wall, py_wall


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--cli", default=os.path.join(ROOT, "build", "nonholo"))
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--bodies", type=int, default=1000)
    ap.add_argument("--t-end", type=float, default=20.0)
    ap.add_argument("--every", type=int, default=20)
    a = ap.parse_args()
    runs = [run_side(a.cli, a.bodies, a.t_end, a.every) for _ in range(a.repeat)]
    cli_ns, py_ns, cli_wall, py_wall = (statistics.median(x) for x in zip(*runs))
    print("run: wheeled_train bodies=%d t_end=%g (every=%d in Python), medians of %d" % (
        a.bodies, a.t_end, a.every, a.repeat))
    print("  ns_per_body_step  CLI %.1f  Python %.1f  ratio %.3f" % (cli_ns, py_ns, py_ns / cli_ns))
    print("  wall time         CLI %.3f s (process)  Python %.3f s (call)  ratio %.3f" % (
        cli_wall, py_wall, py_wall / cli_wall))
    callbacks(a.repeat)


def python_particle():
    """The paper's particle (docs/design.md section 5) with Python callbacks, as the scene has it."""
    b = nonholo.ModelBuilder()
    b.add_body(["x", "y", "z"], np.eye(3))
    b.add_one_form([0, 2])
    b.one_form_values(lambda q: np.array([-q[1], 1.0]))
    b.one_form_bias(lambda q, v: np.array([-v[1] * v[0]]))
    return b.build()


def time_steps(model, scene, n, loop):
    ws = nonholo.Workspace(model)
    state = nonholo.start_from_velocity(model, ws, scene.t0, scene.q0, scene.v0)
    options = nonholo.RattleOptions(scene.dt)
    start = time.perf_counter()
    if loop:  # a Python loop of step() calls
        for _ in range(n):
            nonholo.step(model, ws, state, options)
    else:
        nonholo.steps(model, ws, state, options, n)
    elapsed = time.perf_counter() - start
    assert state.steps == n, ws.message
    return 1e9 * elapsed / n, state.q


def callbacks(repeat, n=20000):
    scene = nonholo.build_scene("particle")
    python = python_particle()
    rows = []
    for _ in range(repeat):
        cpp, q_cpp = time_steps(scene.model, scene, n, False)
        py_steps, q_py = time_steps(python, scene, n, False)
        py_loop, _ = time_steps(python, scene, n, True)
        cpp_loop, _ = time_steps(scene.model, scene, n, True)
        assert np.array_equal(q_cpp, q_py), "the two particles differ"
        rows.append((cpp, py_steps, py_loop, cpp_loop))
    cpp, py_steps, py_loop, cpp_loop = (statistics.median(x) for x in zip(*rows))
    print("callback: the particle, %d steps, medians of %d (the same q at the end, bit for bit)" % (n, repeat))
    print("  C++ model, steps()             %8.0f ns/step" % cpp)
    print("  C++ model, Python loop of step %8.0f ns/step  (%.1fx)" % (cpp_loop, cpp_loop / cpp))
    print("  Python callbacks, steps()      %8.0f ns/step  (%.1fx)" % (py_steps, py_steps / cpp))
    print("  Python callbacks, loop of step %8.0f ns/step  (%.1fx)" % (py_loop, py_loop / cpp))


if __name__ == "__main__":
    main()
