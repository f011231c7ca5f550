"""The argument parser of the commands the nonholo executable runs in Python (`nonholo animate`,
`nonholo view`): bad arguments exit 1, as the tool's own commands do (argparse's is 2), and the
help has one width whatever the terminal, so that the docs can show it verbatim."""
from __future__ import annotations

import argparse
import os
import sys
from typing import Any


class CommandParser(argparse.ArgumentParser):
    def __init__(self, command: str, **kwargs: Any) -> None:
        super().__init__(prog=os.environ.get("NONHOLO_COMMAND_NAME", "nonholo " + command),
                         formatter_class=lambda prog: argparse.HelpFormatter(prog, width=100), **kwargs)

    def error(self, message: str) -> Any:
        self.print_usage(sys.stderr)
        sys.stderr.write("%s: %s\n" % (self.prog, message))
        sys.exit(1)


def same_file(a: str, b: str) -> bool:
    """Whether two paths name one file: links followed (by device and inode when both exist),
    so that an output given through a link to its input is refused instead of destroying it."""
    try:
        if os.path.exists(a) and os.path.exists(b):
            return os.path.samefile(a, b)
    except OSError:
        return False
    return os.path.realpath(a) == os.path.realpath(b)
