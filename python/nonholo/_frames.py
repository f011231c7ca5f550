"""The frames a picture can show (`nonholo animate` and `nonholo view`): a run that failed or blew
up leaves NaN, infinite or enormous coordinates from some frame on, on which matplotlib raised a
traceback and the page's JSON could not be written. Both draw the frames before it and say why."""
from typing import Iterable, List, Tuple

import numpy as np

# Coordinates beyond this cannot be drawn: the view's spans and the shapes' corners (differences,
# sums and squares of them) would overflow.
DRAWABLE = 1e150


def drawable(t: np.ndarray, q: np.ndarray, columns: Iterable[int], names: List[str], label: str,
             error: type) -> Tuple[int, str]:
    """(n, note): the count of frames before the first whose time or one of the drawn `columns` of
    q is NaN, infinite or beyond DRAWABLE, and a note on what was left out ("" when nothing).
    Raises `error` (the command's ValueError) when the first frame is such: nothing to draw."""
    cols = sorted(set(columns))
    values = q[:, cols]
    bad = ~np.isfinite(t) | ~np.all(np.isfinite(values) & (np.abs(values) <= DRAWABLE), axis=1)
    if not bad.any():
        return t.shape[0], ""
    first = int(np.argmax(bad))
    if not np.isfinite(t[first]):
        what = "t is %r" % float(t[first])
    else:
        c = next(c for c in cols if not (np.isfinite(q[first, c]) and abs(q[first, c]) <= DRAWABLE))
        what = "%s is %r" % (names[c], float(q[first, c]))
    if first == 0:
        raise error("%s: its first frame cannot be drawn: %s (NaN, infinite or beyond %g): nothing to show"
                    % (label, what, DRAWABLE))
    return first, ("frames from t = %g on cannot be drawn (%s: NaN, infinite or beyond %g; the run failed or blew up "
                   "there, its summary says why): shown up to t = %g" % (t[first], what, DRAWABLE, t[first - 1]))
