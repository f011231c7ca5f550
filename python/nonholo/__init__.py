"""nonholo: momentum- and energy-preserving integrators for nonholonomic systems.

High level, as the command-line tool::

    nonholo.run(scene_or_file, dt=..., t_end=..., set={...}, method=..., order=..., hitch=..., every=...)
    nonholo.batch(scene_or_file, count=..., vary={...}, ...)
    nonholo.scenes()
    nonholo.load(path)   # a run's or batch's output file (CSV or HDF5) back as results

Low level, the C++ library (ModelBuilder, Model, Workspace, RattleOptions, State, step, ...):
see help(nonholo._core).

Messages name the keywords as these functions take them (t_end=-1), not the command line's
flags (--t-end -1); RunResult.line and BatchResult.line stay the tool's own lines.
"""
from __future__ import annotations  # the annotations are for type checkers (py.typed, _core.pyi)

import copyreg as _copyreg
import os as _os
import re as _re
import stat as _stat
import typing as _typing
import warnings as _warnings

import numpy as _np

from . import _core
from ._core import *  # noqa: F401,F403  (the library's API)

if _typing.TYPE_CHECKING:  # names for the annotations only, kept out of the module's namespace
    from typing import Any, Callable, Dict, Iterable, List, Mapping, Optional, Tuple, Union

    from numpy.typing import NDArray

    _Path = Union[str, "_os.PathLike[str]"]
    _Real = Union[float, "_np.floating[Any]", "_np.integer[Any]"]
    _Integer = Union[int, "_np.integer[Any]"]
    _Vector = Union["NDArray[Any]", Iterable[_Real]]  # q0=, v0=: 1-D, converted to float64
    _Condition = Union[str, Callable[[float, "NDArray[Any]"], Any]]  # stop=: "x0>10" or f(t, q) -> bool
    _Stops = Union[_Condition, Iterable[_Condition]]
    _Assignments = Union[Mapping[str, _Real], str, Iterable[str]]  # set=: {NAME: value} or "NAME=VALUE"s
    _Ranges = Union[Mapping[str, Tuple[_Real, _Real]], str, Iterable[str]]  # vary=: {NAME: (lo, hi)} or "NAME=LO:HI"s

# Pickling at every protocol. pybind11 pickles a class with __getstate__ only from protocol 2 on:
# protocols 0 and 1 rebuild through object.__new__, which aborted the interpreter ("instance
# allocation failed"). So: State and Status by their state at any protocol (copyreg.__newobj__,
# then __setstate__, as protocol 2 does); RattleOptions by its constructor's keywords; the others
# (a Model may hold Python callables, a Workspace is buffers for one model) refused with a
# TypeError that says what to do.
_RATTLE_KEYWORDS = ("min_pivot_ratio", "hitch", "gap_tolerance", "gap_tolerance_limit", "max_gap_iterations",
                    "restart", "restart_tolerance", "monitor_every", "order", "composition", "rotation")


def _rebuilt(cls: type, args: tuple, keywords: dict) -> object:
    return cls(*args, **keywords)


def _reduce_by_state(self: object, protocol: int) -> tuple:
    return (getattr(_copyreg, "__newobj__"), (type(self),), getattr(self, "__getstate__")())


def _reduce_options(self: "RattleOptions", protocol: int) -> tuple:
    return (_rebuilt, (type(self), (self.h,), {k: getattr(self, k) for k in _RATTLE_KEYWORDS}))


def _refuse_pickle(self: object, protocol: int) -> tuple:
    name = type(self).__name__
    advice = {"Model": "build it again where it is needed (a model may call Python callables)",
              "ModelBuilder": "build the model where it is needed",
              "Workspace": "make one for the model where it is needed: nonholo.Workspace(model)",
              "Diagnostics": "keep its fields (energy, energy_post, residual, ...) instead"}
    raise TypeError("cannot pickle a nonholo.%s: %s" % (name, advice.get(name, "make it again where it is needed")))


for _class in (getattr(_core, _n) for _n in dir(_core)):
    if isinstance(_class, type):
        setattr(_class, "__reduce_ex__", _reduce_by_state if "__getstate__" in vars(_class) else
                _reduce_options if _class is _core.RattleOptions else _refuse_pickle)
del _class

__version__ = _core.__version__  # CMakeLists.txt's project(VERSION); _core.__git_revision__ too
# "portable", or the -march the library was built with (CMake's NONHOLO_ARCH): such a build's results
# differ from the portable build's in the last bits.
__target_arch__ = _core.__target_arch__

