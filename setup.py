"""The wheel's build (pyproject.toml has the metadata): build_ext runs CMake on the repository
and takes the module nonholo._core and its typed stub _core.pyi from the CMake build; the rest of
the package (python/nonholo) is copied as it is. Offline, with Debian's tools:

    /usr/bin/python3 -m build --no-isolation --wheel --outdir build-wheel/dist
    V/bin/python -m pip install --no-build-isolation .     # V: a venv (--system-site-packages)

Environment:
  NONHOLO_CMAKE_BUILD_DIR  a configured CMake build tree to build the module in (no new configure,
                           no full compile when it is up to date); setuptools' scratch goes there too
  CMAKE_ARGS               more configure arguments (e.g. -DCMAKE_CXX_COMPILER_LAUNCHER=ccache)
  CMAKE_BUILD_PARALLEL_LEVEL  parallel jobs (default: all cores)
"""
import os
import re
import shlex
import shutil
import subprocess
import sys
import sysconfig
from pathlib import Path

from setuptools import Extension, setup
from setuptools.command.build_ext import build_ext
from setuptools.command.sdist import sdist

ROOT = Path(__file__).resolve().parent
REUSE = os.environ.get("NONHOLO_CMAKE_BUILD_DIR")


def version():
    """The one version: CMakeLists.txt's project(nonholo VERSION x.y.z)."""
    m = re.search(r"project\(\s*nonholo\s+VERSION\s+([0-9]+\.[0-9]+\.[0-9]+)", (ROOT / "CMakeLists.txt").read_text())
    if not m:
        sys.exit("setup.py: CMakeLists.txt has no project(nonholo VERSION x.y.z)")
    return m.group(1)


def cmake(*args):
    print("setup.py: cmake " + " ".join(shlex.quote(str(a)) for a in args), flush=True)
    subprocess.run(["cmake", *map(str, args)], check=True)


class CMakeBuild(build_ext):
    def build_extension(self, ext):
        if REUSE:
            tree = Path(REUSE).resolve()
            cache = tree / "CMakeCache.txt"
            if not cache.is_file():
                sys.exit("setup.py: NONHOLO_CMAKE_BUILD_DIR=%s is not a configured CMake build tree "
                         "(no CMakeCache.txt)" % REUSE)
            source = re.search(r"^CMAKE_HOME_DIRECTORY:INTERNAL=(.*)$", cache.read_text(), re.M)
            if not source or Path(source.group(1)).resolve() != ROOT:
                sys.exit("setup.py: NONHOLO_CMAKE_BUILD_DIR=%s builds the sources in %s, not these (%s)"
                         % (REUSE, source.group(1) if source else "?", ROOT))
        else:  # only what the module needs: no tests, benchmarks or MPI
            tree = Path(self.build_temp).resolve() / "cmake"
            cmake("-S", ROOT, "-B", tree, "-DCMAKE_BUILD_TYPE=Release", "-DPython3_EXECUTABLE=" + sys.executable,
                  "-DNONHOLO_BUILD_PYTHON=ON", "-DNONHOLO_BUILD_TESTS=OFF", "-DNONHOLO_BUILD_BENCHMARKS=OFF",
                  "-DNONHOLO_WITH_MPI=OFF", *shlex.split(os.environ.get("CMAKE_ARGS", "")))
        jobs = [] if "CMAKE_BUILD_PARALLEL_LEVEL" in os.environ else ["--parallel", str(os.cpu_count() or 1)]
        cmake("--build", tree, "--target", "nonholo_python", *jobs)

        package = tree / "python" / "nonholo"
        module = package / ("_core" + sysconfig.get_config_var("EXT_SUFFIX"))
        if not module.is_file():
            found = ", ".join(p.name for p in package.glob("_core*.so")) or "none"
            sys.exit("setup.py: %s was not built (found: %s): the CMake tree %s is for another Python than %s; "
                     "configure it with -DPython3_EXECUTABLE=%s" % (module.name, found, tree, sys.executable,
                                                                    sys.executable))
        stub = package / "_core.pyi"
        if not stub.is_file() or stub.stat().st_mtime < module.stat().st_mtime:
            sys.exit("setup.py: no up-to-date %s: the CMake build writes it with mypy's stubgen when the Python it "
                     "was configured with has mypy (Debian: python3-mypy); install it and re-run cmake" % stub)
        target = Path(self.get_ext_fullpath(ext.name))
        target.parent.mkdir(parents=True, exist_ok=True)
        self.copy_file(str(module), str(target))
        self.copy_file(str(stub), str(target.with_name("_core.pyi")))
        # nonholo view's three.js for 3-D scenes, downloaded by the CMake configure (python/CMakeLists.txt;
        # absent offline: the viewer then says so for 3-D scenes)
        for name in ("three.module.min.js", "three.LICENSE"):
            if (package / "viewer" / name).is_file():
                (target.parent / "viewer").mkdir(parents=True, exist_ok=True)
                self.copy_file(str(package / "viewer" / name), str(target.parent / "viewer" / name))


class SourceWithRevision(sdist):
    """The source distribution with the checkout's git revision in GIT_REVISION: python3 -m build
    makes the wheel from the sdist, which has no .git, and its nonholo said git_revision
    "unknown" (cmake/GitRevision.cmake reads the file)."""

    def make_release_tree(self, base_dir, files):
        super().make_release_tree(base_dir, files)
        if (ROOT / "GIT_REVISION").is_file():  # an sdist made from an sdist (as the CMake build, first)
            revision = (ROOT / "GIT_REVISION").read_text().strip()
        else:
            done = subprocess.run(["git", "rev-parse", "--short=12", "HEAD"], cwd=ROOT, capture_output=True, text=True)
            revision = done.stdout.strip() if done.returncode == 0 else ""
        if revision:
            target = Path(base_dir) / "GIT_REVISION"
            if target.exists():
                target.unlink()  # a hard link to the source's copy, made by make_release_tree
            target.write_text(revision + "\n")


# setuptools' scratch (build/, *.egg-info) out of the source tree's python/: into the reused CMake
# tree, or build-wheel/ (ignored by git, as build*/).
scratch = str(Path(REUSE).resolve() / "wheel") if REUSE else "build-wheel"
os.makedirs(scratch, exist_ok=True)
for old in [*Path(scratch).glob("lib*"), *Path(scratch).glob("*.egg-info")]:
    shutil.rmtree(old)  # an earlier build's files (and file list) would go into the wheel
setup(
    version=version(),
    package_dir={"": "python"},
    packages=["nonholo"],
    entry_points={"console_scripts": ["nonholo = nonholo.__main__:main"]},  # the tool, for pip install users
    package_data={"nonholo": ["py.typed", "viewer/viewer.html"]},  # _core's module and stub come from build_ext
    ext_modules=[Extension("nonholo._core", sources=[])],
    cmdclass={"build_ext": CMakeBuild, "sdist": SourceWithRevision},
    options={"build": {"build_base": scratch}, "egg_info": {"egg_base": scratch}},
)
