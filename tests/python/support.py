"""What the pytest files share: the command-line tool (NONHOLO_CLI, set by CTest) and its
outputs read back."""
import csv
import os
import subprocess

CLI = os.environ.get("NONHOLO_CLI", "nonholo")


def cli(*args):
    return subprocess.run([CLI, *args], capture_output=True, text=True)


def read_csv(path):
    """The header and the rows (as strings) of a CSV file."""
    with open(path, newline="") as f:
        rows = list(csv.reader(f))
    return rows[0], rows[1:]


def summary_of(line):
    """A summary line as a dict of its key=value words."""
    return dict(w.split("=", 1) for w in line.split())


def without_timings(line):
    """The summary line without what the clock measures."""
    return " ".join(w for w in line.split() if not w.startswith(("wall_s=", "setup_s=", "ns_per_step=", "ns_per_body_step=")))


def chain_builder(n, thrust=1.0):
    """n sleighs hitched body by body (knife edge of b, then the hitch b -> b+1), as the
    scenes' chains: a chain of elements, stepped by the fused sweep without Python."""
    import nonholo
    b = nonholo.ModelBuilder()
    for i in range(n):
        b.add_planar_body([f"x{i}", f"y{i}", f"theta{i}"], 1.0, 0.1)
    for i in range(n):
        b.add_knife_edge(i, a=0.1)
        if i + 1 < n:
            b.add_hitch(i, i + 1, 0.5, 0.5)
    if thrust is not None:
        b.add_thrust(0, force=thrust, torque=0.2)
    return b
