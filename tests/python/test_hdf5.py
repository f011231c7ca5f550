"""`nonholo run|batch --out FILE.h5` (scenarios/src/output/hdf5_output.cpp) read with h5py: the CSV's
numbers to the last digit, the attributes, /p and /gap against invariants, and a readable file
after a failed step and after Ctrl-C."""
import os
import signal
import subprocess
import time

import numpy as np
import pytest

import nonholo

from support import CLI, cli, read_csv as table, summary_of

h5py = pytest.importorskip("h5py")


def text(x):
    return x.decode() if isinstance(x, bytes) else x


def test_run_writes_the_csvs_numbers_and_its_attributes(tmp_path):
    args = ["run", "wheeled_train", "--set", "bodies=6", "--set", "seed=4", "--t-end", "2", "--every", "7"]
    done_csv = cli(*args, "--out", str(tmp_path / "a.csv"))
    done_h5 = cli(*args, "--out", str(tmp_path / "a.h5"))
    assert done_csv.returncode == 0 and done_h5.returncode == 0, done_h5.stderr
    header, rows = table(tmp_path / "a.csv")
    values = np.array([[float(x) for x in row] for row in rows])
    with h5py.File(tmp_path / "a.h5", "r") as f:
        names = [text(c) for c in f["coordinates"][:]]
        n = len(names)
        assert header == ["t"] + names + ["energy", "energy_post", "residual"]
        assert f["q"].shape == f["p"].shape == (len(rows), n) and f["t"].shape == (len(rows),)
        assert f["q"].compression == "gzip" and f["q"].chunks is not None
        for j, name in enumerate(["t"]):
            assert np.array_equal(values[:, j], f[name][:])
        assert np.array_equal(values[:, 1:n + 1], f["q"][:])
        assert np.array_equal(values[:, n + 1], f["energy"][:])
        assert np.array_equal(values[:, n + 2], f["energy_post"][:], equal_nan=True)
        assert np.array_equal(values[:, n + 3], f["residual"][:])
        # Attributes: the scene, its parameters, the options, the summary (the line's numbers).
        assert text(f.attrs["scene"]) == "wheeled_train" and text(f.attrs["method"]) == "reflection"
        assert f["parameters"].attrs["bodies"] == 6 and f["parameters"].attrs["seed"] == 4
        assert f.attrs["every"] == 7 and f.attrs["t_end"] == 2.0
        s = f["summary"].attrs
        line = summary_of(done_h5.stdout)
        assert text(s["status"]) == "ok" and s["steps"] == int(line["steps"]) == 200
        assert format(s["gap_max"], ".6g") == line["gap_max"]
        # /gap is the gap of each frame: its largest is at most the run's (taken over every step).
        assert 0 < f["gap"][:].max() <= s["gap_max"]


def test_p_is_the_momentum_whose_energy_the_run_reports(tmp_path):
    # The particle: M = I and no potential, so energy = |p~|^2 / 2 at every frame.
    path = tmp_path / "particle.h5"
    assert cli("run", "particle", "--t-end", "3", "--out", str(path)).returncode == 0
    with h5py.File(path, "r") as f:
        p, energy = f["p"][:], f["energy"][:]
    assert p.shape == (301, 3)
    assert np.allclose(0.5 * (p * p).sum(axis=1), energy, rtol=1e-14, atol=0)


JAM = ["--set", "phi0=1.5607963267948966", "--set", "phi_dot0=1", "--set", "v0=0"]  # fails at step 1


def test_a_failed_run_leaves_a_readable_file_with_its_status(tmp_path):
    path = tmp_path / "jam.h5"
    done = cli("run", "snakeboard", "--dt", "0.01", *JAM, "--out", str(path))
    assert done.returncode == 2
    with h5py.File(path, "r") as f:
        assert f["t"].shape == (1,) and f["q"].shape == (1, 5)
        assert text(f["summary"].attrs["status"]) == "dependent-one-forms"
        assert "step 1 from t = 0 failed" in text(f["summary"].attrs["message"])


def started(proc, path, timeout=120.0):
    """Waits (polling, generous) until the run `proc` has created its output `path`: its signal
    handlers are in place and it is in its loop. Fails if the run ended first."""
    deadline = time.monotonic() + timeout
    while not os.path.exists(path):
        assert proc.poll() is None, "the run ended before it wrote %s" % path
        assert time.monotonic() < deadline, "no %s after %g s" % (path, timeout)
        time.sleep(0.01)


