"""Small set operations on 1-D arrays, without :func:`numpy.unique` (which imports :mod:`numpy.ma`: some 10 ms of
a command's start-up, for a sort and a comparison)."""

from __future__ import annotations

import numpy as np


def unique_sorted(values) -> np.ndarray:
    """The distinct values of ``values``, sorted ascending: ``np.unique(values)`` for a 1-D numeric array.

    Parameters
    ----------
    values : array_like
        Numbers (flattened).

    Returns
    -------
    ndarray
        Sorted, without repeats (NaNs, which never compare equal, are all kept, at the end).

    Examples
    --------
    >>> unique_sorted([3.0, 1.0, 3.0, 2.0]).tolist()
    [1.0, 2.0, 3.0]
    """
    a = np.sort(np.asarray(values).ravel())
    if a.size < 2:
        return a
    keep = np.empty(a.size, dtype=bool)
    keep[0] = True
    np.not_equal(a[1:], a[:-1], out=keep[1:])
    return a[keep]
