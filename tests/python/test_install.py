"""cmake --install puts the package where this Python finds it under the prefix: installed
into a scratch prefix, it imports and runs from there alone (not from the build tree)."""
import os
import subprocess
import sys

import pytest

BUILD = os.environ.get("NONHOLO_BUILD_DIR")
SITE = os.environ.get("NONHOLO_PYTHON_INSTALL_DIR")


@pytest.mark.skipif(not BUILD or not SITE, reason="run by CTest (NONHOLO_BUILD_DIR)")
def test_the_installed_package_imports_and_runs(tmp_path):
    prefix = tmp_path / "prefix"
    done = subprocess.run(["cmake", "--install", BUILD, "--prefix", str(prefix)], capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    site = prefix / SITE
    assert (site / "nonholo" / "__init__.py").is_file()
    code = ("import nonholo, sys; r = nonholo.run('sleigh', t_end=1); "
            "assert nonholo.__file__.startswith(sys.argv[1]), nonholo.__file__; print(r.status)")
    env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
    env["PYTHONPATH"] = str(site)
    ran = subprocess.run([sys.executable, "-c", code, str(site)], capture_output=True, text=True, env=env)
    assert ran.returncode == 0, ran.stderr
    assert ran.stdout.strip() == "ok"