def test_ctrl_c_leaves_a_readable_file(tmp_path):
    path = tmp_path / "long.h5"
    proc = subprocess.Popen([CLI, "run", "sleigh_chain", "--set", "bodies=2000", "--t-end", "10000", "--every", "50",
                             "--out", str(path)], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    started(proc, path)
    time.sleep(0.5)  # a moment into the run (the test's outcome does not depend on which)
    proc.send_signal(signal.SIGINT)
    out, err = proc.communicate(timeout=60)
    assert proc.returncode == 130, err
    with h5py.File(path, "r") as f:
        frames = f["t"].shape[0]
        assert frames >= 1 and f["q"].shape == (frames, 6000)
        assert text(f["summary"].attrs["status"]) == "interrupted"
        assert f["summary"].attrs["steps"] == int(summary_of(out)["steps"])


def test_batch_writes_the_csvs_columns(tmp_path):
    args = ["batch", "sleigh", "--count", "9", "--vary", "m=-0.5:1.5", "--seed", "5", "--t-end", "1"]
    assert cli(*args, "--out", str(tmp_path / "b.csv")).returncode == 2  # some are refused
    done = cli(*args, "--out", str(tmp_path / "b.h5"))
    assert done.returncode == 2, done.stderr
    header, rows = table(tmp_path / "b.csv")
    with h5py.File(tmp_path / "b.h5", "r") as f:
        for j, name in enumerate(header):
            column = f[name][:]
            if name == "status":
                assert [text(x) for x in column] == [row[j] for row in rows]
            else:
                assert np.array_equal(column, np.array([float(row[j]) for row in rows]), equal_nan=True), name
        failed = [i for i, row in enumerate(rows) if row[-1] != "ok"]
        assert failed and all(text(f["messages"][i]) for i in failed)
        assert f["batch"].attrs["failed"] == len(failed) and f["batch"].attrs["trajectories"] == 9
        assert text(f.attrs["vary m"]) == "m=-0.5:1.5"


def test_an_unwritable_path_is_refused_before_integrating():
    done = cli("run", "sleigh", "--out", "/nonexistent-dir/x.h5")
    assert done.returncode == 1
    assert "cannot open '/nonexistent-dir/x.h5' for writing" in done.stderr


def test_plot_train_draws_the_same_picture_from_either_format(tmp_path):
    pytest.importorskip("matplotlib")
    script = os.path.join(os.path.dirname(__file__), "..", "..", "tools", "plot_train.py")
    pictures = []
    for ext in ("csv", "h5"):
        data = tmp_path / ("train." + ext)
        assert cli("run", "wheeled_train", "--set", "bodies=30", "--t-end", "2", "--every", "10",
                   "--out", str(data)).returncode == 0
        png = tmp_path / (ext + ".png")
        subprocess.run(["/usr/bin/python3", script, str(data), str(png)], check=True, capture_output=True)
        pictures.append(png.read_bytes())
    assert pictures[0] == pictures[1]


def test_a_resumed_run_continues_its_hdf5_file_bit_for_bit(tmp_path):
    # The run to t = 3 against the run to t = 1 with a checkpoint, resumed to t = 3: the frames
    # of the continued file are the whole run's, every bit, and the summary is written anew.
    args = ["run", "sleigh_chain", "--set", "bodies=30", "--order", "4", "--dt", "0.05"]
    whole = cli(*args, "--t-end", "3", "--out", str(tmp_path / "whole.h5"))
    part = cli(*args, "--t-end", "1", "--out", str(tmp_path / "part.h5"), "--checkpoint", str(tmp_path / "ck.h5"))
    assert whole.returncode == 0 and part.returncode == 0, part.stderr
    resumed = cli("run", "--resume", str(tmp_path / "ck.h5"), "--t-end", "3")
    assert resumed.returncode == 0, resumed.stderr
    with h5py.File(tmp_path / "whole.h5", "r") as a, h5py.File(tmp_path / "part.h5", "r") as b:
        for name in ["t", "q", "p", "energy", "energy_post", "residual", "gap"]:
            x, y = a[name][()], b[name][()]
            assert x.shape == y.shape and x.shape[0] == 61, name
            assert np.array_equal(x.view(np.uint64), y.view(np.uint64)), name
        assert b["summary"].attrs["steps"] == 60
    with h5py.File(tmp_path / "ck.h5", "r") as c:  # readable beside the bytes
        assert text(c.attrs["format"]) == "nonholo checkpoint" and c.attrs["step"] == 60
        assert c["q"].shape == (90,) and c.attrs["t"] == 3.0


def test_a_killed_run_leaves_a_readable_file_of_the_runs_frames(tmp_path):
    # kill -9 at five moments of a long HDF5 run: the file opens (nonholo.load; h5py with
    # swmr=True), and its frames are the first frames of the run, bit for bit (a run to the
    # last one's step reproduces them). The file is flushed at the start and every 2 s.
    args = ["run", "sleigh_chain", "--set", "bodies=100"]
    for i, delay in enumerate([0.2, 1.0, 2.6, 3.3, 4.8]):
        path = tmp_path / ("killed%d.h5" % i)
        child = subprocess.Popen([CLI, *args, "--t-end", "1e6", "--out", str(path)],
                                 stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        started(child, path)  # the file exists (a loaded machine may take longer than `delay` to get there)
        time.sleep(delay)
        child.send_signal(signal.SIGKILL)
        child.wait()
        back = nonholo.load(path)
        frames = back.t.shape[0]
        assert frames >= 1 and back.q.shape == (frames, 300) and back.summary == {}
        if frames > 1:
            again = nonholo.run(args[1], set={"bodies": 100}, t_end=float(back.t[-1]))
            assert again.t.shape[0] == frames
            assert np.array_equal(again.q.view(np.uint64), back.q.view(np.uint64)), delay
            assert np.array_equal(again.p.view(np.uint64), back.p.view(np.uint64)), delay


def test_a_run_killed_with_hdf5_output_resumes_bit_for_bit(tmp_path):
    # kill -9 left the file marked open by its writer: --resume exited 1 ("cannot open it for
    # writing (HDF5)"). Now the resume takes the file up (the mark cleared) and continues it into
    # the uninterrupted run's frames, every bit; closed at the end, it opens with plain h5py.
    args = ["run", "sleigh_chain", "--set", "bodies=100", "--every", "3"]
    out, checkpoint = tmp_path / "killed.h5", tmp_path / "ck.h5"
    child = subprocess.Popen([CLI, *args, "--t-end", "1e6", "--out", str(out), "--checkpoint", str(checkpoint),
                              "--checkpoint-every", "20"], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    deadline = time.monotonic() + 120.0
    step = 0
    while step < 60:  # a few checkpoints in (written whole, renamed: readable whenever it is there)
        assert child.poll() is None and time.monotonic() < deadline
        if checkpoint.exists():
            with h5py.File(checkpoint, "r") as f:
                step = int(f.attrs["step"])
        time.sleep(0.01)
    child.send_signal(signal.SIGKILL)
    child.wait()
    with pytest.raises(OSError):
        h5py.File(out, "r")  # the mark a killed writer leaves (swmr=True or nonholo.load read it)
    with h5py.File(checkpoint, "r") as f, h5py.File(out, "r", swmr=True) as killed:
        t = float(f.attrs["t"])
        assert text(f.attrs["run_id"]) == text(killed.attrs["run_id"])
        end = repr(round(t + 0.6, 10))
        # A reader holding the file (HDF5 locks what it reads) makes the resume fail: it says so.
        held = cli("run", "--resume", str(checkpoint), "--t-end", end)
        assert held.returncode == 1 and "another program has it open (h5py, HDFView" in held.stderr, held.stderr
    resumed = cli("run", "--resume", str(checkpoint), "--t-end", end)
    assert resumed.returncode == 0, resumed.stderr
    whole = cli(*args, "--t-end", end, "--out", str(tmp_path / "whole.h5"))
    assert whole.returncode == 0, whole.stderr
    with h5py.File(out, "r") as a, h5py.File(tmp_path / "whole.h5", "r") as b:
        assert a["t"].shape[0] == b["t"].shape[0] > 20
        for name in ["t", "q", "p", "energy", "energy_post", "residual", "gap"]:
            assert np.array_equal(a[name][()].view(np.uint64), b[name][()].view(np.uint64)), name
        assert a["summary"].attrs["steps"] == b["summary"].attrs["steps"]


def test_a_resume_refuses_an_hdf5_file_another_run_wrote(tmp_path):
    # The checkpoint and the file carry the run's id: another run's file at that path (the same
    # command run again included: it is another run, with its own attributes) is refused and kept.
    args = ["run", "sleigh_chain", "--set", "bodies=5", "--out", str(tmp_path / "o.h5")]
    assert cli(*args, "--t-end", "2", "--checkpoint", str(tmp_path / "ck.h5")).returncode == 0
    assert cli(*args, "--t-end", "4").returncode == 0
    before = (tmp_path / "o.h5").read_bytes()
    done = cli("run", "--resume", str(tmp_path / "ck.h5"), "--t-end", "3")
    assert done.returncode == 1 and "it is not the file this run wrote (its run_id is" in done.stderr, done.stderr
    assert (tmp_path / "o.h5").read_bytes() == before


def test_files_say_what_they_hold(tmp_path):
    # The dt and t_end used (the scene's defaults here, not sentinels), the steps, the version and
    # the checkout's revision, the units convention and the command that made the file.
    done = cli("run", "sleigh", "--out", str(tmp_path / "r.h5"))
    assert done.returncode == 0, done.stderr
    with h5py.File(tmp_path / "r.h5", "r") as f:
        a = f.attrs
        assert a["dt"] == 0.01 and a["t_end"] == 10.0 and a["steps"] == 1000
        assert text(a["nonholo_version"]).count(".") == 2 and len(text(a["git_revision"])) > 0
        assert text(a["target_arch"]) == nonholo.__target_arch__  # "portable" or "-march=..."
        assert "consistent units, SI suggested" in text(a["units"])
        assert text(a["command"]) == "nonholo run sleigh --out " + str(tmp_path / "r.h5")
    done = cli("batch", "sleigh", "--count", "2", "--t-end", "0.5", "--out", str(tmp_path / "b.h5"))
    assert done.returncode == 0, done.stderr
    with h5py.File(tmp_path / "b.h5", "r") as f:
        assert f.attrs["dt"] == 0.01 and f.attrs["t_end"] == 0.5 and f.attrs["steps"] == 50
    r = nonholo.run("sleigh", t_end=0.2, out=tmp_path / "p.h5")
    with h5py.File(tmp_path / "p.h5", "r") as f:
        assert text(f.attrs["command"]).startswith("nonholo run sleigh --t-end 0.2 --out ")
        assert text(f.attrs["command"]).endswith("(from Python)")


def _slabs(grid):
    """The (start, stride, count) hyperslabs of a frame grid, geometry first."""
    out = []
    for item in grid.iter("DataItem"):
        if item.get("ItemType") == "HyperSlab":
            numbers = [int(v) for v in item.find("DataItem").text.split()]
            out.append((numbers[0], numbers[1], numbers[3], numbers[5]))  # frame, first column, stride, count
    return out


def test_an_xdmf_sidecar_shows_the_bodies_in_paraview(tmp_path):
    # run.h5 -> run.xdmf: one grid per frame whose hyperslabs pick, from /q, exactly the columns
    # named x<i>, y<i> (and theta<i> as an attribute) of that frame; a model with no centres
    # (the Suslov top) gets none.
    import xml.etree.ElementTree as ET
    assert cli("run", "wheeled_train", "--set", "bodies=4", "--t-end", "0.5", "--every", "10",
               "--out", str(tmp_path / "run.h5")).returncode == 0
    root = ET.parse(tmp_path / "run.xdmf").getroot()
    frames = root.find("Domain").find("Grid").findall("Grid")
    with h5py.File(tmp_path / "run.h5", "r") as f:
        names = [text(n) for n in f["coordinates"][()]]
        t = f["t"][()]
        assert len(frames) == len(t) == 6
        for grid in frames:
            k = int(grid.get("Name").split()[1])
            assert float(grid.find("Time").get("Value")) == t[k]
            assert grid.find("Geometry").get("GeometryType") == "X_Y"
            for (frame, first, stride, count), letter in zip(_slabs(grid), ["x", "y", "theta"]):
                assert frame == k and count == 4
                assert [names[first + i * stride] for i in range(count)] == ["%s%d" % (letter, i) for i in range(4)]
            source = grid.find("Geometry").find("DataItem").findall("DataItem")[1]
            assert source.text == "run.h5:/q" and source.get("Dimensions") == "6 %d" % len(names)
    assert cli("run", "suslov", "--t-end", "0.1", "--out", str(tmp_path / "top.h5")).returncode == 0
    assert not (tmp_path / "top.xdmf").exists()


@pytest.mark.parametrize("name", ["a&b", "x<y>z", "h<!--<script>--&", "a--b-", "]]>", "quote\"and'", "ünï©ødé", "t&amp;"])
def test_any_file_name_leaves_the_xdmf_well_formed(tmp_path, name):
    # The name is XML-escaped where it is data (&, <, >) and kept out of "--" in the comment: the
    # sidecar parses (a real XML parser) and names the file exactly.
    import xml.etree.ElementTree as ET
    out = tmp_path / (name + ".h5")
    assert cli("run", "sleigh_chain", "--set", "bodies=3", "--t-end", "0.2", "--out", str(out)).returncode == 0
    root = ET.parse(tmp_path / (name + ".xdmf")).getroot()
    sources = [d for d in root.iter("DataItem") if d.get("Format") == "HDF"]
    assert sources and all(d.text == name + ".h5:/q" for d in sources)


def test_random_file_names_leave_the_xdmf_well_formed(tmp_path):
    # The property on random names of dangerous pieces (two seeds' worth, 20 names).
    import xml.etree.ElementTree as ET
    random = np.random.default_rng(37)
    pieces = ["&", "<", ">", "-", "--", "]]>", "<!--", "-->", "\"", "'", "&amp;", "?>", "<?", "x", "\u00e9", " "]
    for k in range(20):
        name = "%d%s" % (k, "".join(random.choice(pieces, size=random.integers(1, 10))))
        out = tmp_path / (name + ".h5")
        assert cli("run", "sleigh_chain", "--set", "bodies=2", "--t-end", "0.05", "--out", str(out)).returncode == 0
        root = ET.parse(tmp_path / (name + ".xdmf")).getroot()
        assert all(d.text == name + ".h5:/q" for d in root.iter("DataItem") if d.get("Format") == "HDF"), name


def test_a_file_name_xml_cannot_hold_gets_no_sidecar(tmp_path):
    # A control character or invalid UTF-8 cannot be written in XML 1.0, even as an entity: the
    # run and its HDF5 file are as any other, without the sidecar.
    for name in ("ctl\x01", os.fsdecode(b"bad\xff")):
        out = tmp_path / (name + ".h5")
        done = subprocess.run([CLI, "run", "sleigh_chain", "--set", "bodies=3", "--t-end", "0.2", "--out", str(out)],
                              capture_output=True)  # bytes: the name is echoed
        assert done.returncode == 0, done.stderr
        assert out.exists() and not (tmp_path / (name + ".xdmf")).exists()



def test_a_checkpoint_is_never_torn(tmp_path):
    # kill -9 at five moments of a run that checkpoints every 5 steps (about 20 times a second):
    # the checkpoint file is always whole (written aside, flushed, renamed), and resumes.
    args = ["run", "sleigh_chain", "--set", "bodies=2000", "--t-end", "1e6"]
    for i, delay in enumerate([0.5, 0.9, 1.3, 1.8, 2.4]):
        checkpoint = tmp_path / ("ck%d.h5" % i)
        child = subprocess.Popen([CLI, *args, "--checkpoint", str(checkpoint), "--checkpoint-every", "5"],
                                 stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        time.sleep(delay)
        child.send_signal(signal.SIGKILL)
        child.wait()
        if not checkpoint.exists():
            continue  # killed before the first one
        with h5py.File(checkpoint, "r") as f:
            t, step = float(f.attrs["t"]), int(f.attrs["step"])
        assert step % 5 == 0
        done = cli("run", "--resume", str(checkpoint), "--t-end", repr(t + 0.05))
        assert done.returncode == 0, done.stderr
        assert summary_of(done.stdout)["steps"] == str(step + 5)
