"""`nonholo view`: the HTML viewer, opened as a person would, in a browser (Debian's chromium,
headless) from disk: bodies drawn where the file says (pixel checks at positions computed from
the file's coordinates with the viewer's documented initial world-to-screen transform,
nonholo/_viewer.py), two times differ, no error in the page (the page writes every error and
console.error into #errors and body[data-errors]), bad input refused with exit code 1, the size
of the page and the frame time for a 1000-body train."""
import html
import json
import os
import pathlib
import re
import shutil
import subprocess
import sys

import numpy as np
import pytest

import nonholo
from support import cli

Image = pytest.importorskip("PIL.Image")
CHROMIUM = shutil.which("chromium")
WIDTH, HEIGHT = 1200, 800
MARGIN_PX = 40  # nonholo._viewer.MARGIN_PX: the documented margin of the initial view


def browser(html_path, fragment, screenshot=None):
    """Loads the page in headless chromium at URL fragment; returns the DOM after it ran (and
    writes a screenshot when asked)."""
    if CHROMIUM is None:
        pytest.skip("no chromium (Debian: chromium, tools/setup.sh)")
    args = [CHROMIUM, "--headless=new", "--no-sandbox", "--disable-gpu", "--hide-scrollbars",
            "--window-size=%d,%d" % (WIDTH, HEIGHT), "--virtual-time-budget=3000", "--force-device-scale-factor=1"]
    args += ["--screenshot=%s" % screenshot] if screenshot else ["--dump-dom"]
    url = "file://%s#%s" % (os.path.abspath(html_path), fragment)
    done = subprocess.run(args + [url], capture_output=True, text=True, timeout=90)
    assert done.returncode == 0, done.stderr[-2000:]
    if screenshot:
        assert os.path.isfile(screenshot), done.stderr[-2000:]
    return done.stdout


def body_attributes(dom):
    """body's data-* attributes, unescaped."""
    tag = re.search(r"<body([^>]*)>", dom).group(1)
    return {k: html.unescape(v) for k, v in re.findall(r'data-([a-z]+)="([^"]*)"', tag)}


def assert_no_errors(dom):
    attrs = body_attributes(dom)
    errors = re.search(r'<pre id="errors"[^>]*>(.*?)</pre>', dom, re.S).group(1)
    assert "errors" not in attrs and errors.strip() == "", html.unescape(errors)
    assert attrs.get("ready") == "1", "the page did not finish drawing"
    return attrs


def run_to(tmp_path, name, *args):
    out = tmp_path / (name + ".h5")
    done = cli("run", name, "--out", str(out), *args)
    assert done.returncode == 0, done.stderr
    return out


def view(source, target, *args):
    done = cli("view", str(source), "-o", str(target), *args)
    assert done.returncode == 0, done.stderr
    return target


def saturated(pixel):
    r, g, b = pixel[:3]
    return max(r, g, b) - min(r, g, b) > 80


