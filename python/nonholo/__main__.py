"""`python -m nonholo` and the `nonholo` command a pip install makes: the tool's commands in this
process. run, batch, list and wp are the compiled tool's own (its options, messages and exit
codes); animate and view are the package's, as the nonholo executable runs them."""
from __future__ import annotations

import os
import sys
from typing import Optional, Sequence


def main(argv: Optional[Sequence[str]] = None) -> int:
    args = list(sys.argv[1:] if argv is None else argv)
    if args and args[0] in ("animate", "view"):
        os.environ.setdefault("NONHOLO_COMMAND_NAME", "nonholo " + args[0])
        from . import _animation, _viewer
        return (_animation if args[0] == "animate" else _viewer).main(args[1:])
    from . import _core
    sys.stdout.flush()  # the tool writes through the process's own streams, after what Python wrote
    sys.stderr.flush()
    return _core._main(args)


if __name__ == "__main__":
    sys.exit(main())
