"""tools/check_layers.py, the check that keeps the rooms of docs/layout.md: it passes on the tree
as it is, and fails, naming the file and the rule, on each kind of include it exists to refuse,
planted into a copy of the sources."""
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
CHECK = ROOT / "tools" / "check_layers.py"
FOLDERS = ["core", "sparse", "scenarios", "reference", "mpi", "python/src", "tests", "benchmarks", "examples"]


def run_check(root):
    return subprocess.run([sys.executable, str(CHECK), "--root", str(root)], capture_output=True, text=True)


@pytest.fixture
def tree(tmp_path):
    """A copy of the sources and of docs/layout.md (the check's table)."""
    for folder in FOLDERS:
        shutil.copytree(ROOT / folder, tmp_path / folder,
                        ignore=shutil.ignore_patterns("__pycache__", "*.json", "*.py", "corpus"))
    (tmp_path / "docs").mkdir()
    shutil.copy(ROOT / "docs" / "layout.md", tmp_path / "docs" / "layout.md")
    return tmp_path


def plant(root, path, line, at_top=False):
    """Adds `line` after the file's opening comment (or as its first line)."""
    file = root / path
    lines = file.read_text().splitlines(keepends=True)
    index = 0 if at_top else next(i for i, l in enumerate(lines) if not l.startswith("//"))
    lines.insert(index, line + "\n")
    file.write_text("".join(lines))


def test_the_tree_passes():
    result = run_check(ROOT)
    assert result.returncode == 0, result.stdout + result.stderr


def test_the_copy_passes(tree):
    result = run_check(tree)
    assert result.returncode == 0, result.stdout + result.stderr


@pytest.mark.parametrize("path, include, expected", [
    # a lower room including a higher one, by a private and by a public header
    ("core/src/model/model.cpp", '#include "step/rattle_internal.hpp"',
     "room core/model includes room core/step"),
    ("core/src/base/status.cpp", "#include <nonholo/workspace.hpp>", "room core/base includes room core/step"),
    # two rooms side by side
    ("core/src/methods/dla.cpp", "#include <nonholo/adaptive.hpp>", "room core/methods includes room core/trajectory"),
    # the output calling into the run loop, which calls the output
    ("scenarios/src/output/hdf5_output.cpp", '#include "run/run_internal.hpp"',
     "room scenarios/output includes room scenarios/run"),
    # a library including one above it
    ("core/src/step/rattle.cpp", "#include <nonholo/scenarios/run.hpp>", "room core/step includes room scenarios/run"),
])
def test_an_include_running_up_fails(tree, path, include, expected):
    plant(tree, path, include)
    result = run_check(tree)
    assert result.returncode == 1
    assert f"{path}:" in result.stdout and expected in result.stdout, result.stdout


def test_a_relative_path_into_core_src_fails(tree):
    plant(tree, "tests/test_restart.cpp", '#include "../core/src/step/restart_internal.hpp"')
    result = run_check(tree)
    assert result.returncode == 1
    assert "tests/test_restart.cpp" in result.stdout and "nonholo_private_headers" in result.stdout, result.stdout


def test_a_private_header_of_another_library_fails(tree):
    # the command line sees only public headers, though it is compiled into nonholo_scenarios
    plant(tree, "scenarios/cli/command_line.cpp", '#include "run/run_internal.hpp"')
    result = run_check(tree)
    assert result.returncode == 1
    assert "scenarios/cli/command_line.cpp" in result.stdout and "a private header of scenarios" in result.stdout


@pytest.mark.parametrize("path, header", [
    ("scenarios/src/run/run.cpp", "#include <hdf5.h>"),
    ("core/src/step/workspace.cpp", "#include <cholmod.h>"),
    ("scenarios/src/batch/batch.cpp", "#include <mpi.h>"),
])
def test_a_heavy_header_outside_its_room_fails(tree, path, header):
    plant(tree, path, header)
    result = run_check(tree)
    assert result.returncode == 1
    assert path in result.stdout and "only" in result.stdout, result.stdout


def test_a_public_header_without_a_room_fails(tree):
    (tree / "core/include/nonholo/new_thing.hpp").write_text("#pragma once\n")
    plant(tree, "core/src/step/rattle.cpp", "#include <nonholo/new_thing.hpp>")
    result = run_check(tree)
    assert result.returncode == 1
    assert "core/include/nonholo/new_thing.hpp" in result.stdout and "no room" in result.stdout, result.stdout


def test_a_folder_without_a_room_fails(tree):
    (tree / "core/src/extras").mkdir()
    (tree / "core/src/extras/thing.cpp").write_text("// A thing.\n")
    result = run_check(tree)
    assert result.returncode == 1
    assert "core/src/extras/thing.cpp: in no room" in result.stdout, result.stdout


def test_a_cpp_without_its_opening_line_fails(tree):
    plant(tree, "core/src/step/dynamics.cpp", "#include <cmath>", at_top=True)
    result = run_check(tree)
    assert result.returncode == 1
    assert "core/src/step/dynamics.cpp:1: opens without a one-line comment" in result.stdout, result.stdout


def test_the_report_counts_rooms():
    result = subprocess.run([sys.executable, str(CHECK), "--report"], capture_output=True, text=True, check=True)
    rows = {line.split()[0]: line.split() for line in result.stdout.splitlines()[1:]}
    assert rows["core"][1] == "6" and rows["core"][4] == "0", result.stdout  # six rooms, no arrow in a cycle