def test_a_planar_chain_is_drawn_where_the_file_says(tmp_path):
    data = run_to(tmp_path, "sleigh_chain", "--set", "bodies=5", "--t-end", "4", "--every", "10")
    page = view(data, tmp_path / "chain.html")
    result = nonholo.load(data)
    xs = result.q[:, [result.coordinates.index("x%d" % i) for i in range(5)]]
    ys = result.q[:, [result.coordinates.index("y%d" % i) for i in range(5)]]
    # the documented initial transform: every centre over every frame, fitted with the margin
    shots = {}
    for t in (1.0, 4.0):
        k = int(np.argmin(abs(result.t - t)))
        assert abs(result.t[k] - t) < 1e-9
        dom = browser(page, "t=%g&paused=1" % t)
        attrs = assert_no_errors(dom)
        v = json.loads(attrs["view"])
        scale = min((v["width"] - 2 * MARGIN_PX) / (xs.max() - xs.min()),
                    (v["height"] - 2 * MARGIN_PX) / (ys.max() - ys.min()))
        assert v["scale"] == pytest.approx(scale, rel=1e-9)
        cx, cy = (xs.max() + xs.min()) / 2, (ys.max() + ys.min()) / 2
        shot = tmp_path / ("chain-%g.png" % t)
        browser(page, "t=%g&paused=1" % t, screenshot=shot)
        image = Image.open(shot).convert("RGB")
        assert image.size == (WIDTH, HEIGHT)
        # chromium's --dump-dom lays the page out in a smaller viewport than --screenshot: the
        # screenshot's canvas is the page's layout (viewer.html): left 0, top 0, 300 px panel on
        # the right, 44 px controls below
        v = dict(left=0, top=0, width=WIDTH - 300, height=HEIGHT - 44)
        scale = min((v["width"] - 2 * MARGIN_PX) / (xs.max() - xs.min()),
                    (v["height"] - 2 * MARGIN_PX) / (ys.max() - ys.min()))
        for i in range(5):
            X = v["left"] + v["width"] / 2 + (xs[k, i] - cx) * scale
            Y = v["top"] + v["height"] / 2 - (ys[k, i] - cy) * scale
            pixel = image.getpixel((int(round(X)), int(round(Y))))
            assert saturated(pixel), "body %d at t=%g: pixel %s at (%.1f, %.1f) is not a body's" % (i, t, pixel, X, Y)
            if i == 0:  # the lead is red
                assert pixel[0] > 150 and pixel[1] < 100, pixel
        shots[t] = (image, k, v, scale, cx, cy)
    (a, ka, v, scale, cx, cy), (b, kb, _, _, _, _) = shots[1.0], shots[4.0]
    stage = (0, 0, int(v["width"]), int(v["height"]))
    assert np.abs(np.asarray(a.crop(stage), int) - np.asarray(b.crop(stage), int)).sum() > 0
    # the lead moved: where it was at t = 1 it is no longer red at t = 4
    X = v["left"] + v["width"] / 2 + (xs[ka, 0] - cx) * scale
    Y = v["top"] + v["height"] / 2 - (ys[ka, 0] - cy) * scale
    assert np.hypot(xs[kb, 0] - xs[ka, 0], ys[kb, 0] - ys[ka, 0]) * scale > 30
    assert b.getpixel((int(round(X)), int(round(Y))))[:3] != a.getpixel((int(round(X)), int(round(Y))))[:3]
    # follow: the view centred on the mean of the bodies' centres, at the same scale
    followed = json.loads(assert_no_errors(browser(page, "t=1&paused=1&follow=1"))["view"])
    assert (followed["cx"], followed["cy"]) == pytest.approx((xs[ka].mean(), ys[ka].mean()), abs=1e-5)


