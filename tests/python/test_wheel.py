"""The wheel (pyproject.toml, setup.py): built offline with `python3 -m build --no-isolation
--wheel` reusing the CMake build tree CTest names in NONHOLO_BUILD_DIR (only an out-of-date
module is rebuilt), installed with pip into a fresh venv without an index, and used from / with
nothing of the build tree on the path: an example runs, and mypy finds the package's types."""
import os
import subprocess
import sys
import zipfile
from pathlib import Path

import pytest

import nonholo

ROOT = Path(__file__).resolve().parents[2]
BUILD = os.environ.get("NONHOLO_BUILD_DIR")

# The installed package, not the build tree's: PYTHONPATH and pip's own settings dropped.
CLEAN = {k: v for k, v in os.environ.items() if k != "PYTHONPATH" and not k.startswith("PIP_")}


def run(*args, **kwargs):
    done = subprocess.run([str(a) for a in args], capture_output=True, text=True, env=kwargs.pop("env", CLEAN),
                          timeout=600, **kwargs)
    assert done.returncode == 0, "%s\n%s\n%s" % (" ".join(map(str, args)), done.stdout[-3000:], done.stderr[-3000:])
    return done.stdout


@pytest.fixture(scope="module")
def wheel(tmp_path_factory):
    out = tmp_path_factory.mktemp("dist")
    run(sys.executable, "-m", "build", "--no-isolation", "--wheel", "--outdir", out, ROOT,
        env=dict(CLEAN, NONHOLO_CMAKE_BUILD_DIR=BUILD))
    wheels = list(out.glob("*.whl"))
    assert len(wheels) == 1, wheels
    return wheels[0]


@pytest.fixture(scope="module")
def venv(wheel, tmp_path_factory):
    v = tmp_path_factory.mktemp("venv")
    run(sys.executable, "-m", "venv", "--system-site-packages", v)  # numpy from Debian's
    run(v / "bin" / "python", "-m", "pip", "install", "--no-index", wheel)  # offline; checks numpy is there
    return v


pytestmark = pytest.mark.skipif(not BUILD, reason="run by CTest (NONHOLO_BUILD_DIR)")


def test_the_wheel_holds_the_package_its_types_and_the_one_version(wheel):
    version = nonholo.__version__  # CMakeLists.txt's project(VERSION), through the build tree's module
    assert wheel.name.startswith("nonholo-%s-cp%d%d-" % ((version,) + sys.version_info[:2]))
    with zipfile.ZipFile(wheel) as z:
        names = set(z.namelist())
        metadata = z.read("nonholo-%s.dist-info/METADATA" % version).decode()
    for name in ("nonholo/__init__.py", "nonholo/_core.pyi", "nonholo/py.typed"):
        assert name in names
    assert [n for n in names if n.startswith("nonholo/_core.") and n.endswith(".so")]
    assert "Version: %s\n" % version in metadata and "Requires-Dist: numpy\n" in metadata
    assert "License: BSD-3-Clause\n" in metadata


def test_the_installed_package_runs_from_anywhere(venv, tmp_path):
    python = venv / "bin" / "python"
    code = ("import nonholo, sys; r = nonholo.run('sleigh', t_end=1); "
            "print(nonholo.__file__, nonholo._core.__file__, nonholo.__version__, r.status)")
    module, core, version, status = run(python, "-c", code, cwd="/").split()
    assert module.startswith(str(venv)) and core.startswith(str(venv))  # not build/python
    assert version == nonholo.__version__ and status == "ok"
    out = run(python, ROOT / "examples" / "python" / "particle.py", tmp_path / "particle.png", cwd="/")
    assert "max |q - q_exact|" in out and (tmp_path / "particle.png").is_file()


def test_the_installed_package_has_the_command_line(venv, tmp_path):
    # pip install users get the tool: the wheel's `nonholo` command and `python -m nonholo` run
    # run, batch, list and wp in-process (the tool's own code: its summary line, exit codes and
    # messages), animate and view in Python.
    command = venv / "bin" / "nonholo"
    line = run(command, "run", "sleigh", "--t-end", "1", "--out", tmp_path / "s.h5", cwd="/").strip()
    assert line.startswith("scene=sleigh method=reflection") and line.endswith("status=ok")
    assert "particle:" in run(venv / "bin" / "python", "-m", "nonholo", "list", cwd="/")
    done = subprocess.run([str(command), "run", "sleigh", "--dt", "-1"], capture_output=True, text=True, env=CLEAN)
    assert done.returncode == 1 and "nonholo run: --dt -1" in done.stderr
    done = subprocess.run([str(command), "run", "sleigh", "--dt", "2"], capture_output=True, text=True, env=CLEAN)
    assert done.returncode == 3 and "status=inaccurate" in done.stdout  # the tool's exit codes
    page = tmp_path / "s.html"
    run(command, "view", tmp_path / "s.h5", "-o", page, cwd="/")
    assert page.stat().st_size > 1000


def test_mypy_finds_the_installed_packages_types(venv, tmp_path):
    # Through py.typed and _core.pyi in site-packages (no MYPYPATH): a misuse is an error, and the
    # example checks clean.
    config = tmp_path / "mypy.ini"
    config.write_text("[mypy]\nallow_redefinition = True\n[mypy-matplotlib.*]\nignore_missing_imports = True\n")
    wrong = tmp_path / "wrong.py"
    wrong.write_text("import nonholo\nnonholo.run('sleigh', t_end='5')\nnonholo.step()\n")
    mypy = [venv / "bin" / "python", "-m", "mypy", "--config-file", config, "--cache-dir", tmp_path / "cache"]
    run(*mypy, ROOT / "examples" / "python" / "particle.py", cwd="/")
    done = subprocess.run([str(a) for a in mypy + [wrong]], capture_output=True, text=True, env=CLEAN, cwd="/")
    assert done.returncode == 1 and "wrong.py:2: error" in done.stdout and "wrong.py:3: error" in done.stdout, \
        done.stdout + done.stderr


def test_the_source_distribution_carries_the_git_revision(tmp_path):
    # python3 -m build makes the wheel from the sdist, which has no .git: its nonholo said
    # git_revision "unknown". The sdist now holds GIT_REVISION, which the CMake build reads
    # (cmake/GitRevision.cmake, run here as a script on the unpacked sdist).
    import tarfile
    head = subprocess.run(["git", "rev-parse", "--short=12", "HEAD"], cwd=ROOT, capture_output=True, text=True)
    if head.returncode != 0:
        pytest.skip("not a git checkout")
    run(sys.executable, "-m", "build", "--no-isolation", "--sdist", "--outdir", tmp_path, ROOT)
    (archive,) = tmp_path.glob("nonholo-*.tar.gz")
    with tarfile.open(archive) as tar:
        tar.extractall(tmp_path / "src")
    (tree,) = (tmp_path / "src").glob("nonholo-*")
    assert (tree / "GIT_REVISION").read_text().strip() == head.stdout.strip()
    shown = subprocess.run(["cmake", "-DSOURCE=%s" % tree, "-P", str(ROOT / "cmake" / "GitRevision.cmake")],
                           capture_output=True, text=True)
    assert shown.stderr.strip() == "git revision: " + head.stdout.strip(), shown.stderr
    assert not (ROOT / "GIT_REVISION").exists()  # written into the sdist only

