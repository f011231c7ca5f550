"""The typed package: nonholo/_core.pyi (python/make_stubs.py, mypy's stubgen at build time)
agrees with the built module (mypy's stubtest) and holds every signature pybind11 gives; mypy
checks the examples against it and catches misuse; and no signature or docstring the user sees
names a C++ type."""
import ast
import inspect
import os
import re
import subprocess
import sys
import textwrap
from pathlib import Path

import nonholo
from nonholo import _core

PACKAGE = Path(nonholo.__file__).parent
STUB = PACKAGE / "_core.pyi"
ROOT = Path(__file__).resolve().parents[2]
BUILD = os.environ.get("NONHOLO_BUILD_DIR")

# Third-party modules without type information (matplotlib 3.6, h5py); nonholo is not one of them.
MYPY_CONFIG = """[mypy]
# examples/python/particle.py reuses its names for lists, then the arrays made from them
allow_redefinition = True
[mypy-matplotlib.*,h5py.*]
ignore_missing_imports = True
"""


def mypy(tmp_path, *args):
    config = tmp_path / "mypy.ini"
    config.write_text(MYPY_CONFIG)
    cache = Path(BUILD) / "mypy_cache" if BUILD else tmp_path / "mypy_cache"
    env = dict(os.environ, MYPYPATH=str(PACKAGE.parent))
    return subprocess.run([sys.executable, "-m", "mypy", "--config-file", str(config), "--cache-dir", str(cache),
                           *map(str, args)], capture_output=True, text=True, env=env, cwd=tmp_path)


def test_the_package_says_it_is_typed():
    assert (PACKAGE / "py.typed").is_file()
    assert STUB.is_file(), "no %s: the build writes it with mypy's stubgen (Debian: python3-mypy)" % STUB
    assert STUB.stat().st_mtime >= Path(_core.__file__).stat().st_mtime, "the stub is older than the module"


def test_stubtest_finds_the_stub_and_the_module_agree():
    # pybind11's classes have their own metaclass, which a stub cannot name: the only difference
    # allowed, and reported for every class (stubtest without a stub says nothing at all).
    done = subprocess.run([sys.executable, "-m", "mypy.stubtest", "--concise", "nonholo._core"], capture_output=True,
                          text=True, env=dict(os.environ, PYTHONPATH=str(PACKAGE.parent)))
    lines = done.stdout.splitlines()
    errors = [line for line in lines if line and not line.endswith(" is inconsistent, metaclass differs")]
    assert errors == [] and "Traceback" not in done.stderr, done.stdout + done.stderr
    classes = {"nonholo._core." + name for name, c in vars(_core).items() if inspect.isclass(c)}
    assert {line.split(" is inconsistent")[0] for line in lines if line} == classes


def documented_signature(function):
    """The parameter names of pybind11's first docstring line: name(a: T, b: U = 1, *, c: V) -> R."""
    first = (function.__doc__ or "").splitlines()[0] if function.__doc__ else ""
    name = function.__name__
    if not first.startswith(name + "("):
        return None  # not a pybind11 signature (no constructor bound: Model, State, ...)
    text, depth, params, current = first[len(name) + 1:], 0, [], ""
    for c in text:
        if depth == 0 and c in ",)":
            if current.strip():
                params.append(current.split(":")[0].split("=")[0].strip())
            current = ""
            if c == ")":
                return params
            continue
        depth += c in "[({"
        depth -= c in "])}"
        current += c
    raise AssertionError("cannot read %r" % first)


def stub_parameters(function):
    a = function.args
    return [p.arg for p in a.posonlyargs + a.args] + (["*"] if a.kwonlyargs else []) + [p.arg for p in a.kwonlyargs]