def test_a_3d_scene_is_drawn_with_three_js_and_moves(tmp_path):
    if not (pathlib.Path(nonholo.__file__).parent / "viewer" / "three.module.min.js").is_file():
        pytest.skip("three.js was not vendored at configure time (no network: see CMake's warning)")
    data = run_to(tmp_path, "chaplygin_ball", "--t-end", "3", "--every", "10")
    page = view(data, tmp_path / "ball.html")
    assert "window.THREE={" in page.read_text()
    result = nonholo.load(data)
    r = 1.0  # the scene's default radius
    centres = np.stack([result.q[:, result.coordinates.index("x0")], result.q[:, result.coordinates.index("y0")],
                        np.full(len(result.t), r)], axis=1)
    images = []
    for t in (0, 3):
        attrs = assert_no_errors(browser(page, "t=%g&paused=1&axes=0" % t))
        assert attrs["mode"] == "3d", "no WebGL in this chromium"
        assert attrs["axes"] == "0"
        shot = tmp_path / ("ball-%g.png" % t)
        browser(page, "t=%g&paused=1&axes=0" % t, screenshot=shot)  # the ball alone: its centre below
        stage = np.asarray(Image.open(shot).convert("RGB").crop((0, 0, WIDTH - 300, HEIGHT - 44)), int)
        coloured = (stage.max(axis=2) - stage.min(axis=2)) > 60  # the ball's octants
        assert coloured.sum() > 2000, "no ball drawn at t=%g" % t
        # where the ball's centre is on the screen by the documented initial camera (_viewer.py)
        X, Y = project(centres[int(np.argmin(abs(result.t - t)))], centres, r, stage.shape[1], stage.shape[0])
        rows, cols = np.nonzero((stage.max(axis=2) - stage.min(axis=2)) > 20)  # the ball, not the grey grid
        middle = ((cols.min() + cols.max()) / 2, (rows.min() + rows.max()) / 2)
        assert np.hypot(middle[0] - X, middle[1] - Y) < 6, (middle, X, Y)
        images.append(stage)
    assert np.abs(images[0] - images[1]).sum() > 1000
    # By default each body frame's axes are drawn (1.8 r from the centre: 0.8 r of each outside the
    # ball): the pixels that differ from the same view without them, around the ball's centre;
    # between t = 0 and 3 the ball turned, and so did they (their pixels' mean offset from the
    # centre moved).
    offsets = []
    for t, plain in zip((0, 3), images):
        assert assert_no_errors(browser(page, "t=%g&paused=1" % t))["axes"] == "1"
        shot = tmp_path / ("axes-%g.png" % t)
        browser(page, "t=%g&paused=1" % t, screenshot=shot)
        stage = np.asarray(Image.open(shot).convert("RGB").crop((0, 0, WIDTH - 300, HEIGHT - 44)), int)
        rows, cols = np.nonzero(np.abs(stage - plain).sum(axis=2) > 60)
        X, Y = project(centres[int(np.argmin(abs(result.t - t)))], centres, r, stage.shape[1], stage.shape[0])
        reach = np.hypot(cols - X, rows - Y)
        print("t = %g: %d pixels of axes, up to %.0f px from the centre" % (t, len(rows), reach.max(initial=0)))
        assert len(rows) > 30, "no body axes drawn at t=%g" % t
        assert reach.max() < 3 * radius_px(centres, r, stage.shape[0]), "axes drawn away from the ball"
        offsets.append(np.array([(cols - X).mean(), (rows - Y).mean()]))
    assert np.hypot(*(offsets[0] - offsets[1])) > 3, ("the axes did not turn with the ball", offsets)


def radius_px(centres, r, height):
    """About the ball's radius on the screen in pixels at the documented initial camera's distance."""
    lo, hi = centres.min(axis=0), centres.max(axis=0)
    size = max((hi - lo).max(), 4 * r)
    dist = 1.3 * (size / 2 + 2 * r) / np.tan(np.radians(20))
    return r / (dist * np.tan(np.radians(20))) * height / 2


def project(point, centres, r, width, height):
    """The 3-D view's initial camera (nonholo/_viewer.py): looking at the centre of the centres'
    bounding box from azimuth -60 deg, elevation 0.5 rad, at 1.3 (size / 2 + 2 r) / tan(20 deg),
    size the box's largest side (at least 4 r); 40 deg vertical field of view; z up."""
    lo, hi = centres.min(axis=0), centres.max(axis=0)
    target = (lo + hi) / 2
    size = max((hi - lo).max(), 4 * r)
    az, el, dist = -np.pi / 3, 0.5, 1.3 * (size / 2 + 2 * r) / np.tan(np.radians(20))
    camera = target + dist * np.array([np.cos(el) * np.cos(az), np.cos(el) * np.sin(az), np.sin(el)])
    forward = (target - camera) / np.linalg.norm(target - camera)
    right = np.cross(forward, [0, 0, 1])
    right /= np.linalg.norm(right)
    up = np.cross(right, forward)
    d = np.asarray(point) - camera
    depth, half = d @ forward, np.tan(np.radians(20))
    x, y = (d @ right) / (depth * half * width / height), (d @ up) / (depth * half)
    return (x + 1) / 2 * width, (1 - y) / 2 * height


# Texts that would change the page's structure if inlined as they are: "<!--<script>" switches the
# HTML parser into a state where "</script>" no longer ends the data block (the whole page blanked
# while only "</" was escaped), the others end elements or open new ones.
HOSTILE = ["<!--<script>", "</script><script>document.body.dataset.injected = 1</script>",
           "<img src=x onerror=\"document.body.dataset.injected = 1\">", "--><!--", "]]>", "&amp;&lt;",
           "\u2028\u2029", "\"'`${1}"]