__all__ = [name for name in dir(_core) if not name.startswith("_")] + [
    "run", "batch", "scenes", "load", "animate", "view", "RunResult", "BatchResult", "RunError", "RunWarning",
    "AccuracyWarning", "StabilityWarning", "PrecisionWarning", "MethodWarning", "PerformanceWarning"]


class RunWarning(UserWarning):
    """A warning of a run or batch that ended (summary["warning_list"]), raised through the
    warnings module by run() and batch() as one of its kinds below: filter them by category
    (warnings.simplefilter("ignore", nonholo.PerformanceWarning), or "error" to make them raise)."""


class AccuracyWarning(RunWarning):
    """The accuracy check could not judge as it should (its companion or its samples failed)."""


class StabilityWarning(RunWarning):
    """dt within a factor 2 of the explicit step's stability limit."""


class PrecisionWarning(RunWarning):
    """Coordinates large enough to lose digits of a step's displacement."""


class MethodWarning(RunWarning):
    """The method's own behaviour: a grown period-2 mode."""


class PerformanceWarning(RunWarning):
    """The run could go faster: threads that do not help, steps capped by the output interval."""


_WARNINGS = {"accuracy": AccuracyWarning, "stability": StabilityWarning, "precision": PrecisionWarning,
             "method": MethodWarning, "performance": PerformanceWarning}


class RunError(RuntimeError):
    """A run or batch that did not end with status ok, raised on request (check=True).
    The results up to the failure are in .result."""

    def __init__(self, message: str, result: Union[RunResult, BatchResult]) -> None:
        super().__init__(message)
        self.result = result


class _Result:
    """Results built from the dict the C++ returns: one attribute per slot."""

    __slots__: Tuple[str, ...] = ()
    summary: Dict[str, Any]

    def __init__(self, d: Dict[str, Any]) -> None:
        for name in self.__slots__:
            setattr(self, name, d[name])

    @property
    def status(self) -> Optional[str]:
        """The summary's status; None where there is no summary (a CSV file, or the HDF5 file of a
        run that did not finish: killed)."""
        return self.summary.get("status")


class RunResult(_Result):
    """What run() returns: the frames written (t_0, every `every`-th step and the last), as
    the CLI's CSV holds them, and the CLI's summary.

    Attributes::

        t            (frames,) times
        q            (frames, coordinates) configurations
        p            (frames, velocities) the momentum the method carries (reflection: p~; the
                     reference methods: M v), as the HDF5 output's /p (None from a CSV file)
        coordinates  the coordinates' names (the CSV's header); velocities: p's entries' names
        energy, energy_post, residual, gap   (frames,) per-frame diagnostics (gap: the hitches'
                     largest |g|; None from a CSV file)
        summary      the summary line as a dict, numbers unrounded; "status" is "ok" unless a step
                     failed ("message" says why), "warning" what the CLI prints on stderr,
                     "threads_note" when one thread ran a split chain's steps faster (a timing,
                     not repeatable) ({} from a CSV file, which has no summary)
        line         the summary line exactly as `nonholo run` prints it ("" from a file)
    """

    __slots__ = ("t", "q", "p", "coordinates", "velocities", "energy", "energy_post", "residual", "gap",
                 "summary", "line")
    t: NDArray[_np.float64]
    q: NDArray[_np.float64]
    p: Optional[NDArray[_np.float64]]
    coordinates: List[str]
    velocities: List[str]
    energy: NDArray[_np.float64]
    energy_post: NDArray[_np.float64]
    residual: NDArray[_np.float64]
    gap: Optional[NDArray[_np.float64]]
    line: str

    def __repr__(self) -> str:
        if not self.summary:  # read from a CSV, or from the file of a run that did not finish
            return "<nonholo.RunResult: %d frames x %d coordinates, no summary>" % (
                self.t.shape[0], len(self.coordinates))
        return "<nonholo.RunResult %s: %d frames x %d coordinates, status=%s>" % (
            self.summary.get("scene", "?"), self.t.shape[0], len(self.coordinates), self.status)


