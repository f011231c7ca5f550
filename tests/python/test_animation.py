"""`nonholo animate` and nonholo.animate: GIF and MP4 of short runs, their frame counts and sizes,
bodies drawn where the file says, and the messages for input that cannot be animated."""
import math
import os
import shutil
import subprocess

import numpy as np
import pytest

import nonholo
from nonholo import _animation
from support import CLI, cli

Image = pytest.importorskip("PIL.Image")


def run(tmp_path, name, *args):
    path = str(tmp_path / name)
    done = cli("run", *args, "--out", path)
    assert done.returncode == 0, done.stderr
    return path


def gif_frames(path):
    with Image.open(path) as im:
        return im.n_frames, im.size


def last_frame(path):
    with Image.open(path) as im:
        im.seek(im.n_frames - 1)
        return np.asarray(im.convert("RGB")).astype(int)


def rgb(colour):
    return np.array([int(colour[k:k + 2], 16) for k in (1, 3, 5)])


def near(image, pixel, colour, reach=3, tol=40):
    """Whether a pixel within `reach` of `pixel` has about the colour."""
    x, y = int(round(pixel[0])), int(round(pixel[1]))
    patch = image[max(0, y - reach):y + reach + 1, max(0, x - reach):x + reach + 1]
    return bool((np.abs(patch - rgb(colour)).max(axis=2) <= tol).any())


def test_gif_of_a_sleigh_from_hdf5_by_the_cli(tmp_path):
    h5 = run(tmp_path, "sleigh.h5", "sleigh", "--t-end", "2")
    gif = tmp_path / "sleigh.gif"
    done = cli("animate", h5, "-o", str(gif), "--frames", "7", "--width", "320", "--fps", "10", "--trail", "0.5")
    assert done.returncode == 0, done.stderr
    assert gif_frames(gif) == (7, (320, 240))


def test_gif_of_a_chain_from_csv_by_the_function(tmp_path):
    csv = run(tmp_path, "chain.csv", "sleigh_chain", "--set", "bodies=5", "--t-end", "1", "--every", "25")
    gif = tmp_path / "chain.gif"
    nonholo.animate(nonholo.load(csv), gif, width=200, follow=True)  # 5 frames in the file, fewer than 100
    assert gif_frames(gif) == (5, (200, 150))
    done = cli("animate", csv, "-o", str(tmp_path / "all.gif"), "--frames", "1000", "--width", "100")
    assert done.returncode == 0, done.stderr
    assert gif_frames(tmp_path / "all.gif") == (5, (100, 76))


def test_mp4_of_a_20_body_train_following_the_front(tmp_path):
    if shutil.which("ffprobe") is None:
        pytest.skip("no ffprobe (Debian: ffmpeg)")
    h5 = run(tmp_path, "train.h5", "wheeled_train", "--set", "bodies=20", "--t-end", "3")
    mp4 = tmp_path / "train.mp4"
    done = cli("animate", h5, "-o", str(mp4), "--follow", "--frames", "12", "--width", "320", "--trail", "1")
    assert done.returncode == 0, done.stderr
    probe = subprocess.run(["ffprobe", "-v", "error", "-select_streams", "v:0", "-count_frames", "-show_entries",
                            "stream=nb_read_frames,width,height", "-of", "csv=p=0", str(mp4)],
                           capture_output=True, text=True, check=True)
    width, height, count = probe.stdout.strip().split(",")
    assert (int(width), int(height), int(count)) == (320, 240, 12)


@pytest.mark.parametrize("scene", ["chaplygin_ball", "suslov"])
def test_rigid_bodies_from_above(tmp_path, scene):
    h5 = run(tmp_path, scene + ".h5", scene, "--t-end", "2")
    gif = tmp_path / (scene + ".gif")
    anim = _animation.animate(h5, gif, frames=2, width=320)
    assert gif_frames(gif) == (2, (320, 240))
    r = nonholo.load(h5)
    image = last_frame(gif)
    centre = (0.0, 0.0)
    if "x0" in r.coordinates:
        centre = (r.q[-1, r.coordinates.index("x0")], r.q[-1, r.coordinates.index("y0")])
    # The ball (radius r = 1) is filled around its centre: most points at 0.8 r have its colour.
    ring = [anim.to_pixel(1, centre[0] + 0.8 * math.cos(a), centre[1] + 0.8 * math.sin(a))
            for a in np.linspace(0, 2 * math.pi, 12, endpoint=False)]
    assert sum(near(image, p, _animation.BALL, reach=1) for p in ring) >= 9