def test_hostile_text_cannot_change_the_page(tmp_path):
    # From a title, a scene file's name and description (they reach the summary's scene and
    # command): the page runs (ready, no error, nothing injected) and shows each text as it is.
    scene = json.loads((pathlib.Path(__file__).parents[2] / "examples" / "scenes" / "towed_pair.json").read_text())
    scene["description"] = " ".join(HOSTILE)
    path = tmp_path / "x<!--<script>&\"'.json"  # no "/" in a file's name
    path.write_text(json.dumps(scene))
    data = run_to(tmp_path, str(path), "--t-end", "1", "--every", "10")
    title = "".join(HOSTILE)
    page = view(data, tmp_path / "hostile.html", "--title", title)
    dom = browser(page, "t=0.5&paused=1")
    attrs = assert_no_errors(dom)
    assert "injected" not in attrs
    heading = re.search(r'<h2 id="heading">(.*?)</h2>', dom, re.S).group(1)
    assert html.unescape(heading) == title
    info = html.unescape(re.search(r'<div id="info"[^>]*>(.*?)</div>', dom, re.S).group(1))
    assert info.startswith(str(path) + ", planar"), info


@pytest.mark.parametrize("seed", range(3))
def test_no_inlined_text_holds_markup(tmp_path, seed):
    # The property behind it, on random texts of dangerous pieces: the page's data block holds no
    # "<" at all (nothing can end it or change the parser's state) and reads back as the data; the
    # title holds no markup character.
    from nonholo import _viewer
    result = nonholo.load(run_to(tmp_path, "sleigh", "--t-end", "0.5"))
    random = np.random.default_rng(seed)
    pieces = HOSTILE + ["<", ">", "&", "/", "!", "-", "<\\/", "\\", "\"", "x", "\u00e9", "\U0001F600"]
    for _ in range(50):
        title = "".join(random.choice(pieces, size=random.integers(1, 12)))
        page = _viewer.build_page(result, title=title)
        block = re.search(r'<script type="application/json" id="meta">(.*?)</script>', page, re.S).group(1)
        assert "<" not in block
        meta = json.loads(block)
        assert meta["title"] == title
        head = re.search(r"<title>(.*?)</title>", page, re.S).group(1)
        assert not set(head) & set("<>\"") and html.unescape(head) == title


def test_a_csv_file_plays_too(tmp_path):
    csv = tmp_path / "sleigh.csv"
    assert cli("run", "sleigh", "--t-end", "2", "--out", str(csv)).returncode == 0
    page = view(csv, tmp_path / "sleigh.html")
    dom = browser(page, "t=1&paused=1")
    assert_no_errors(dom)
    assert "a CSV file has no summary" in dom


def test_bad_input_is_refused_with_a_message(tmp_path):
    done = cli("view", str(tmp_path / "missing.h5"), "-o", str(tmp_path / "x.html"))
    assert done.returncode == 1 and "missing.h5: no such file" in done.stderr
    done = cli("view", str(tmp_path / "x.txt"), "-o", str(tmp_path / "x.html"))
    assert done.returncode == 1 and "expected a run's .h5" in done.stderr
    data = run_to(tmp_path, "sleigh", "--t-end", "0.1")
    done = cli("view", str(data), "-o", str(tmp_path / "x.png"))
    assert done.returncode == 1 and "HTML" in done.stderr
    done = cli("view", str(data), "-o", str(tmp_path / "x.html"), "--max-frames", "0")
    assert done.returncode == 1 and "at least 1" in done.stderr
    batch = tmp_path / "batch.h5"
    assert cli("batch", "sleigh", "--count", "2", "--t-end", "0.1", "--out", str(batch)).returncode == 0
    done = cli("view", str(batch), "-o", str(tmp_path / "x.html"))
    assert done.returncode == 1 and "batch" in done.stderr
    broken = tmp_path / "broken.h5"
    broken.write_bytes(b"not hdf5")
    done = cli("view", str(broken), "-o", str(tmp_path / "x.html"))
    assert done.returncode == 1 and "broken.h5" in done.stderr and "Traceback" not in done.stderr
    assert not (tmp_path / "x.html").exists()


