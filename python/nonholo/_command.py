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