def test_a_ball_chains_rods_are_drawn_between_the_centres(tmp_path):
    h5 = run(tmp_path, "balls.h5", "ball_chain", "--t-end", "1")
    r = nonholo.load(h5)
    gif = tmp_path / "balls.gif"
    anim = _animation.animate(h5, gif, frames=2, width=480, trail=0)
    image = last_frame(gif)
    for b in range(2):  # the middle of each rod (length 3) lies outside both balls (radius 1)
        x = [r.q[-1, r.coordinates.index("x%d" % k)] for k in (b, b + 1)]
        y = [r.q[-1, r.coordinates.index("y%d" % k)] for k in (b, b + 1)]
        middle = anim.to_pixel(1, 0.5 * (x[0] + x[1]), 0.5 * (y[0] + y[1]))
        assert near(image, middle, _animation.LINK, reach=2), "rod %d-%d not drawn at %s" % (b, b + 1, middle)


def test_bodies_are_drawn_where_the_file_says(tmp_path):
    h5 = run(tmp_path, "chain.h5", "sleigh_chain", "--set", "bodies=5", "--t-end", "4")
    r = nonholo.load(h5)
    gif = tmp_path / "chain.gif"
    anim = _animation.animate(h5, gif, frames=2, width=480, trail=0)
    assert anim.indices == [0, r.t.size - 1]
    image = last_frame(gif)
    for b in range(5):
        x, y = r.q[-1, r.coordinates.index("x%d" % b)], r.q[-1, r.coordinates.index("y%d" % b)]
        colour = _animation.LEAD if b == 0 else _animation.BODY
        # the body's centre, a little ahead of its blade line
        theta = r.q[-1, r.coordinates.index("theta%d" % b)]
        ahead = anim.to_pixel(1, x + 0.15 * math.cos(theta), y + 0.15 * math.sin(theta))
        assert near(image, ahead, colour), "body %d not drawn at %s" % (b, ahead)
    # and nothing of a body's colour far from every body (the chain is in a fixed view)
    x0, x1, y0, y1 = anim.limits[1]
    assert not near(image, anim.to_pixel(1, x0 + 0.02 * (x1 - x0), y0 + 0.02 * (y1 - y0)), _animation.BODY)


def animate_cli(*args):
    done = cli("animate", *args)
    return done.returncode, done.stderr


@pytest.mark.parametrize("bad", ["nan", "inf", "-1.7e308", "1e200"])
def test_frames_that_cannot_be_drawn_are_left_out_and_said(tmp_path, bad):
    # A file whose coordinates turn NaN, infinite or enormous at some frame (another tool's, or
    # edited): animate raised matplotlib's traceback ("Axis limits cannot be NaN or Inf", then an
    # IndexError), view "Out of range float values are not JSON compliant". Both now show the
    # frames before it and say what was left out; a first frame so is refused.
    import csv as csvlib
    path = run(tmp_path, "run.csv", "sleigh_chain", "--set", "bodies=3", "--t-end", "1", "--every", "10")
    with open(path, newline="") as f:
        rows = list(csvlib.reader(f))
    rows[5][1] = bad  # x0 at t = 0.4 (row 0 is the header)
    edited = tmp_path / "edited.csv"
    with open(edited, "w", newline="") as f:
        csvlib.writer(f).writerows(rows)
    note = "frames from t = 0.4 on cannot be drawn (x0 is %r: NaN, infinite or beyond 1e+150" % float(bad)
    done = cli("animate", str(edited), "-o", str(tmp_path / "a.gif"))
    assert done.returncode == 0 and note in done.stderr and "shown up to t = 0.3" in done.stderr, done.stderr
    assert gif_frames(tmp_path / "a.gif")[0] == 4
    assert note in nonholo.view(edited, tmp_path / "v.html")
    done = cli("view", str(edited), "-o", str(tmp_path / "v2.html"))
    assert done.returncode == 0 and note in done.stderr, done.stderr
    rows[1][2] = bad  # y0 of the first frame
    with open(edited, "w", newline="") as f:
        csvlib.writer(f).writerows(rows)
    for command, out in (("animate", "b.gif"), ("view", "b.html")):
        done = cli(command, str(edited), "-o", str(tmp_path / out))
        assert done.returncode == 1 and "its first frame cannot be drawn: y0 is %r" % float(bad) in done.stderr, done.stderr
        assert "Traceback" not in done.stderr