class BatchResult(_Result):
    """What batch() returns: one row per trajectory, as the CLI's batch CSV.

    Attributes::

        columns   dict of the CSV's columns (same names and order) as 1-D numpy arrays
        messages  per trajectory: why it failed ("" when it did not)
        summary   the summary line as a dict (trajectories, threads, failed, first_failure too)
        line      the summary line exactly as `nonholo batch` prints it
        q, p      with states: every trajectory's whole final state, (count, coordinates) and
                  (count, velocities) arrays (NaN rows where a set-up failed); None otherwise
        coordinates, velocities   their names (None without states)
    """

    __slots__ = ("columns", "messages", "summary", "line", "q", "p", "coordinates", "velocities")
    columns: Dict[str, NDArray[Any]]
    messages: List[str]
    line: str
    q: Optional[NDArray[_np.float64]]
    p: Optional[NDArray[_np.float64]]
    coordinates: Optional[List[str]]
    velocities: Optional[List[str]]

    def __init__(self, d: Dict[str, Any]) -> None:
        for name in ("q", "p", "coordinates", "velocities"):
            d.setdefault(name, None)
        super().__init__(d)

    def __repr__(self) -> str:
        if "trajectories" not in self.summary:  # read from a CSV table or a journal: no summary
            rows = len(self.columns["trajectory"]) if "trajectory" in self.columns else len(self.messages)
            return "<nonholo.BatchResult: %d trajectories, no summary>" % rows
        return "<nonholo.BatchResult %s: %d trajectories, %d failed>" % (
            self.summary.get("scene", "?"), self.summary["trajectories"], self.summary["failed"])


def _text(name, value):
    """A string argument as the command line gets it; name is the Python keyword. The tool's
    arguments are C strings: a NUL byte would end one there and the rest be lost silently."""
    text = _os.fspath(value) if name in ("scene", "out", "checkpoint", "resume", "states") else str(value)
    if isinstance(text, bytes):
        text = _os.fsdecode(text)
    if "\0" in text:
        raise ValueError("%s: %r contains a NUL byte: the command line's arguments end at the first one, so "
                         "the rest would be lost; remove it" % (name, text))
    return text


def _scene(scene, what):
    """The scene argument: a name or a file, never an option the command line would act on."""
    text = _text("scene", scene)
    if text.startswith("-"):
        raise ValueError("scene: %r is not a scene name or file but looks like a command-line option: %s() takes "
                         "the scene first and options as keywords; help(nonholo.%s) describes them and "
                         "nonholo.scenes() lists the scenes (a file whose name starts with '-': pass './%s')"
                         % (text, what, what, text))
    return text


def _number(name, value):
    """A number as the command line reads it, exactly (repr is the shortest round trip)."""
    if isinstance(value, (bool, _np.bool_)) or not isinstance(value, (int, float, _np.integer, _np.floating)):
        raise ValueError("%s: expected a number, got %r" % (name, value))
    if isinstance(value, (int, _np.integer)):
        return str(int(value))
    return repr(float(value))


def _integer(name, value):
    if isinstance(value, (bool, _np.bool_)) or not isinstance(value, (int, _np.integer)):
        raise ValueError("%s: expected an integer, got %r" % (name, value))
    return str(int(value))


def _assignments(name, values, form):
    """set / vary: a dict {NAME: value} or an iterable of "NAME=..." strings."""
    if values is None:
        return []
    if isinstance(values, dict):
        return [form(_text(name, k), v) for k, v in values.items()]
    if isinstance(values, str):
        return [_text(name, values)]
    return [_text(name, v) for v in values]


def _option(args, keyword, flag, value, form):
    """Appends `flag VALUE` unless value is None; errors name the Python keyword."""
    if value is not None:
        args.extend([flag, form(keyword, value)])


def _run_arguments(what, scene, dt, t_end, set, method, order, hitch, backend, restart, restart_tol,
                   monitor_every, composition, error_estimate, project, tol, rotation=None, accuracy=None,
                   accuracy_check=None):
    args = [_scene(scene, what)]
    for keyword, value, form in (
            ("dt", dt, _number), ("t_end", t_end, _number), ("method", method, _text), ("order", order, _integer),
            ("hitch", hitch, _text), ("backend", backend, _text),
            ("restart", restart, lambda k, v: _text(k, v) if isinstance(v, str) else _integer(k, v)),
            ("restart_tol", restart_tol, _number), ("monitor_every", monitor_every, _integer),
            ("composition", composition, _text), ("rotation", rotation, _text), ("tol", tol, _number),
            ("accuracy", accuracy, _number), ("accuracy_check", accuracy_check, _text)):
        _option(args, keyword, "--" + keyword.replace("_", "-"), value, form)
    if error_estimate:
        args.append("--error-estimate")
    if project:
        args.append("--project")
    for a in _assignments("set", set, lambda k, v: "%s=%s" % (k, _number("set " + k, v))):
        args.extend(["--set", a])  # one value per --set, as the tool takes them
    return args


# A flag of the tool, alone or with a number after it, or quoted text (the caller's own, kept).
_FLAG = _re.compile(r"(?<!\w)'[^']*'|(?<![\w-])--([a-z][a-z0-9-]*)( -?[0-9][0-9.]*(?:e[-+]?[0-9]+)?(?!\w))?")


