"""Results that last (README "Long runs"): nonholo.load() gives back what run() and batch()
returned, bit for bit, from CSV and HDF5; run(checkpoint=...) and run(resume=...) continue a run
with the frames of the longer run."""
import numpy as np
import pytest

import nonholo

h5py = pytest.importorskip("h5py")

FRAME_FIELDS = ["t", "q", "energy", "energy_post", "residual"]


def same(a, b):
    """Equal to the last bit (NaN where NaN)."""
    a, b = np.asarray(a), np.asarray(b)
    return a.shape == b.shape and np.array_equal(a.view(np.uint64), b.view(np.uint64))


@pytest.mark.parametrize("ext", ["csv", "h5"])
def test_load_gives_back_the_run(tmp_path, ext):
    path = tmp_path / ("run." + ext)
    r = nonholo.run("wheeled_train", set={"bodies": 4}, t_end=1, every=3, out=path)
    back = nonholo.load(path)
    assert isinstance(back, nonholo.RunResult) and back.coordinates == r.coordinates
    for name in FRAME_FIELDS:
        assert same(getattr(back, name), getattr(r, name)), name
    if ext == "h5":
        assert same(back.p, r.p) and same(back.gap, r.gap) and back.velocities == r.velocities
        for key, value in r.summary.items():  # every summary value but the timings
            if key not in ("wall_s", "ns_per_step", "ns_per_body_step"):
                assert back.summary[key] == value or (value != value and back.summary[key] != back.summary[key]), key
    else:
        assert back.p is None and back.gap is None and back.summary == {}


@pytest.mark.parametrize("ext", ["csv", "h5"])
def test_load_gives_back_the_batch(tmp_path, ext):
    path = tmp_path / ("batch." + ext)
    b = nonholo.batch("sleigh", count=5, vary={"omega0": (0.5, 1.5)}, t_end=0.5, out=path)
    back = nonholo.load(path)
    assert isinstance(back, nonholo.BatchResult)
    for name, column in b.columns.items():
        if column.dtype.kind == "f":
            assert same(back.columns[name], column), name
        else:
            assert list(back.columns[name]) == list(column), name


def test_load_refuses_what_it_cannot_read(tmp_path):
    with pytest.raises(ValueError, match="expected a .csv, .h5 or .hdf5 file"):
        nonholo.load(tmp_path / "x.txt")
    (tmp_path / "other.csv").write_text("a,b\n1,2\n")
    with pytest.raises(ValueError, match="not a CSV file nonholo wrote"):
        nonholo.load(tmp_path / "other.csv")
    nonholo.run("sleigh", t_end=0.1, checkpoint=tmp_path / "ck.h5")
    with pytest.raises(ValueError, match="not a run's or batch's output"):
        nonholo.load(tmp_path / "ck.h5")


def test_a_run_resumed_from_python_goes_on_bit_for_bit(tmp_path):
    whole = nonholo.run("sleigh_chain", set={"bodies": 6}, order=4, dt=0.05, t_end=3)
    first = nonholo.run("sleigh_chain", set={"bodies": 6}, order=4, dt=0.05, t_end=1, checkpoint=tmp_path / "ck.h5")
    rest = nonholo.run(resume=tmp_path / "ck.h5", t_end=3)
    assert first.t.shape == (21,) and rest.t.shape == (40,)  # the resumed frames: from its first step on
    for name in FRAME_FIELDS + ["p", "gap"]:
        joined = np.concatenate([getattr(first, name), getattr(rest, name)])
        assert same(joined, getattr(whole, name)), name
    assert rest.summary["steps"] == 60
    with pytest.raises(ValueError, match="order with resume: a resumed run takes its scene and options"):
        nonholo.run(resume=tmp_path / "ck.h5", order=6)
    with pytest.raises(ValueError, match="--resume .*: cannot read it"):
        nonholo.run(resume=tmp_path / "missing.h5")


def test_a_killed_batch_keeps_every_finished_row(tmp_path):
    # Rows go to OUT.partial.csv as trajectories finish: kill -9 the batch once some have, and
    # each row there is, to the last character, the complete batch's row of that trajectory.
    import signal
    import subprocess
    import time
    from support import CLI, cli
    args = ["batch", "sleigh_chain", "--set", "bodies=150", "--count", "60", "--t-end", "30",
            "--vary", "omega0=0.5:1.5", "--threads", "2"]
    out = tmp_path / "killed.csv"
    journal = tmp_path / "killed.csv.partial.csv"
    child = subprocess.Popen([CLI, *args, "--out", str(out)], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    deadline = time.time() + 60
    while time.time() < deadline and (not journal.exists() or len(journal.read_text().splitlines()) < 6):
        time.sleep(0.05)
    child.send_signal(signal.SIGKILL)
    child.wait()
    kept = journal.read_text().splitlines()
    assert len(kept) >= 6, "no rows were journaled before the kill"
    done = cli(*args, "--out", str(tmp_path / "whole.csv"))
    assert done.returncode == 0, done.stderr
    whole = (tmp_path / "whole.csv").read_text().splitlines()
    assert not (tmp_path / "whole.csv.partial.csv").exists()  # removed once the output is written
    assert kept[0] == whole[0]  # the same header
    rows = {line.split(",", 1)[0]: line for line in whole[1:]}
    for line in kept[1:]:
        assert line == rows[line.split(",", 1)[0]]
    back = nonholo.load(journal)
    assert len(back.columns["trajectory"]) == len(kept) - 1