def test_every_signature_of_the_module_is_in_the_stub():
    # Before: stubgen read no signature with pybind11's keyword-only '*' and wrote (*args, **kwargs).
    tree = ast.parse(STUB.read_text())
    stubs = {}
    for node in tree.body:
        if isinstance(node, ast.FunctionDef):
            stubs[node.name] = node
        elif isinstance(node, ast.ClassDef):
            stubs.update({node.name + "." + f.name: f for f in node.body if isinstance(f, ast.FunctionDef)})
    runtime = [(name, f) for name, f in vars(_core).items() if inspect.isbuiltin(f)]
    for cls_name, cls in vars(_core).items():
        if inspect.isclass(cls):
            runtime += [(cls_name + "." + n, f) for n, f in vars(cls).items() if inspect.isroutine(f)]
    checked = 0
    for name, function in runtime:
        expected = documented_signature(function)
        member = name.split(".")[-1]
        if expected is None or (member.startswith("__") and member != "__init__"):
            continue  # no signature, or object's own protocol (stubgen leaves __repr__ out)
        assert name in stubs, name
        assert stub_parameters(stubs[name]) == expected, name
        checked += 1
    assert checked > 40  # every function and method, not a few


def test_mypy_checks_the_examples_and_the_package_with_the_stubs(tmp_path):
    examples = sorted((ROOT / "examples" / "python").glob("*.py"))
    assert len(examples) >= 2
    done = mypy(tmp_path, *examples, PACKAGE)
    assert done.returncode == 0, done.stdout + done.stderr


def test_mypy_catches_misuse_through_the_stubs(tmp_path):
    # Types, not Any: each of these lines is an error mypy must report.
    wrong = tmp_path / "wrong.py"
    wrong.write_text(textwrap.dedent("""\
        import nonholo
        model = nonholo.ModelBuilder().build()
        ws = nonholo.Workspace(model)
        nonholo.step(model, ws)
        steps: str = nonholo.RattleOptions(0.1).order
        nonholo.run("sleigh", t_end="5")
        nonholo.start_from_velocity(model, ws, 0.0, [0.0], [0.0], multiplier=1)
        nonholo.run("sleigh").q.no_such_attribute
        """))
    done = mypy(tmp_path, wrong)
    lines = {int(line.split(":")[1]) for line in done.stdout.splitlines() if ": error:" in line}
    assert lines == {4, 5, 6, 7, 8}, done.stdout + done.stderr


def public_objects():
    """(name, object) for everything public in nonholo and nonholo._core: functions, classes, their
    methods (constructors too) and properties' getters and setters."""
    seen, out = set(), []

    def visit(name, obj):
        if id(obj) in seen:
            return
        seen.add(id(obj))
        out.append((name, obj))
        if inspect.isclass(obj):
            for member, value in vars(obj).items():
                if member.startswith("_") and member not in ("__init__", "__call__"):
                    continue
                if isinstance(value, property):
                    for accessor in (value.fget, value.fset):
                        if accessor is not None:
                            visit(name + "." + member, accessor)
                elif callable(value):
                    visit(name + "." + member, value)

    for module, names in ((nonholo, nonholo.__all__), (_core, dir(_core))):
        out.append((module.__name__, module))
        for name in names:
            if not name.startswith("_"):
                visit(module.__name__ + "." + name, getattr(module, name))
    return out


# A C++ scope (name::name) and C++ spellings; a reStructuredText literal block's "::" at the end
# of a line is not one.
CPP = re.compile(r"\w::\w|std::|Eigen|\(anonymous namespace\)")


def test_no_cpp_names_in_signatures_or_docstrings():
    # Before: ModelBuilder.build() -> nonholo::python::(anonymous namespace)::PyModel.
    objects = public_objects()
    assert len(objects) > 100
    found = []
    for name, obj in objects:
        texts = [getattr(obj, "__doc__", None) or ""]
        if inspect.isfunction(obj):
            texts.append(str(inspect.signature(obj)))
        found += ["%s: %s" % (name, t.strip().splitlines()[0]) for t in texts if CPP.search(t)]
    assert found == []
    assert not CPP.search(STUB.read_text())