def _keywords_in(text, keywords):
    """The tool's message with its flags named as the Python keywords: "--t-end -1" becomes
    "t_end=-1", "--restart auto" "restart auto"; flags that are no keyword stay (--help)."""
    def name(m):
        keyword = (m.group(1) or "").replace("-", "_")
        if keyword not in keywords:
            return m.group(0)
        return keyword + ("=" + m.group(2)[1:] if m.group(2) else "")
    return _FLAG.sub(name, text)


def _keywords(function):
    code = function.__code__
    return frozenset(code.co_varnames[:code.co_argcount + code.co_kwonlyargcount])


def _call_tool(core, keywords, *args):
    """_core._run or _core._batch: their messages (ValueError, the summary's and the trajectories')
    in the keywords of the Python function that called them."""
    try:
        d = core(*args)
    except ValueError as e:
        raise ValueError(_keywords_in(str(e), keywords)) from None
    summary = d["summary"]
    for key in ("message", "warning", "first_failure"):
        if isinstance(summary.get(key), str):
            summary[key] = _keywords_in(summary[key], keywords)
    for w in summary.get("warning_list", []):
        w["text"] = _keywords_in(w["text"], keywords)
    if "messages" in d:
        d["messages"] = [_keywords_in(m, keywords) for m in d["messages"]]
    return d


def _finish(result, d, check, what):
    for w in d["summary"].get("warning_list", []):
        _warnings.warn(w["text"], _WARNINGS.get(w["kind"], RunWarning), stacklevel=3)
    interrupt = d.get("interrupt")
    if interrupt is not None:  # Ctrl-C during the run or batch: raised, with the results so far
        interrupt.result = result
        raise interrupt
    if check and result.status != "ok":
        message = d["summary"].get("first_failure") or d["summary"]["message"]
        raise RunError("nonholo %s: status=%s: %s" % (what, result.status, message), result)
    return result


def _stop_conditions(stop, stop_every):
    """stop=: the texts for --stop-when and the callables as (name, f, every)."""
    every = 1 if stop_every is None else int(_integer("stop_every", stop_every))
    if every < 1:
        raise ValueError("stop_every=%d: check the conditions every 1 step or more" % every)
    items = [] if stop is None else [stop] if isinstance(stop, str) or callable(stop) else list(stop)
    texts, calls = [], []
    for item in items:
        if isinstance(item, str):
            texts.append(item)
        elif callable(item):
            calls.append((str(getattr(item, "__name__", "stop")), item, every))
        else:
            raise ValueError("stop: expected a condition as text ('x0>10') or a callable f(t, q) -> bool, got %r"
                             % (item,))
    if stop_every is not None and not calls:
        raise ValueError("stop_every: it spaces the checks of callables given as stop=; the texts are checked "
                         "after every step")
    return texts, calls


