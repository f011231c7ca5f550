"""Results that last (README "Long runs"): nonholo.load() gives back what run() and batch()
returned, bit for bit, from CSV and HDF5; run(checkpoint=...) and run(resume=...) continue a run
with the frames of the longer run."""
import os

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
            if key not in ("wall_s", "setup_s", "ns_per_step", "ns_per_body_step"):
                assert back.summary[key] == value or (value != value and back.summary[key] != back.summary[key]), key
        assert back.status == "ok" and repr(back) == repr(r)
        with h5py.File(path, "r") as f:  # the file's wall_s is the run's but its closing (was 0)
            assert 0 < f["summary"].attrs["wall_s"] <= r.summary["wall_s"]
    else:
        assert back.p is None and back.gap is None and back.summary == {}
        # No summary to show: repr and status say so (both raised KeyError).
        assert back.status is None and repr(back) == "<nonholo.RunResult: %d frames x 12 coordinates, no summary>" % (
            r.t.shape[0])


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
    assert repr(back) == (repr(b) if ext == "h5" else "<nonholo.BatchResult: 5 trajectories, no summary>")


def test_load_refuses_what_it_cannot_read(tmp_path):
    with pytest.raises(ValueError, match="expected a .csv, .h5 or .hdf5 file"):
        nonholo.load(tmp_path / "x.txt")
    (tmp_path / "other.csv").write_text("a,b\n1,2\n")
    with pytest.raises(ValueError, match="not a CSV file nonholo wrote"):
        nonholo.load(tmp_path / "other.csv")
    nonholo.run("sleigh", t_end=0.1, checkpoint=tmp_path / "ck.h5")
    with pytest.raises(ValueError, match="not a run's or batch's output"):
        nonholo.load(tmp_path / "ck.h5")



def test_load_refuses_what_is_not_a_file_and_names_the_file(tmp_path):
    # Nothing that blocks or reads for ever (a FIFO, a link to /dev/zero), and no raw library
    # error: each refusal names the file and what it is.
    os.mkfifo(tmp_path / "fifo.csv")
    os.symlink("/dev/zero", tmp_path / "zero.h5")
    (tmp_path / "dir.csv").mkdir()
    (tmp_path / "bytes.csv").write_bytes(b"t,x\n\xff\xfe,1\n")
    (tmp_path / "garbage.h5").write_bytes(b"not HDF5 at all")
    h5py.File(tmp_path / "plain.h5", "w").close()
    cases = {"fifo.csv": "a FIFO, not a file", "zero.h5": "a device, not a file", "dir.csv": "a directory, not a file",
             "bytes.csv": "not a run's or a batch's file written by nonholo (UnicodeDecodeError",
             "garbage.h5": "not an HDF5 file h5py can open",
             "plain.h5": "an HDF5 file without nonholo's format attribute, not a run's or batch's output"}
    for name, words in cases.items():
        path = tmp_path / name
        with pytest.raises(ValueError) as error:
            nonholo.load(path)
        assert str(path) in str(error.value) and words in str(error.value), str(error.value)
    with pytest.raises(FileNotFoundError, match=r"missing.csv'\): no such file"):
        nonholo.load(tmp_path / "missing.csv")


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
    with pytest.raises(ValueError, match="^resume .*: cannot read it"):  # the keyword, not --resume
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
    out.write_text("an earlier table\n")  # was emptied as the batch began; a killed batch leaves it
    journal = tmp_path / "killed.csv.partial.csv"
    child = subprocess.Popen([CLI, *args, "--out", str(out)], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    deadline = time.time() + 60
    while time.time() < deadline and (not journal.exists() or len(journal.read_text().splitlines()) < 6):
        time.sleep(0.05)
    child.send_signal(signal.SIGKILL)
    child.wait()
    kept = journal.read_text().splitlines()
    assert len(kept) >= 6, "no rows were journaled before the kill"
    assert out.read_text() == "an earlier table\n"
    again = cli(*args, "--out", str(out))  # the journal is not written over
    assert again.returncode != 0 and "killed.csv.partial.csv' exists" in again.stderr, again.stderr
    assert journal.read_text().splitlines() == kept
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


def test_a_batch_keeps_every_trajectorys_whole_final_state(tmp_path):
    # states=: (count, n) arrays of the final q and p, the same for 1 and 2 threads, bit for bit,
    # each row the state a single run of that trajectory ends in; the --states file holds them.
    kw = dict(count=6, vary={"omega0": (0.5, 1.5)}, set={"bodies": 8}, t_end=1.0, order=4, dt=0.05)
    one = nonholo.batch("sleigh_chain", threads=1, states=True, **kw)
    two = nonholo.batch("sleigh_chain", threads=2, states=tmp_path / "states.h5", **kw)
    assert one.q.shape == (6, 24) and one.p.shape == (6, 24) and one.coordinates[:3] == ["x0", "y0", "theta0"]
    assert same(one.q, two.q) and same(one.p, two.p)
    for i in (0, 5):
        alone = nonholo.run("sleigh_chain", set={"bodies": 8, "omega0": float(one.columns["omega0"][i])},
                            t_end=1.0, order=4, dt=0.05)
        assert same(alone.q[-1], one.q[i]) and same(alone.p[-1], one.p[i])
    back = nonholo.load(tmp_path / "states.h5")
    assert same(back.q, one.q) and same(back.p, one.p) and list(back.columns["status"]) == ["ok"] * 6
    with pytest.raises(ValueError, match="^states with vary bodies"):  # the keywords, not --states, --vary
        nonholo.batch("sleigh_chain", count=2, vary={"bodies": (5, 9)}, states=True)
    assert nonholo.batch("sleigh", count=2, t_end=0.1).q is None


def test_the_final_states_are_the_same_over_mpi_ranks(tmp_path):
    # mpirun -n 3 nonholo batch --states: the same /q and /p as one process, bit for bit.
    import os
    import shutil
    import subprocess
    from support import CLI
    mpirun = shutil.which("mpirun")
    if mpirun is None:
        pytest.skip("no mpirun (Debian: openmpi-bin)")
    args = ["batch", "sleigh_chain", "--count", "7", "--set", "bodies=6", "--vary", "omega0=0.5:1.5", "--t-end", "1"]
    env = dict(os.environ, OMPI_ALLOW_RUN_AS_ROOT="1", OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1")
    done = subprocess.run([mpirun, "-n", "3", "--oversubscribe", CLI, *args, "--threads", "1",
                           "--states", str(tmp_path / "ranks.h5")], env=env, capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    one = nonholo.batch("sleigh_chain", count=7, set={"bodies": 6}, vary={"omega0": (0.5, 1.5)}, t_end=1.0, states=True)
    spread = nonholo.load(tmp_path / "ranks.h5")
    assert same(spread.q, one.q) and same(spread.p, one.p)


def test_a_checkpoint_of_another_version_is_refused(tmp_path):
    nonholo.run("sleigh", t_end=0.1, checkpoint=tmp_path / "ck.h5")
    with h5py.File(tmp_path / "ck.h5", "r+") as f:
        assert f.attrs["format"] == "nonholo checkpoint"
        f.attrs["nonholo_version"] = "0.0.1"
    with pytest.raises(ValueError, match="written by nonholo 0.0.1, this is nonholo .*: resume it with the version"):
        nonholo.run(resume=tmp_path / "ck.h5")
