"""`nonholo view FILE.h5|FILE.csv -o OUT.html`, nonholo.view(result, path): one self-contained
HTML file that plays a run in a browser opened from disk (no server, no network).

The page (template nonholo/viewer/viewer.html) gets the frames as a base64 Float32Array and the
rest as JSON. Planar scenes (bodies with x<i>, y<i>, theta<i>; a point with x, y) are drawn on a
2-D canvas; scenes with 3-D rigid bodies (qw<i>, qx<i>, qy<i>, qz<i> and x<i>, y<i>, z<i>) with
three.js, which the build downloads from npm into nonholo/viewer/three.module.min.js
(python/CMakeLists.txt) and which is inlined into the page only for such scenes.

Decimation: at most max_frames frames (evenly spaced, the first and last kept) and at most
max_bodies bodies drawn (evenly spaced over the chain, the lead and the tail kept).

The planar view's initial world-to-screen transform (also written by the page into
document.body.dataset.view, with the canvas's position in the page): the bounding box of every
drawn body's centre over every kept frame, centred in the canvas and scaled to fit with MARGIN_PX
pixels on each side, the same scale on both axes, y up:

    X = width / 2 + (x - cx) * scale,  Y = height / 2 - (y - cy) * scale,
    scale = min((width - 2 MARGIN_PX) / max(xmax - xmin, e), (height - 2 MARGIN_PX) / max(ymax - ymin, e))

(cx, cy the box's centre; e = 1e-9, and a box of one point is taken as 1 wide and high).
The 3-D view's initial camera: looking at the centre of the centres' bounding box from azimuth
-60 degrees and elevation 0.5 rad, at a distance 1.3 (size / 2 + 2 r) / tan(20 degrees) (size: the
box's largest side, at least 4 r; r the scene's radius), a 40-degree vertical field of view, z up
(drag: orbit, shift-drag: pan, wheel: zoom). Without WebGL the page draws a top view in 2-D.
Followed (follow=1; the default for a planar system of more than 20 bodies, whose whole run in
one view would draw each body a few pixels wide): centred on the mean of the front's centres (the
first min(20, drawn) bodies, as `animate --follow`) at each time, scaled so that a square of half
side H fits, H the front's widest reach from its mean over the kept frames plus the distance of
its first two bodies at the start: scale = min(width, height) - 2 MARGIN_PX over 2 H.
URL parameters (query or fragment): t=T (start at time T), paused=1, follow=1 (0: the whole run), axes=0 (3-D: hide each
body frame's axes, drawn by default 1.8 r from the centre, x red, y green, z blue; also a checkbox),
bench=1 (time 100 redraws and write the mean into #bench and document.body.dataset.bench, in ms).
"""
from __future__ import annotations

import base64
import json
import math
import os
import re
import sys
from typing import Any, Dict, List, Optional, Sequence, Tuple, Union

import numpy as np

from ._command import CommandParser, same_file
from ._frames import drawable

MARGIN_PX = 40
DEFAULT_MAX_FRAMES = 1000
DEFAULT_MAX_BODIES = 1000
_HERE = os.path.dirname(os.path.abspath(__file__))
VIEWER_DIR = os.path.join(_HERE, "viewer")
THREE_FILE = os.path.join(VIEWER_DIR, "three.module.min.js")


class ViewError(ValueError):
    """Bad input for the viewer: the message says what is wrong."""


def _decimate(n: int, limit: int) -> np.ndarray:
    """Indices 0..n-1, at most limit of them, evenly spaced, first and last kept."""
    if n <= limit:
        return np.arange(n)
    if limit == 1:
        return np.array([0])
    return np.unique(np.round(np.linspace(0, n - 1, limit)).astype(int))


def _parameters(path: Optional[str]) -> Dict[str, float]:
    if path is None or not path.endswith((".h5", ".hdf5")):
        return {}
    try:
        import h5py
    except ImportError:  # pragma: no cover - load() has said so already
        return {}
    with h5py.File(path, "r", swmr=True) as f:
        if "parameters" not in f:
            return {}
        out: Dict[str, float] = {}
        for key, value in f["parameters"].attrs.items():
            try:
                out[str(key)] = float(value)
            except (TypeError, ValueError):
                pass
        return out