def run(scene: Union[_Path, "Model", None] = None, *, dt: Optional[_Real] = None, t_end: Optional[_Real] = None,
        set: Optional[_Assignments] = None, method: Optional[str] = None, order: Optional[_Integer] = None,
        hitch: Optional[str] = None, every: Optional[_Integer] = None, backend: Optional[str] = None,
        restart: Union[str, _Integer, None] = None, restart_tol: Optional[_Real] = None,
        monitor_every: Optional[_Integer] = None, composition: Optional[str] = None, error_estimate: bool = False,
        project: bool = False, tol: Optional[_Real] = None, rotation: Optional[str] = None,
        accuracy: Optional[_Real] = None, accuracy_check: Optional[str] = None, out: Optional[_Path] = None,
        check: bool = False,
        checkpoint: Optional[_Path] = None, checkpoint_every: Union[str, _Integer, None] = None,
        resume: Optional[_Path] = None, threads: Optional[_Integer] = None,
        q0: Optional[_Vector] = None, v0: Optional[_Vector] = None, t0: Optional[_Real] = None,
        state: Optional["State"] = None, name: Optional[str] = None, stop: Optional[_Stops] = None,
        stop_every: Optional[_Integer] = None,
        progress: Optional[Callable[[float, float], Any]] = None) -> RunResult:
    """Integrates one scene (a built-in name or a scene file) as `nonholo run` does, or a Model
    built in code, and returns a RunResult with its frames and summary.

    A Model (ModelBuilder.build()) runs through the same run with the same options, checks,
    outputs and checkpoints, from q0 (n_q entries) with the velocity guess v0 (n_v), projected
    onto the constraints as start_from_velocity does, at time t0 (default 0), or from state= a
    State (start_from_velocity's or one step() advanced); dt and t_end (the end time) are then
    required and set does not apply; name names it in the summary and the files (default
    "model"). run(model, resume=path) continues its checkpoint with the same model.

    stop ends the run where a condition first holds (summary["status"] "stopped", the frames
    up to the step that saw it kept; summary["stopped_by"] names it and summary["t_stop"] is the
    first time it held, found by bisection on the interpolant between the last two checks): a
    text as the tool's --stop-when takes it ("x0>10", "theta2<-1", "hitch-angle>1.2", "gap>0.01";
    checked after every step, in C++), a callable f(t, q) -> bool (called with the GIL every
    stop_every steps, default 1, and at the interpolated states), or a list of them.

    Every option is the command line's (None: the tool's default): dt, t_end, set (a dict of
    scene parameters, or "NAME=VALUE" strings), method, order, hitch, every (keep every K-th
    step and the last), backend, restart ("auto", 0 or K), restart_tol, monitor_every,
    composition, error_estimate, project, tol (ARKODE's tolerance; with the reflection method
    and order 4, 6 or 8: adaptive composed steps aiming at this error in q at t_end, dt then
    the output interval they land on), rotation (scenes with 3-D rigid bodies:
    "moser-veselov", "moser-veselov-f" or "exponential"), accuracy (the accuracy check's
    tolerance, a fraction of the motion's extent, default 0.1; 0: off: a run above it ends with
    summary["status"] "inaccurate", its frames kept), accuracy_check (how the check estimates the
    error: "companion", a second run at 2 dt alongside, which sees errors that grow; "sampled",
    cheap and blind to growth; "auto", the default: the companion up to 300000 velocities;
    summary["accuracy_check"] says which ran); out also writes the CLI's file (CSV,
    or HDF5 for .h5). With rigid bodies q holds each body's quaternion (w, x, y, z) and centre.
    checkpoint (an .h5 path) writes the run's whole state at its end (also when it fails or
    Ctrl-C stops it) and, with checkpoint_every (steps, or "60s"), during it;
    threads splits one step of a chain of knife edges and hitches over that many threads
    (default: one thread per 500 bodies with hitch "oneform", per 5000 with "holonomic", up to
    every usable core; summary["threads"] says how many ran).
    run(resume=path, t_end=...) continues such a run bit for bit, with the checkpoint's options
    (no scene or other option then), its frames from where it resumed (the output file has the
    earlier ones). Bad options raise ValueError with the tool's message, naming the keywords
    (t_end=-1 where the tool says --t-end -1); a failed step ends the run early with
    summary["status"] saying why (check=True raises RunError instead). Ctrl-C
    raises KeyboardInterrupt with the frames so far in its .result.

    progress(t, fraction) is called every 20-100 ms of the run, on the calling thread, and once at
    its end, with the time reached and the fraction of the steps done (tqdm:
    bar = tqdm(total=1.0); progress=lambda t, f: bar.update(f - bar.n)); an exception it raises
    stops the run and is raised with the frames so far in its .result. The run's warnings are
    raised through the warnings module, one category per kind (AccuracyWarning, StabilityWarning,
    PrecisionWarning, MethodWarning, PerformanceWarning, all RunWarning); summary["warning_list"]
    has them as dicts of kind and text.
    """
    if progress is not None and not callable(progress):
        raise ValueError("progress: expected a callable progress(t, fraction), got %r" % (progress,))
    model = scene if isinstance(scene, _core.Model) else None
    stop_texts, stop_calls = _stop_conditions(stop, stop_every)
    starts = [key for key, value in (("q0", q0), ("v0", v0), ("t0", t0), ("state", state), ("name", name))
              if value is not None]
    if model is None and starts:
        raise ValueError("%s: the start of a model built in code (run(model, q0=..., v0=...)); a scene starts "
                         "where it says" % ", ".join(starts))
    if resume is not None:
        given = [key for key, value in (
            ("scene" if model is None else "name", scene if model is None else name), ("dt", dt), ("set", set),
            ("method", method), ("order", order), ("hitch", hitch),
            ("every", every), ("backend", backend), ("restart", restart), ("restart_tol", restart_tol),
            ("monitor_every", monitor_every), ("composition", composition), ("tol", tol), ("rotation", rotation),
            ("accuracy", accuracy), ("accuracy_check", accuracy_check), ("out", out),
            ("threads", threads), ("q0", q0), ("v0", v0), ("t0", t0), ("state", state),
            ("stop (a text: the checkpoint's)", stop_texts or None)) if value is not None]
        given += [key for key, flag in (("error_estimate", error_estimate), ("project", project)) if flag]
        if given:
            raise ValueError("%s with resume: a resumed run takes its %s and options from the checkpoint (only "
                             "t_end, checkpoint and checkpoint_every may be given)"
                             % (", ".join(given), "scene" if model is None else "start"))
        args: List[str] = []
        _option(args, "t_end", "--t-end", t_end, _number)
        _option(args, "resume", "--resume", resume, _text)
    else:
        if scene is None:
            raise ValueError("scene: give a scene name or file, or a Model (or resume= a checkpoint)")
        if model is not None:
            if state is not None and (q0 is not None or v0 is not None or t0 is not None):
                raise ValueError("state with q0, v0 or t0: give the start as a State or as t0, q0 and v0")
            if state is None and (q0 is None or v0 is None):
                raise ValueError("q0 and v0 (or state=): a model built in code starts where you say")
            if set is not None:
                raise ValueError("set: the parameters of a scene; a model built in code has its own in the code")
        label = _scene("model" if name is None else name, "run") if model is not None else scene
        args = _run_arguments("run", label, dt, t_end, set, method, order, hitch, backend, restart, restart_tol,
                              monitor_every, composition, error_estimate, project, tol, rotation, accuracy,
                              accuracy_check)
        _option(args, "every", "--every", every, _integer)
        _option(args, "out", "--out", out, _text)
        _option(args, "threads", "--threads", threads, _integer)
        args.extend("--stop-when=" + text for text in stop_texts)
    _option(args, "checkpoint", "--checkpoint", checkpoint, _text)
    _option(args, "checkpoint_every", "--checkpoint-every", checkpoint_every,
            lambda k, v: _text(k, v) if isinstance(v, str) else _integer(k, v))
    if model is None:
        d = _call_tool(_core._run, _keywords(run), args, stop_calls, progress)
    else:
        start_time = 0.0 if t0 is None else float(_number("t0", t0))
        d = _call_tool(_core._run_model, _keywords(run), model, args, start_time, q0, v0, state, stop_calls, progress)
    return _finish(RunResult(d), d, check, "run")


