"""`nonholo animate FILE.csv|FILE.h5 -o OUT.gif|OUT.mp4` and nonholo.animate: a run drawn frame by frame.

Planar bodies (coordinates x<i>, y<i>, theta<i>) are drawn as oriented sleighs with their blade
(a short line across the body), hitch links between consecutive bodies, the paths of the bodies
(the lead's and every k-th for long chains) over the last `trail` time units, and the time.
3-D rigid bodies (qw<i>, qx<i>, qy<i>, qz<i> and x<i>, y<i>(, z<i>)) are drawn from above as
circles with a marker at a body-fixed point (filled when it is on the upper half), a ball chain's
rods as lines between the centres, and the path of their centre; a body without translation (a top) as a circle at the origin.

Matplotlib (Agg) draws; Pillow writes GIF, ffmpeg MP4 (Debian: python3-pil, ffmpeg).
"""
from __future__ import annotations

import math
import os
import re
import shutil
import subprocess
import sys
from typing import Any, Dict, List, Optional, Sequence, Tuple, Union

import numpy as np

from ._command import CommandParser, same_file
from ._frames import drawable

BODY = "#1f77b4"     # planar bodies' fill
LEAD = "#d62728"     # the lead (body 0) of a chain, and the rotating marker of rigid bodies
BALL = "#aec7e8"     # rigid bodies' fill
TRAIL = "#2ca02c"    # paths
LINK = "#7f7f7f"     # hitch links

_NAME = re.compile(r"^(x|y|z|theta|qw|qx|qy|qz|phi|psi)(\d*)$")


class AnimationError(ValueError):
    """Input that cannot be animated; its message is what `nonholo animate` prints."""


class Animation:
    """What animate() drew: the file's frames used (indices), their times, the image size and,
    per frame, the view's limits (x0, x1, y0, y1) and the axes' box in pixels (left, top,
    width, height from the image's top-left corner): to_pixel maps a point of the plane."""

    def __init__(self, indices: List[int], times: List[float], size: Tuple[int, int],
                 limits: List[Tuple[float, float, float, float]], box: Tuple[float, float, float, float]) -> None:
        self.indices = indices
        self.times = times
        self.size = size
        self.limits = limits
        self.box = box
        self.note = ""  # set when frames were left out (non-finite or out of range from some time on)

    def to_pixel(self, frame: int, x: float, y: float) -> Tuple[float, float]:
        x0, x1, y0, y1 = self.limits[frame]
        left, top, width, height = self.box
        return left + (x - x0) / (x1 - x0) * width, top + (y1 - y) / (y1 - y0) * height


class _Body:
    """One drawable body: its columns in q and how to draw it."""

    def __init__(self, kind: str, suffix: str) -> None:
        self.kind = kind            # "planar", "rigid", "point"
        self.suffix = suffix
        self.x: Optional[int] = None
        self.y: Optional[int] = None
        self.theta: Optional[int] = None
        self.quat: Optional[List[int]] = None
        self.phi: Optional[int] = None


def _bodies(names: Sequence[str]) -> List[_Body]:
    columns: Dict[str, Dict[str, int]] = {}
    order: List[str] = []
    for i, name in enumerate(names):
        m = _NAME.match(name)
        if not m:
            continue
        if m.group(2) not in columns:
            columns[m.group(2)] = {}
            order.append(m.group(2))
        columns[m.group(2)][m.group(1)] = i
    out = []
    for suffix in sorted(order, key=lambda s: int(s) if s else -1):
        c = columns[suffix]
        if all(k in c for k in ("qw", "qx", "qy", "qz")):
            b = _Body("rigid", suffix)
            b.quat = [c["qw"], c["qx"], c["qy"], c["qz"]]
            b.x, b.y = c.get("x"), c.get("y")
        elif "x" in c and "y" in c and "theta" in c:
            b = _Body("planar", suffix)
            b.x, b.y, b.theta, b.phi = c["x"], c["y"], c["theta"], c.get("phi")
        elif "x" in c and "y" in c:
            b = _Body("point", suffix)
            b.x, b.y = c["x"], c["y"]
        else:
            continue
        out.append(b)
    return out