def _bodies(names: Sequence[str]) -> Tuple[str, List[Dict[str, Any]]]:
    """("rigid"|"planar", bodies): each body's suffix and its columns in q."""
    index = {n: i for i, n in enumerate(names)}
    rigid = []
    for n in names:
        m = re.fullmatch(r"qw(\d*)", n)
        if m:
            s = m.group(1)
            cols = [index.get(c + s) for c in ("qw", "qx", "qy", "qz", "x", "y", "z")]
            if None in cols[:4]:
                continue
            rigid.append({"suffix": s, "columns": cols})
    if rigid:
        return "rigid", sorted(rigid, key=lambda b: int(b["suffix"] or 0))
    planar = []
    for n in names:
        m = re.fullmatch(r"x(\d*)", n)
        if m and ("y" + m.group(1)) in index:
            s = m.group(1)
            planar.append({"suffix": s, "columns": [index[n], index["y" + s], index.get("theta" + s)]})
    if planar:
        return "planar", sorted(planar, key=lambda b: int(b["suffix"] or 0))
    raise ViewError("no bodies to draw: the coordinates (%s) have neither x<i>, y<i> (planar) nor qw<i>, qx<i>, "
                    "qy<i>, qz<i> (rigid bodies)" % ", ".join(list(names)[:8]))


def _finite(a: Optional[np.ndarray]) -> Optional[List[Optional[float]]]:
    if a is None:
        return None
    return [float(v) if math.isfinite(v) else None for v in np.asarray(a, dtype=float)]


# Everything inlined from data is escaped so that no text can change the page's structure: the
# JSON inside <script type="application/json"> holds no "<" at all (as \u003c, also ">" and "&"),
# so no "</script", "<!--" or "<script" can end the element or switch the HTML parser's state; the
# title's text holds no markup character. (Only "</" was escaped before: "<!--<script>" in a
# title blanked the page.)
_JSON_ESCAPES = {"<": "\\u003c", ">": "\\u003e", "&": "\\u0026", "\u2028": "\\u2028", "\u2029": "\\u2029"}


def _inline_json(value: Any) -> str:
    text = json.dumps(value, separators=(",", ":"), allow_nan=False)
    return re.sub("[<>&\u2028\u2029]", lambda m: _JSON_ESCAPES[m.group(0)], text)


def _html_text(text: str) -> str:
    return text.replace("&", "&amp;").replace("<", "&lt;").replace(">", "&gt;").replace('"', "&quot;")


def _rigid_shape(scene: str, params: Dict[str, float], has_z: bool, has_xy: bool) -> str:
    if scene in ("chaplygin_ball", "ball_chain"):
        return "ball"
    if scene == "rolling_disk":
        return "disk"
    if scene in ("suslov", "veselova") or not has_xy:
        return "top"
    return "ball" if not has_z else "box"


def build_page(result: Any, source: Optional[str] = None, max_frames: int = DEFAULT_MAX_FRAMES,
               max_bodies: int = DEFAULT_MAX_BODIES, title: Optional[str] = None,
               three: Optional[str] = None) -> str:
    """The HTML text for a RunResult (source: the file it came from, for /parameters and the
    page's title; three: three.module.min.js's path, default the package's)."""
    return _page(result, source, max_frames, max_bodies, title, three)[0]