def batch(scene: Union[_Path, Callable[[Dict[str, float]], Any]], *, count: _Integer, threads: Optional[_Integer] = None,
          vary: Optional[_Ranges] = None,
          seed: Optional[_Integer] = None, out: Optional[_Path] = None, dt: Optional[_Real] = None,
          t_end: Optional[_Real] = None, set: Optional[_Assignments] = None, method: Optional[str] = None,
          order: Optional[_Integer] = None, hitch: Optional[str] = None, backend: Optional[str] = None,
          restart: Union[str, _Integer, None] = None, restart_tol: Optional[_Real] = None,
          monitor_every: Optional[_Integer] = None, composition: Optional[str] = None, error_estimate: bool = False,
          project: bool = False, tol: Optional[_Real] = None, rotation: Optional[str] = None,
          accuracy: Optional[_Real] = None, accuracy_check: Optional[str] = None, check: bool = False,
          states: Union[bool, _Path, None] = None, name: Optional[str] = None) -> BatchResult:
    """Many trajectories of one scene in parallel, as `nonholo batch` does: count
    trajectories, vary (a dict {NAME: (lo, hi)} or "NAME=LO:HI" strings) drawn per trajectory
    from seed, threads (default: all cores), out (the CLI's CSV, or HDF5 for .h5) and run()'s
    options. Returns a BatchResult; failed trajectories are reported in its columns["status"]
    and messages (check=True raises RunError if any failed). Ctrl-C stops every trajectory at
    its next step and raises KeyboardInterrupt with the BatchResult in its .result: the finished
    rows as usual, the others with status "interrupted". states=True keeps every trajectory's
    whole final state in the result's q and p; states=path (.h5) also writes them there.

    scene may instead be a factory of models built in code: factory(params), params a dict of
    trajectory i's draws of vary (its names are the factory's own), returns (model, q0, v0),
    (model, q0, v0, t0) or (model, state). It is called for every trajectory on the calling
    thread before the batch starts (the models are kept until it ends), so no Python runs in the
    parallel part unless the models call it; dt and t_end are required, set does not apply, name
    names the model (default "model"). The rows, states and files are those of a scene's batch.
    """
    factory = None if isinstance(scene, (str, bytes, _os.PathLike)) or not callable(scene) else scene
    if factory is not None and set is not None:
        raise ValueError("set: the parameters of a scene; a factory's vary its own")
    label = ("model" if name is None else name) if factory is not None else scene
    if factory is None and name is not None:
        raise ValueError("name: it names a factory's model; a scene is named by itself")
    args = _run_arguments("batch", label, dt, t_end, set, method, order, hitch, backend, restart, restart_tol,
                          monitor_every, composition, error_estimate, project, tol, rotation, accuracy,
                          accuracy_check)
    args.extend(["--count", _integer("count", count)])
    _option(args, "threads", "--threads", threads, _integer)
    _option(args, "seed", "--seed", seed, _integer)
    varies = _assignments("vary", vary, lambda k, v: "%s=%s:%s" % (
        k, _number("vary " + k, v[0]), _number("vary " + k, v[1])))
    for a in varies:
        args.extend(["--vary", a])
    _option(args, "out", "--out", out, _text)
    if states is not None and states is not True and states is not False:
        _option(args, "states", "--states", states, _text)
    if factory is None:
        d = _call_tool(_core._batch, _keywords(batch), args, bool(states))
    else:
        names = [a.split("=", 1)[0] for a in varies]
        d = _call_tool(_core._batch_models, _keywords(batch), args, bool(states), _made(factory, args, count, names))
    return _finish(BatchResult(d), d, check, "batch")