def _rotate(q: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Rows of unit quaternions (w, x, y, z) applied to the vector v: (rows, 3)."""
    w, u = q[:, :1], q[:, 1:]
    t = 2.0 * np.cross(u, np.broadcast_to(v, u.shape))
    return np.asarray(v + w * t + np.cross(u, t))


def _read(source: Any) -> Tuple[Any, str, Dict[str, float], str]:
    """The RunResult, the scene's name, its parameters and a label for messages."""
    from . import RunResult, BatchResult, load
    if isinstance(source, RunResult):
        scene = str(source.summary.get("scene", "")) if isinstance(source.summary, dict) else ""
        return source, scene, {}, ""
    if isinstance(source, BatchResult):
        raise AnimationError("a batch's result has one row per trajectory, not a run's frames: animate a run")
    path = os.fspath(source)
    if not isinstance(path, str):
        path = os.fsdecode(path)
    if not path.endswith((".csv", ".h5", ".hdf5")):
        raise AnimationError("%s: expected a run's output file, FILE.csv or FILE.h5 (.hdf5), as `nonholo run "
                             "--out` writes it" % path)
    if not os.path.isfile(path):
        raise AnimationError("%s: no such file" % path)
    try:
        result = load(path)
    except (ValueError, KeyError, OSError) as e:
        raise AnimationError("%s: cannot read it as a run's output: %s" % (path, e)) from None
    if isinstance(result, BatchResult):
        raise AnimationError("%s is a batch's output (one row per trajectory), not a run's frames: animate a "
                             "file written by `nonholo run --out`" % path)
    scene, parameters = "", {}
    if path.endswith((".h5", ".hdf5")):
        import h5py
        with h5py.File(path, "r", swmr=True) as f:
            s = f.attrs.get("scene", "")
            scene = s.decode() if isinstance(s, bytes) else str(s)
            if "parameters" in f:
                for k, v in f["parameters"].attrs.items():
                    try:
                        parameters[k] = float(v)
                    except (TypeError, ValueError):
                        pass
    return result, scene, parameters, path


def _decimate(t: np.ndarray, frames: int) -> List[int]:
    """At most `frames` indices of t, evenly in time, first and last included."""
    n = t.shape[0]
    if n <= frames:
        return list(range(n))
    if frames == 1:
        return [n - 1]
    targets = np.linspace(t[0], t[-1], frames)
    idx = np.clip(np.searchsorted(t, targets), 1, n - 1)
    nearer_left = (targets - t[idx - 1]) < (t[idx] - targets)
    idx = np.where(nearer_left, idx - 1, idx)
    picked = sorted(set(int(i) for i in idx))
    if len(picked) < frames:  # uneven times: fill with the frames evenly in index
        for i in np.linspace(0, n - 1, frames).round().astype(int):
            if len(picked) >= frames:
                break
            if int(i) not in picked:
                picked.append(int(i))
        picked.sort()
    return picked


def _check_ffmpeg() -> None:
    import matplotlib
    exe = matplotlib.rcParams["animation.ffmpeg_path"]
    if not (os.path.isfile(exe) and os.access(exe, os.X_OK)) and shutil.which(exe) is None:
        raise AnimationError("making an MP4 needs ffmpeg, which was not found (Debian: apt-get install ffmpeg); "
                             "or write a GIF (-o OUT.gif)")


def animate(result: Any, path: Union[str, "os.PathLike[str]"], *, fps: int = 20, width: int = 640,
            follow: bool = False, trail: Optional[float] = None, frames: int = 100) -> Animation:
    """Writes a GIF or MP4 (by path's extension) of a run: result is a RunResult or a run's
    output file (CSV or HDF5; an HDF5 file's scene parameters size the shapes). fps: frames per
    second; width: the image's width in pixels (height 3/4 of it, even); follow: a fixed-size
    view that follows the bodies (the front of a long chain); trail: the paths' length in time
    units (None: the whole run so far, 0: none); frames: at most this many of the file's frames,
    evenly in time. Returns what was drawn (an Animation). Raises AnimationError (a ValueError)
    with a message on input it cannot animate."""
    out = os.fspath(path)
    if not isinstance(out, str):
        out = os.fsdecode(out)
    ext = os.path.splitext(out)[1].lower()
    if ext not in (".gif", ".mp4"):
        raise AnimationError("%s: the output must be OUT.gif or OUT.mp4" % out)
    for name, value, least in (("fps", fps, 1), ("width", width, 64), ("frames", frames, 1)):
        if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < least:
            raise AnimationError("%s: expected an integer of at least %d, got %r" % (name, least, value))
    if ext == ".mp4" and width % 2:
        raise AnimationError("width: an MP4 needs an even width (H.264, yuv420p), got %d" % width)
    if trail is not None and not (isinstance(trail, (int, float, np.integer, np.floating)) and trail >= 0):
        raise AnimationError("trail: expected a number of time units >= 0, got %r" % (trail,))
    if isinstance(result, (str, os.PathLike)) and same_file(os.fsdecode(os.fspath(result)), out):
        raise AnimationError("%s is the input %s (the same file, through a link or another name): writing the "
                             "animation would destroy it; write elsewhere" % (out, os.fsdecode(os.fspath(result))))
    if ext == ".mp4":
        _check_ffmpeg()
    run, scene, parameters, label = _read(result)
    bodies = _bodies(run.coordinates)
    if not bodies:
        raise AnimationError("%s: no coordinates to draw (planar bodies x<i>, y<i>, theta<i>, or rigid bodies "
                             "qw<i>, ..., x<i>, y<i>); its coordinates are %s"
                             % (label or "the run", ", ".join(run.coordinates[:8]) + (", ..." if len(run.coordinates) > 8 else "")))
    t = np.asarray(run.t, dtype=float)
    q = np.asarray(run.q, dtype=float)
    if t.shape[0] == 0:
        raise AnimationError("%s: no frames" % (label or "the run"))
    out_dir = os.path.dirname(os.path.abspath(out))
    if not os.path.isdir(out_dir):
        raise AnimationError("%s: no such directory: %s" % (out, out_dir))
    columns = [c for b in bodies for c in (b.x, b.y, b.theta, b.phi, *(b.quat or [])) if c is not None]
    count, note = drawable(t, q, columns, list(run.coordinates), label or "the run", AnimationError)
    t, q = t[:count], q[:count]
    anim = _draw(t, q, bodies, scene, parameters, label, out, ext, int(fps), int(width), bool(follow),
                 None if trail is None else float(trail), int(frames))
    anim.note = note
    return anim


def _draw(t: np.ndarray, q: np.ndarray, bodies: List[_Body], scene: str, parameters: Dict[str, float],
          label: str, out: str, ext: str, fps: int, width: int, follow: bool, trail: Optional[float], frames: int) -> Animation:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib import animation
    from matplotlib.collections import LineCollection, PolyCollection

    nb = len(bodies)
    n = t.shape[0]
    # Positions (frames, bodies) of every body's centre (drawing point) and headings.
    xs = np.zeros((n, nb))
    ys = np.zeros((n, nb))
    for j, b in enumerate(bodies):
        if b.x is not None and b.y is not None:
            xs[:, j] = q[:, b.x]
            ys[:, j] = q[:, b.y]
    planar = [j for j, b in enumerate(bodies) if b.kind == "planar"]
    rigid = [j for j, b in enumerate(bodies) if b.kind == "rigid"]
    points = [j for j, b in enumerate(bodies) if b.kind == "point"]

    # The typical size: from the parameters when the scene is known, else from the spacing.
    p = parameters
    spacing = 0.0
    if nb > 1:
        d = np.hypot(np.diff(xs[0]), np.diff(ys[0]))
        d = d[d > 0]
        spacing = float(np.median(d)) if d.size else 0.0
    extent = float(max(np.ptp(xs), np.ptp(ys))) if n else 0.0
    # A planar body's outline along its heading from its coordinate point: rear, front, width, blade.
    if scene in ("sleigh_chain", "wheeled_train") and all(k in p for k in ("a", "d", "f")):
        rear, front, blade = -p["d"], p["f"], -p["a"]
    elif scene == "sleigh" and "a" in p:
        h = max(2 * p["a"], 0.25)
        rear, front, blade = -h, h, -p["a"]
    elif scene == "sleigh_contact" and "a" in p:
        h = max(2 * p["a"], 0.25)
        rear, front, blade = p["a"] - h, p["a"] + h, 0.0
    elif scene == "snakeboard" and "r" in p:
        rear, front, blade = -1.3 * p["r"], 1.3 * p["r"], -p["r"]
    else:
        length = 0.9 * spacing if spacing > 0 else (extent / 10 if extent > 0 else 1.0)
        rear, front, blade = -length / 2, length / 2, -0.2 * length
    length = front - rear
    half_width = 0.18 * length
    radius = float(p.get("r", 1.0)) if rigid else 0.0
    size = max(length if planar else 0.0, 2 * radius if rigid else 0.0, spacing if points else 0.0, 1e-9)
    if not planar and not rigid:
        size = spacing if spacing > 0 else (extent / 10 if extent > 0 else 1.0)
    snakeboard = scene == "snakeboard" and "r" in p

    # Trails: every body up to 10, else the lead and every k-th.
    step = 1 if nb <= 10 else int(math.ceil(nb / 10))
    trailed = list(range(0, nb, step))
    # A top's trail is its marker's path.
    marker_xy: Dict[int, np.ndarray] = {}
    for j in rigid:
        b = bodies[j]
        assert b.quat is not None
        quat = q[:, b.quat]
        quat = quat / np.linalg.norm(quat, axis=1, keepdims=True)
        marker_xy[j] = _rotate(quat, np.array([radius, 0.0, 0.0]))  # (n, 3)

    def trail_xy(j: int) -> Tuple[np.ndarray, np.ndarray]:
        b = bodies[j]
        if b.kind == "rigid" and b.x is None:
            return marker_xy[j][:, 0], marker_xy[j][:, 1]
        return xs[:, j], ys[:, j]

    picked = _decimate(t, frames)
    height = int(round(width * 0.75 / 2)) * 2
    dpi = 100
    fig = plt.figure(figsize=(width / dpi, height / dpi), dpi=dpi)
    ax = fig.add_axes((0.09, 0.07, 0.88, 0.88))
    ax.set_aspect("equal", adjustable="datalim")
    ax.tick_params(labelsize=7)
    ax.grid(True, lw=0.3, alpha=0.5)

    # The view: fixed over all frames, or following the bodies (the front 20 of a long chain).
    front_group = list(range(min(nb, 20)))
    box_w, box_h = 0.88 * width, 0.88 * height
    aspect = box_w / box_h

    def fit(cx: float, cy: float, hx: float, hy: float) -> Tuple[float, float, float, float]:
        hx, hy = max(hx, 1e-9), max(hy, 1e-9)
        if hx / hy < aspect:
            hx = hy * aspect
        else:
            hy = hx / aspect
        return cx - hx, cx + hx, cy - hy, cy + hy

    margin = max(size, radius * 1.2)
    if follow:
        half = 0.0
        for i in picked:
            cx, cy = float(np.mean(xs[i, front_group])), float(np.mean(ys[i, front_group]))
            half = max(half, float(np.max(np.hypot(xs[i, front_group] - cx, ys[i, front_group] - cy))))
        half += 2 * margin
        fixed = None
    else:
        lo_x, hi_x = float(np.min(xs)), float(np.max(xs))
        lo_y, hi_y = float(np.min(ys)), float(np.max(ys))
        for j in rigid:
            if bodies[j].x is None:
                lo_x, hi_x, lo_y, hi_y = min(lo_x, 0.0), max(hi_x, 0.0), min(lo_y, 0.0), max(hi_y, 0.0)
        fixed = fit((lo_x + hi_x) / 2, (lo_y + hi_y) / 2, (hi_x - lo_x) / 2 + margin, (hi_y - lo_y) / 2 + margin)

    trail_lines = [ax.plot([], [], color=LEAD if j == 0 and nb > 1 else TRAIL, lw=1.0, alpha=0.8, zorder=1)[0]
                   for j in trailed] if trail != 0 else []
    links = ax.plot([], [], color=LINK, lw=1.0, zorder=2)[0] if len(planar) > 1 else None
    # A chain of 3-D bodies (the ball chain's rods): its centres joined in order, under the bodies.
    rods = ax.plot([], [], color=LINK, lw=1.5, zorder=2)[0] if scene == "ball_chain" and len(rigid) > 1 else None
    polys = PolyCollection([], facecolors=BODY, edgecolors="k", linewidths=0.4, zorder=3)
    ax.add_collection(polys)
    blades = LineCollection([], colors="k", linewidths=1.5, zorder=4)
    ax.add_collection(blades)
    if rigid:
        from matplotlib.patches import Circle
        circles = [Circle((0.0, 0.0), radius, facecolor=BALL, edgecolor="k", lw=0.8, zorder=3) for _ in rigid]
        for c in circles:
            ax.add_patch(c)
        hands = LineCollection([], colors=LEAD, linewidths=1.5, zorder=5)
        ax.add_collection(hands)
        up = ax.scatter([], [], s=40, c=LEAD, zorder=6)
        down = ax.scatter([], [], s=40, facecolors="white", edgecolors=LEAD, zorder=6)
    dots = ax.scatter([], [], s=20, c=BODY, zorder=3) if points else None
    title = scene if scene else (os.path.basename(label) if label else "nonholo")
    if nb > 1:
        title += ", %d bodies" % nb
    spacing_t = float(np.min(np.diff(t[picked]))) if len(picked) > 1 else 1.0
    digits = max(2, min(6, int(math.ceil(-math.log10(spacing_t))) + 1 if spacing_t > 0 else 2))
    text = ax.text(0.01, 0.99, "", transform=ax.transAxes, va="top", ha="left", fontsize=9, zorder=10,
                   bbox=dict(boxstyle="round", facecolor="white", alpha=0.85, lw=0.3))

    outline = np.array([[rear, -half_width], [front - half_width, -half_width], [front, 0.0],
                        [front - half_width, half_width], [rear, half_width]])
    facecolors = [LEAD if j == 0 and len(planar) > 1 else BODY for j in planar]
    polys.set_facecolors(facecolors)
    limits: List[Tuple[float, float, float, float]] = []
    theta_columns = np.array([bodies[j].theta for j in planar], dtype=int)

    def draw(i: int) -> None:
        if planar:
            th = q[i, theta_columns]
            c, s = np.cos(th), np.sin(th)
            px, py = xs[i, planar], ys[i, planar]
            vx = px[:, None] + c[:, None] * outline[None, :, 0] - s[:, None] * outline[None, :, 1]
            vy = py[:, None] + s[:, None] * outline[None, :, 0] + c[:, None] * outline[None, :, 1]
            polys.set_verts(list(np.stack([vx, vy], axis=2)))
            bl = 1.6 * half_width
            segs = [np.array([[px + c * blade + s * bl, py + s * blade - c * bl],
                              [px + c * blade - s * bl, py + s * blade + c * bl]]).transpose(2, 0, 1)]
            if snakeboard:
                segs = []
                r = p["r"]
                for j, k in enumerate(planar):
                    phi_col = bodies[k].phi
                    phi = q[i, phi_col] if phi_col is not None else 0.0
                    for sign in (-1.0, 1.0):
                        a = th[j] - sign * phi
                        cx, cy = px[j] + sign * r * c[j], py[j] + sign * r * s[j]
                        segs.append(np.array([[[cx + 0.5 * r * math.sin(a), cy - 0.5 * r * math.cos(a)],
                                               [cx - 0.5 * r * math.sin(a), cy + 0.5 * r * math.cos(a)]]]))
            blades.set_segments(list(np.concatenate(segs)))
            if links is not None:
                links.set_data(px, py)
        if rigid:
            tips: List[List[Tuple[float, float]]] = []
            ups: List[Tuple[float, float]] = []
            downs: List[Tuple[float, float]] = []
            for k, j in enumerate(rigid):
                cx, cy = xs[i, j], ys[i, j]
                circles[k].center = (cx, cy)
                m = marker_xy[j][i]
                tip = (cx + m[0], cy + m[1])
                tips.append([(cx, cy), tip])
                (ups if m[2] >= 0 else downs).append(tip)
            hands.set_segments(tips)
            if rods is not None:
                rods.set_data(xs[i, rigid], ys[i, rigid])
            up.set_offsets(np.array(ups).reshape(-1, 2))
            down.set_offsets(np.array(downs).reshape(-1, 2))
        if dots is not None:
            dots.set_offsets(np.column_stack([xs[i, points], ys[i, points]]))
        if trail_lines:
            lo = 0 if trail is None else int(np.searchsorted(t, t[i] - trail, side="left"))
            for line, j in zip(trail_lines, trailed):
                tx, ty = trail_xy(j)
                line.set_data(tx[lo:i + 1], ty[lo:i + 1])
        if fixed is None:
            cx, cy = float(np.mean(xs[i, front_group])), float(np.mean(ys[i, front_group]))
            view = fit(cx, cy, half, half)
        else:
            view = fixed
        ax.set_xlim(view[0], view[1])
        ax.set_ylim(view[2], view[3])
        limits.append(view)
        text.set_text("%s   t = %.*f" % (title, digits, t[i]))

    if ext == ".gif":
        writer: Any = animation.PillowWriter(fps=fps)
    else:
        writer = animation.FFMpegWriter(fps=fps, codec="libx264", extra_args=["-pix_fmt", "yuv420p"])
    try:
        with writer.saving(fig, out, dpi):
            for i in picked:
                draw(i)
                writer.grab_frame()
    except (OSError, RuntimeError, subprocess.CalledProcessError) as e:
        plt.close(fig)
        raise AnimationError("%s: writing it failed: %s" % (out, e)) from None
    plt.close(fig)
    left, bottom, w, h = 0.09 * width, 0.07 * height, 0.88 * width, 0.88 * height
    return Animation(picked, [float(t[i]) for i in picked], (width, height), limits,
                     (left, height - bottom - h, w, h))


def main(argv: Optional[Sequence[str]] = None) -> int:
    parser = CommandParser("animate", description="A GIF or MP4 of a run's output file (nonholo run --out FILE.csv|FILE.h5).")
    parser.add_argument("file", metavar="FILE.csv|FILE.h5", help="a run's output file")
    parser.add_argument("-o", "--out", required=True, metavar="OUT.gif|OUT.mp4",
                        help="the animation: GIF (Pillow) or MP4 (ffmpeg), by its extension")
    parser.add_argument("--fps", type=int, default=20, help="frames per second (default 20)")
    parser.add_argument("--width", type=int, default=640, metavar="PIXELS",
                        help="the image's width (default 640; height 3/4 of it)")
    parser.add_argument("--follow", action="store_true",
                        help="a fixed-size view following the bodies (the front of a long chain)")
    parser.add_argument("--trail", type=float, default=None, metavar="T",
                        help="draw the paths over the last T time units (default: all; 0: none)")
    parser.add_argument("--frames", type=int, default=100, metavar="N",
                        help="at most N frames, evenly in time (default 100)")
    args = parser.parse_args(argv)
    try:
        anim = animate(args.file, args.out, fps=args.fps, width=args.width, follow=args.follow, trail=args.trail,
                       frames=args.frames)
    except (AnimationError, OSError) as e:
        sys.stderr.write("%s: %s\n" % (parser.prog, e))
        return 1
    if anim.note:
        sys.stderr.write("%s: note: %s\n" % (parser.prog, anim.note))
    sys.stderr.write("%s: %d frames, %dx%d, t = %g .. %g\n" % (args.out, len(anim.indices), anim.size[0], anim.size[1],
                                                               anim.times[0], anim.times[-1]))
    return 0


if __name__ == "__main__":
    sys.exit(main())
