#!/usr/bin/env python3
"""Keeps the numbers README.md and docs/ show from commands true.

A page shows a command's output in a block of this form:

    <!-- command: nonholo run sleigh --t-end 1 -->
    ```text
    ...what the command printed...
    ```
    <!-- end command -->

This script runs each such command (through bash, from the repository root, with the build
directory's `nonholo` first on PATH) and compares what it prints now with the block:
`--check` (the default; CTest runs it) fails on any difference, `--update` rewrites the blocks.
Timings (wall_s=, ns_per_step=, ...) are not compared; other numbers must agree: integers
exactly, others to 1e-6 relative, or both be round-off (below 1e-11 in magnitude), which differs
between machines.
"""
import argparse
import difflib
import os
import pathlib
import re
import subprocess
import sys

ROOT = pathlib.Path(__file__).resolve().parent.parent
BLOCK = re.compile(r"(<!-- command: (?P<cmd>.*?) -->\n```text\n)(?P<out>.*?)(```\n<!-- end command -->)",
                   re.S)
NUMBER = re.compile(r"[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?|[-+]?(?:nan|inf)\b")
# Values that measure the machine, not the computation.
TIMING_KEYS = ("wall_s=", "setup_s=", "ns_per_step=", "ns_per_body_step=", "ms=", "seconds=")


def pages():
    yield ROOT / "README.md"
    yield from sorted((ROOT / "docs").rglob("*.md"))


def run(cmd, build):
    env = dict(os.environ, PATH=f"{build}{os.pathsep}{os.environ.get('PATH', '')}")
    done = subprocess.run(["bash", "-c", "set -o pipefail; " + cmd], cwd=ROOT, env=env,
                          capture_output=True, text=True, timeout=300)
    if done.returncode not in (0, 3):
        raise RuntimeError(f"`{cmd}` exited with {done.returncode}:\n{done.stderr}")
    return done.stdout


def tokens(text):
    """Splits text into (kind, value) pieces: numbers, and the text between them."""
    out, pos = [], 0
    for m in NUMBER.finditer(text):
        out.append(("text", text[pos:m.start()]))
        out.append(("number", m.group()))
        pos = m.end()
    out.append(("text", text[pos:]))
    return out


def same_number(a, b):
    if a == b:
        return True
    try:
        x, y = float(a), float(b)
    except ValueError:
        return False
    if re.fullmatch(r"[-+]?\d+", a) and re.fullmatch(r"[-+]?\d+", b):
        return False  # counts agree exactly
    if abs(x) < 1e-11 and abs(y) < 1e-11:
        return True  # round-off: its digits depend on the machine
    return abs(x - y) <= 1e-6 * max(abs(x), abs(y))


def agree(shown, now):
    """Whether two outputs differ only in timings and within the tolerances above."""
    a, b = tokens(shown), tokens(now)
    if len(a) != len(b):
        return False
    for i, ((ka, va), (kb, vb)) in enumerate(zip(a, b)):
        if ka != kb:
            return False
        if ka == "text":
            if va != vb:
                return False
        elif not any(a[i - 1][1].endswith(k) for k in TIMING_KEYS) and not same_number(va, vb):
            return False
    return True


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--build", default=os.environ.get("NONHOLO_BUILD", str(ROOT / "build")),
                        help="build directory holding the nonholo executable")
    parser.add_argument("--update", action="store_true", help="rewrite the blocks instead of checking")
    args = parser.parse_args()
    build = pathlib.Path(args.build).resolve()
    if not (build / "nonholo").is_file():
        sys.exit(f"readme_numbers: no {build / 'nonholo'}: build the project first (bash tools/test.sh)")

    stale, count = [], 0
    for page in pages():
        text = page.read_text()

        def replace(m):
            nonlocal count
            count += 1
            now = run(m.group("cmd"), build)
            if agree(m.group("out"), now):
                return m.group(0)  # timings are not rewritten
            stale.append((page.relative_to(ROOT), m.group("cmd"), m.group("out"), now))
            return m.group(1) + (now if args.update else m.group("out")) + m.group(4)

        new = BLOCK.sub(replace, text)
        if args.update and new != text:
            page.write_text(new)
    for page, cmd, shown, now in stale:
        print(f"{page}: `{cmd}` now prints something else:")
        sys.stdout.writelines(difflib.unified_diff(shown.splitlines(True), now.splitlines(True),
                                                   "shown", "now"))
    verb = "rewrote" if args.update else "differ"
    print(f"readme_numbers: {count} command blocks, {len(stale)} {verb}")
    return 1 if stale and not args.update else 0


if __name__ == "__main__":
    sys.exit(main())