def _made(factory, args, count, names):
    """Every trajectory's (model, t0, q0, v0, state) from the factory, called with its draws."""
    try:
        draws = _core._batch_draws(args, int(_integer("count", count)))
    except ValueError as e:
        raise ValueError(_keywords_in(str(e), _keywords(batch))) from None
    made = []
    for i, values in enumerate(draws):
        out = factory(dict(zip(names, (float(x) for x in values))))
        if not isinstance(out, tuple) or not out or not isinstance(out[0], _core.Model) or len(out) not in (2, 3, 4) \
                or (len(out) == 2 and not isinstance(out[1], _core.State)):
            raise ValueError("factory: trajectory %d: expected (model, q0, v0), (model, q0, v0, t0) or (model, state), "
                             "got %r" % (i, type(out).__name__ if not isinstance(out, tuple) else
                                         tuple(type(x).__name__ for x in out)))
        if len(out) == 2:
            made.append((out[0], out[1].t, None, None, out[1]))
        else:
            t0 = 0.0 if len(out) == 3 else float(_number("factory t0", out[3]))
            made.append((out[0], t0, out[1], out[2], None))
    return made


def scenes() -> List[Dict[str, Any]]:
    """The built-in scenes: a list of dicts with name, description, dt, t_end (the defaults)
    and parameters (each a dict with name, default and description)."""
    return _core._scenes()


def _load_csv(path):
    import csv
    with open(path, newline="") as f:
        reader = csv.reader(f)
        header = next(reader, None)
        rows = list(reader)
    if header and header[0] == "t" and header[-3:] == ["energy", "energy_post", "residual"]:
        values = _np.array([[float(x) for x in row] for row in rows], dtype=float).reshape(len(rows), len(header))
        names = header[1:-3]
        return RunResult(dict(t=values[:, 0], q=values[:, 1:1 + len(names)], p=None, coordinates=names,
                              velocities=names, energy=values[:, -3], energy_post=values[:, -2],
                              residual=values[:, -1], gap=None, summary={}, line=""))
    if header and header[0] == "trajectory":
        columns = {}
        for i, name in enumerate(header):
            cells = [row[i] for row in rows]
            try:
                columns[name] = _np.array([float(c) for c in cells])
            except ValueError:
                columns[name] = _np.array(cells)
        return BatchResult(dict(columns=columns, messages=[""] * len(rows), summary={}, line=""))
    raise ValueError("%s: not a CSV file nonholo wrote (its header starts %r)" % (path, header[0] if header else None))


def _attributes(group):
    out = {}
    for key, value in group.attrs.items():
        if isinstance(value, bytes):
            value = value.decode()
        elif isinstance(value, _np.generic):
            value = value.item()
        out[key] = value
    return out