def _page(result: Any, source: Optional[str], max_frames: int, max_bodies: int, title: Optional[str],
          three: Optional[str]) -> Tuple[str, str]:
    """build_page's text, and a note on the frames left out ("" when none)."""
    from . import RunResult
    if not isinstance(result, RunResult):
        raise ViewError("%s: a batch's file, not a run's: nonholo view plays one run (nonholo run --out)"
                        % (source or "result"))
    if max_frames < 1 or max_bodies < 1:
        raise ViewError("--max-frames and --max-bodies must be at least 1 (got %d, %d)" % (max_frames, max_bodies))
    t = np.asarray(result.t, dtype=float)
    q = np.asarray(result.q, dtype=float)
    if t.shape[0] == 0:
        raise ViewError("%s: the run has no frames" % (source or "result"))
    summary = dict(result.summary or {})
    scene = str(summary.get("scene", ""))
    params = _parameters(source)
    kind, bodies = _bodies(result.coordinates)
    # Frames from the first NaN, infinite or enormous coordinate on (a failed run) are left out:
    # the page's JSON could not hold them ("Out of range float values are not JSON compliant").
    count, note = drawable(t, q, [c for b in bodies for c in b["columns"] if c is not None],
                           list(result.coordinates), source or "the run", ViewError)
    t, q = t[:count], q[:count]
    frames = _decimate(t.shape[0], max_frames)
    drawn = _decimate(len(bodies), max_bodies)
    nf, nb = len(frames), len(drawn)
    qf = q[frames]
    meta: Dict[str, Any] = {"scene": scene, "kind": kind, "title": title or ("nonholo view: %s" % (
        scene or os.path.basename(source or "run"))), "frames_total": int(t.shape[0]), "bodies_total": len(bodies),
        "bodies": [int(i) for i in drawn], "labels": [bodies[i]["suffix"] for i in drawn],
        "margin_px": MARGIN_PX, "params": params}
    if kind == "planar":
        k = 3
        data = np.zeros((nf, nb, k))
        for j, i in enumerate(drawn):
            cx, cy, ct = bodies[i]["columns"]
            data[:, j, 0] = qf[:, cx]
            data[:, j, 1] = qf[:, cy]
            if ct is not None:
                data[:, j, 2] = qf[:, ct]
        d, f = params.get("d"), params.get("f")
        chain = nb > 1 and scene in ("sleigh_chain", "wheeled_train") and params.get("hitched", 1.0) != 0.0
        meta["hitch"] = {"d": d, "f": f} if (chain and d is not None and f is not None and nb == len(bodies)) else None
        meta["chain"] = chain
        meta["oriented"] = any(bodies[i]["columns"][2] is not None for i in drawn)
        if scene == "snakeboard":
            meta["shape"] = "snakeboard"
            names = list(result.coordinates)
            meta["phi"] = [float(v) for v in qf[:, names.index("phi")]] if "phi" in names else None
        else:
            meta["shape"] = "sleigh" if meta["oriented"] else "point"
        xy = data[:, :, :2].reshape(-1, 2)
        extent = float(np.hypot(*(xy.max(axis=0) - xy.min(axis=0))))
        if d is not None and f is not None and nb > 1:
            length = 0.7 * (d + f)
        elif scene == "snakeboard":
            length = 2.0 * params.get("r", 0.5)
        else:
            length = max(0.05 * extent, 0.3) if extent > 0 else 0.3
        meta["length"] = length
    else:
        k = 7
        data = np.zeros((nf, nb, k))
        has_xy = any(bodies[i]["columns"][4] is not None for i in drawn)
        has_z = any(bodies[i]["columns"][6] is not None for i in drawn)
        shape = _rigid_shape(scene, params, has_z, has_xy)
        radius = params.get("r", 1.0 if shape in ("ball", "disk") else 0.5)
        for j, i in enumerate(drawn):
            cols = bodies[i]["columns"]
            for c in range(7):
                if cols[c] is not None:
                    data[:, j, c] = qf[:, cols[c]]
            if cols[6] is None and shape == "ball":
                data[:, j, 6] = radius
        axis = 2
        if shape == "disk" and has_z:  # the symmetry axis: the body axis that makes z = r sin(tilt)
            best = None
            for a in range(3):
                w, x, y, z = (data[:, 0, c] for c in range(4))
                # (R e_a)_z for each body axis a
                rz = [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)][a]
                err = float(np.max(np.abs(data[:, 0, 6] - radius * np.sqrt(np.clip(1 - rz * rz, 0, 1)))))
                if best is None or err < best:
                    best, axis = err, a
        meta.update(shape=shape, radius=radius, axis=axis, chain=(scene == "ball_chain" and nb > 1),
                    suslov_axis=[params.get("a1", 0.0), params.get("a2", 0.0), params.get("a3", 1.0)])
    centres = data[:, :, :2] if kind == "planar" else data[:, :, 4:7]
    lo = centres.reshape(-1, centres.shape[-1]).min(axis=0)
    hi = centres.reshape(-1, centres.shape[-1]).max(axis=0)
    meta["bbox"] = [float(v) for v in lo] + [float(v) for v in hi]
    meta["paths"] = [int(j) for j in _decimate(nb, 10)]
    meta["t"] = [float(v) for v in t[frames]]
    meta["energy"] = _finite(np.asarray(result.energy)[frames])
    meta["energy_post"] = _finite(np.asarray(result.energy_post)[frames])
    meta["residual"] = _finite(np.asarray(result.residual)[frames])
    gap = np.asarray(result.gap, dtype=float) if result.gap is not None else None
    meta["gap"] = _finite(gap[frames]) if gap is not None and np.any(gap != 0) else None
    meta["gap_note"] = ("the file has no gap (CSV)" if gap is None else
                        "gap 0 throughout (no hitches)" if meta["gap"] is None else "")
    meta["summary"] = {key: (value if isinstance(value, (int, float, str)) and not (
        isinstance(value, float) and not math.isfinite(value)) else str(value)) for key, value in summary.items()}
    meta["stride"] = k
    if not np.all(np.isfinite(data)):
        data = np.nan_to_num(data, nan=0.0, posinf=0.0, neginf=0.0)
    frames_b64 = base64.b64encode(data.astype("<f4").tobytes()).decode("ascii")

    three_block = ""
    if kind == "rigid":
        three = three or THREE_FILE
        if not os.path.isfile(three):
            raise ViewError("%s: a scene with 3-D rigid bodies needs three.js, and %s is missing: the build downloads "
                            "it from the npm registry when it configures (python/CMakeLists.txt, option "
                            "NONHOLO_VIEWER_THREE; it was offline?): re-run cmake with network access, or put "
                            "three.module.min.js (three 0.160.0, package/build/) there by hand"
                            % (source or "result", three))
        with open(three, encoding="utf-8") as fh:
            text = fh.read()
        m = re.search(r"export\s*\{([^}]*)\}\s*;?\s*$", text)
        if not m:
            raise ViewError("%s: not three.js's ES module build (no export list at its end)" % three)
        pairs = []
        for item in m.group(1).split(","):
            parts = item.split(" as ")
            local, exported = parts[0].strip(), parts[-1].strip()
            pairs.append("%s:%s" % (exported, local))
        text = text[:m.start()] + "window.THREE={%s};" % ",".join(pairs)
        lic = os.path.join(os.path.dirname(three), "three.LICENSE")
        notice = "three.js r160, MIT licence, Copyright 2010-2023 three.js authors"
        if os.path.isfile(lic):
            with open(lic, encoding="utf-8") as fh:
                notice = "three.js 0.160.0 (npm), its licence:\n" + fh.read()
        three_block = "<script type=\"module\">\n/*\n%s*/\n%s\n</script>" % (
            notice.replace("*/", "* /"), text.replace("</script", "<\\/script"))
    with open(os.path.join(VIEWER_DIR, "viewer.html"), encoding="utf-8") as fh:
        page = fh.read()
    meta_json = _inline_json(meta)
    title_html = _html_text(meta["title"])
    fill = {"__TITLE__": title_html, "__THREE__": three_block, "__META__": meta_json, "__FRAMES__": frames_b64}
    return re.sub("__(?:TITLE|THREE|META|FRAMES)__", lambda m: fill[m.group(0)], page), note