def test_a_package_not_found_says_where_it_was_looked_for(tmp_path):
    # python3 said only "No module named 'nonholo'" (a copied or moved build, not installed).
    nowhere = tmp_path / "nowhere"
    env = dict(os.environ, NONHOLO_PYTHONPATH=str(nowhere))
    done = subprocess.run([CLI, "animate", "x.csv", "-o", str(tmp_path / "x.gif")], env=env, capture_output=True,
                          text=True)
    assert done.returncode == 1, done.stderr
    assert ("cannot find nonholo's Python package (nonholo/__init__.py); looked in %s: run the nonholo of a build "
            "tree (python/ beside it)" % nowhere) in done.stderr


def test_messages(tmp_path):
    h5 = run(tmp_path, "sleigh.h5", "sleigh", "--t-end", "0.5")
    code, err = animate_cli(str(tmp_path / "missing.h5"), "-o", str(tmp_path / "x.gif"))
    assert code == 1 and "missing.h5: no such file" in err
    (tmp_path / "notes.txt").write_text("x\n")
    code, err = animate_cli(str(tmp_path / "notes.txt"), "-o", str(tmp_path / "x.gif"))
    assert code == 1 and "expected a run's output file, FILE.csv or FILE.h5" in err
    code, err = animate_cli(h5, "-o", str(tmp_path / "x.png"))
    assert code == 1 and "must be OUT.gif or OUT.mp4" in err
    code, err = animate_cli(h5)
    assert code == 1 and "nonholo animate" in err and "-o" in err
    code, err = animate_cli(h5, "-o", str(tmp_path / "x.gif"), "--frames", "0")
    assert code == 1 and "frames: expected an integer of at least 1" in err
    batch = str(tmp_path / "batch.csv")
    assert cli("batch", "sleigh", "--count", "2", "--t-end", "0.1", "--out", batch).returncode == 0
    code, err = animate_cli(batch, "-o", str(tmp_path / "x.gif"))
    assert code == 1 and "is a batch's output" in err
    plain = tmp_path / "plain.csv"
    plain.write_text("t,u,v,energy,energy_post,residual\n0,1,2,0,0,0\n")
    code, err = animate_cli(str(plain), "-o", str(tmp_path / "x.gif"))
    assert code == 1 and "no coordinates to draw" in err and "u, v" in err
    with pytest.raises(ValueError, match="no coordinates to draw"):
        nonholo.animate(str(plain), tmp_path / "x.gif")
    # no ffmpeg on PATH: the MP4 is refused, naming the Debian package
    empty = tmp_path / "bin"
    empty.mkdir()
    tool = os.environ.get("NONHOLO_CLI", "nonholo")
    tool = os.path.abspath(tool) if os.sep in tool else shutil.which(tool)
    done = subprocess.run([tool, "animate", h5, "-o",
                           str(tmp_path / "x.mp4")], capture_output=True, text=True,
                          env=dict(os.environ, PATH=str(empty)))
    assert done.returncode == 1 and "needs ffmpeg" in done.stderr and "apt-get install ffmpeg" in done.stderr
    assert not (tmp_path / "x.mp4").exists() and not (tmp_path / "x.gif").exists()