def _load_hdf5(path):
    try:
        import h5py
    except ImportError as e:  # pragma: no cover - Debian's python3-h5py is in tools/setup.sh
        raise ImportError("nonholo.load(%r): reading HDF5 needs h5py (Debian: python3-h5py)" % str(path)) from e
    try:
        f = h5py.File(path, "r")
    except OSError:  # a run killed while writing: readable as a single-writer/multiple-reader file
        try:
            f = h5py.File(path, "r", swmr=True)
        except OSError as e:
            raise ValueError("load(%r): not an HDF5 file h5py can open (%s)" % (str(path), e)) from e
    with f:
        kind = f.attrs.get("format")
        kind = kind.decode() if isinstance(kind, bytes) else kind
        summary = _attributes(f["summary"]) if "summary" in f else {}
        if isinstance(summary.get("warning_list"), str):  # JSON: the warnings with their kinds
            import json
            summary["warning_list"] = json.loads(summary["warning_list"])
        if kind == "nonholo run":
            names = [n.decode() if isinstance(n, bytes) else n for n in f["coordinates"][()]]
            velocities = ([n.decode() if isinstance(n, bytes) else n for n in f["velocities"][()]]
                          if "velocities" in f else names)
            return RunResult(dict(t=f["t"][()], q=f["q"][()], p=f["p"][()], coordinates=names, velocities=velocities,
                                  energy=f["energy"][()], energy_post=f["energy_post"][()],
                                  residual=f["residual"][()], gap=f["gap"][()], summary=summary, line=""))
        if kind == "nonholo batch states":
            def names(key):
                return [n.decode() if isinstance(n, bytes) else n for n in f[key][()]]
            status = _np.array([v.decode() if isinstance(v, bytes) else v for v in f["status"][()]])
            return BatchResult(dict(columns={"trajectory": f["trajectory"][()], "status": status}, messages=[],
                                    summary={}, line="", q=f["q"][()], p=f["p"][()],
                                    coordinates=names("coordinates"), velocities=names("velocities")))
        if kind == "nonholo batch":
            columns = {}
            messages = []
            for name, data in f.items():
                if not isinstance(data, h5py.Dataset):
                    continue
                values = data[()]
                if name == "messages":
                    messages = [v.decode() if isinstance(v, bytes) else v for v in values]
                    continue
                if values.dtype.kind in "SO":
                    values = _np.array([v.decode() if isinstance(v, bytes) else v for v in values])
                columns[name] = values
            if "batch" in f:
                summary.update(_attributes(f["batch"]))
            return BatchResult(dict(columns=columns, messages=messages, summary=summary, line=""))
        what = "an HDF5 file without nonholo's format attribute" if kind is None else "a %r HDF5 file" % kind
        raise ValueError("%s: %s, not a run's or batch's output (a checkpoint is resumed with "
                         "run(resume=...), not loaded)" % (path, what))


def load(path: _Path) -> Union[RunResult, BatchResult]:
    """A run's or a batch's output file, as `nonholo run|batch --out` (or out=) wrote it, back as a
    RunResult or BatchResult. HDF5 (.h5, .hdf5; needs h5py) has everything: t, q, p, the
    diagnostics, gap and the summary; a CSV has t, q, energy, energy_post and residual (p, gap
    None, summary {}). The numbers are the ones written, bit for bit."""
    text = _os.fspath(path)
    if not text.endswith((".h5", ".hdf5", ".csv")):
        raise ValueError("load(%r): expected a .csv, .h5 or .hdf5 file written by nonholo" % text)
    # Only a regular file (links followed): a FIFO or /dev/zero would block or read for ever.
    try:
        mode = _os.stat(text).st_mode
    except FileNotFoundError:
        raise FileNotFoundError("load(%r): no such file" % text) from None
    if not _stat.S_ISREG(mode):
        kind = ("a directory" if _stat.S_ISDIR(mode) else "a FIFO" if _stat.S_ISFIFO(mode) else
                "a device" if _stat.S_ISCHR(mode) or _stat.S_ISBLK(mode) else "a socket" if _stat.S_ISSOCK(mode)
                else "not a regular file")
        raise ValueError("load(%r): %s, not a file: expected a .csv, .h5 or .hdf5 file written by nonholo" % (text, kind))
    try:
        return _load_hdf5(text) if text.endswith((".h5", ".hdf5")) else _load_csv(text)
    except (KeyError, IndexError, UnicodeDecodeError) as e:  # the file is not what its name says
        raise ValueError("load(%r): not a run's or a batch's file written by nonholo (%s: %s)"
                         % (text, type(e).__name__, e)) from e


def animate(result: Union[RunResult, _Path], path: _Path, **options: Any) -> Any:
    """A GIF or MP4 (by path's extension) of a run: a RunResult or a run's output file (CSV or
    HDF5). Options as `nonholo animate --help` lists them, as keywords (fps=, width=, follow=,
    trail=, frames=). Needs matplotlib, and Pillow for GIF or ffmpeg for MP4. Returns what was
    drawn: the frames' indices and times, the image size and the view's limits, and `note`: what
    was left out ("" when nothing; frames from a NaN, infinite or enormous coordinate on, as a
    failed run leaves them)."""
    from ._animation import animate as _animate
    return _animate(result, path, **options)


def view(result: Union[RunResult, _Path], path: _Path, **options: Any) -> str:
    """A self-contained HTML file that plays a run (a RunResult or a run's output file) in a
    browser with no server: the bodies, their paths, the energy and residual against time.
    Returns a note on what was left out ("" when nothing; frames from a NaN, infinite or
    enormous coordinate on, as a failed run leaves them)."""
    from ._viewer import view as _view
    return _view(result, path, **options)