def test_a_3d_scene_without_three_js_says_what_is_missing(tmp_path):
    from nonholo import _viewer
    data = run_to(tmp_path, "suslov", "--t-end", "0.1")
    with pytest.raises(_viewer.ViewError, match=r"needs three\.js.*nonexistent/three\.module\.min\.js is missing"):
        _viewer.build_page(nonholo.load(data), str(data), three="/nonexistent/three.module.min.js")
    # a planar scene needs no three.js
    planar = run_to(tmp_path, "sleigh", "--t-end", "0.1")
    assert "window.THREE={" not in _viewer.build_page(nonholo.load(planar), str(planar), three="/nonexistent/x.js")


def test_decimation_keeps_the_lead_and_the_tail(tmp_path):
    from nonholo import _viewer
    data = run_to(tmp_path, "sleigh_chain", "--set", "bodies=50", "--t-end", "1")
    text = _viewer.build_page(nonholo.load(data), str(data), max_frames=7, max_bodies=6)
    meta = json.loads(re.search(r'<script type="application/json" id="meta">(.*?)</script>', text, re.S).group(1))
    assert meta["bodies"][0] == 0 and meta["bodies"][-1] == 49 and len(meta["bodies"]) == 6
    assert len(meta["t"]) == 7 and meta["t"][0] == 0 and meta["t"][-1] == pytest.approx(1)


def test_the_main_job_size_and_frame_time(tmp_path):
    """The 1000-body wheeled_train of the issue (--every 20: 101 frames): the page's size, and the
    mean time of 100 redraws (with a read-back that makes the canvas finish) in headless chromium."""
    data = run_to(tmp_path, "wheeled_train", "--every", "20")
    page = view(data, tmp_path / "train.html")
    size = page.stat().st_size
    attrs = assert_no_errors(browser(page, "bench=1"))
    frame_ms = float(attrs["bench"])
    sys.stderr.write("wheeled_train 1000 bodies: HTML %.2f MB, %.2f ms a frame\n" % (size / 1e6, frame_ms))
    assert size < 4e6
    assert frame_ms < 100


def test_a_long_train_is_followed_by_default_and_readable(tmp_path):
    # The 1000-body train in one view of its whole run drew each body under 2 pixels apart. By
    # default the page follows the front (the first 20 drawn bodies): centred on their mean, at
    # the documented scale, which spaces its bodies tens of pixels apart; follow=0 is the whole run.
    data = run_to(tmp_path, "wheeled_train", "--every", "20", "--t-end", "10")
    page = view(data, tmp_path / "train.html")
    meta = json.loads(re.search(r'<script type="application/json" id="meta">(.*?)</script>', page.read_text(),
                                re.S).group(1))
    result = nonholo.load(data)
    front = meta["bodies"][:20]
    xs = result.q[:, [result.coordinates.index("x%d" % b) for b in front]]
    ys = result.q[:, [result.coordinates.index("y%d" % b) for b in front]]
    kept = [int(np.argmin(abs(result.t - t))) for t in meta["t"]]
    reach = max(np.max(np.hypot(xs[k] - xs[k].mean(), ys[k] - ys[k].mean())) for k in kept)
    half = reach + np.hypot(xs[0, 1] - xs[0, 0], ys[0, 1] - ys[0, 0])
    k = kept[len(kept) // 2]
    v = json.loads(assert_no_errors(browser(page, "t=%r&paused=1" % float(result.t[k])))["view"])
    assert v["follow"] is True and v["front"] == 20
    assert (v["cx"], v["cy"]) == pytest.approx((xs[k].mean(), ys[k].mean()), abs=1e-6)
    # (the page holds the frames in float32: its reach differs in the 8th digit)
    assert v["scale"] == pytest.approx((min(v["width"], v["height"]) - 2 * MARGIN_PX) / (2 * half), rel=1e-6)
    spacing = np.median(np.hypot(np.diff(xs[k]), np.diff(ys[k])))  # drawn neighbours, world units
    whole = json.loads(assert_no_errors(browser(page, "t=%r&paused=1&follow=0" % float(result.t[k])))["view"])
    assert whole["follow"] is False
    assert spacing * v["scale"] > 10 and spacing * whole["scale"] < 0.2 * spacing * v["scale"], (v, whole)