def view(result: Any, path: Union[str, "os.PathLike[str]"], max_frames: int = DEFAULT_MAX_FRAMES,
         max_bodies: int = DEFAULT_MAX_BODIES, title: Optional[str] = None) -> str:
    """Writes the HTML viewer of a run (a RunResult or a run's CSV/HDF5 file) to path. Returns a
    note on the frames left out ("" when none): those from the first NaN, infinite or enormous
    coordinate on (a run that failed or blew up)."""
    source: Optional[str] = None
    if isinstance(result, (str, os.PathLike)):
        source = os.fspath(result)
        if not os.path.isfile(source):
            raise ViewError("%s: no such file" % source)
        from . import load
        try:
            result = load(source)
        except (OSError, ValueError, KeyError) as e:
            text = str(e)
            raise ViewError(text if source in text else "%s: %s" % (source, text)) from None
    if source is not None and same_file(source, os.fspath(path)):
        raise ViewError("%s is the input %s (the same file, through a link or another name): writing the page "
                        "would destroy it; write elsewhere" % (os.fspath(path), source))
    page, note = _page(result, source, max_frames, max_bodies, title, None)
    with open(os.fspath(path), "w", encoding="utf-8") as fh:
        fh.write(page)
    return note


def main(argv: Optional[Sequence[str]] = None) -> int:
    parser = CommandParser("view", description=(
        "Writes one self-contained HTML file that plays a run (nonholo run --out FILE) in a browser, from disk: "
        "the bodies and their paths (planar: 2-D canvas; 3-D rigid bodies: three.js), energy, residual and gap "
        "against time. Page URL parameters: #t=T&paused=1&follow=1&bench=1."))
    parser.add_argument("file", help="a run's output file, .h5/.hdf5 or .csv")
    parser.add_argument("-o", "--out", required=True, help="the HTML file to write")
    parser.add_argument("--max-frames", type=int, default=DEFAULT_MAX_FRAMES,
                        help="at most this many frames, evenly spaced (default %(default)s)")
    parser.add_argument("--max-bodies", type=int, default=DEFAULT_MAX_BODIES,
                        help="at most this many bodies drawn, evenly spaced with the lead and tail (default %(default)s)")
    parser.add_argument("--title", help="the page's title")
    args = parser.parse_args(argv)
    prog = parser.prog
    if not args.file.endswith((".h5", ".hdf5", ".csv")):
        print("%s: %s: expected a run's .h5, .hdf5 or .csv file" % (prog, args.file), file=sys.stderr)
        return 1
    if not args.out.endswith((".html", ".htm")):
        print("%s: -o %s: the output is an HTML file: give a name ending in .html" % (prog, args.out), file=sys.stderr)
        return 1
    try:
        note = view(args.file, args.out, max_frames=args.max_frames, max_bodies=args.max_bodies, title=args.title)
    except (ViewError, ValueError, OSError, ImportError, KeyError) as e:
        print("%s: %s" % (prog, e), file=sys.stderr)
        return 1
    if note:
        print("%s: note: %s" % (prog, note), file=sys.stderr)
    size = os.path.getsize(args.out)
    print("%s: wrote %s (%.1f MB)" % (prog, args.out, size / 1e6))
    return 0


if __name__ == "__main__":
    sys.exit(main())
