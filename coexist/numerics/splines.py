"""Cubic splines for the many small evaluations of the solvers, and their CasADi form.

The states of a zone along its curve are smooth functions of ``u``; the solvers evaluate splines
through them thousands of times with a few points per call. scipy's ``PPoly.__call__`` costs about
12 µs of overhead per call, so :class:`FastCubic` evaluates the same polynomial pieces with a handful
of numpy operations (measured 10× faster per small call; ``tests/test_numerics.py`` checks it against
``PPoly`` to rounding, extrapolation included).

Not-a-knot interpolation is linear in the data: the splines through ``m`` quantities on one grid
are one tensor product with the splines through the unit vectors (:func:`not_a_knot_basis`, cached
per grid), which is how a family of curves on a shared grid is built at the cost of one.
"""

from __future__ import annotations

import numpy as np
from scipy.interpolate import CubicSpline, PPoly

__all__ = ["FastCubic", "casadi_piecewise", "casadi_spline", "interpolating_cubics", "not_a_knot_basis"]


class FastCubic:
    """A scipy cubic ``PPoly`` with a lean evaluator.

    ``s(u) = ((c0 d + c1) d + c2) d + c3`` with ``d = u − x_i`` on the piece ``x_i ≤ u < x_{i+1}``; the
    end pieces extend beyond the grid, as scipy's do.

    Parameters
    ----------
    ppoly : scipy.interpolate.PPoly
        A piecewise polynomial of degree at most 3 (lower degrees are padded with zero coefficients).

    Examples
    --------
    >>> import numpy as np
    >>> from scipy.interpolate import CubicSpline
    >>> x = np.linspace(0.0, 1.0, 6)
    >>> s = FastCubic(CubicSpline(x, x**3))
    >>> round(float(s(0.5)), 12), round(float(s.derivative()(0.5)), 12)
    (0.125, 0.75)
    """

    def __init__(self, ppoly: PPoly):
        self.ppoly = ppoly
        self.x = ppoly.x
        self.c = ppoly.c
        c = np.vstack([np.zeros((4 - ppoly.c.shape[0], ppoly.c.shape[1])), ppoly.c])  # degree <= 3
        self._c0, self._c1, self._c2, self._c3 = (np.ascontiguousarray(r) for r in c)
        self._last = self.x.size - 2

    def __call__(self, u):
        """The spline at ``u`` (scalar or array)."""
        i = np.minimum(np.maximum(self.x.searchsorted(u, "right") - 1, 0), self._last)
        d = u - self.x[i]
        return ((self._c0[i] * d + self._c1[i]) * d + self._c2[i]) * d + self._c3[i]

    def derivative(self) -> FastCubic:
        """The derivative, a spline of one degree less.

        Returns
        -------
        FastCubic
            ``s'(u)`` on the same breakpoints (from scipy's ``PPoly.derivative``).
        """
        return FastCubic(self.ppoly.derivative())

    def roots(self, extrapolate: bool = False) -> np.ndarray:
        """Real roots (scipy's ``PPoly.roots``), inside the grid unless ``extrapolate``.

        Parameters
        ----------
        extrapolate : bool, optional
            Also return roots of the end pieces continued beyond the grid (default False).

        Returns
        -------
        ndarray, shape (k,)
            The roots of ``s(u) = 0`` in increasing order; a piece that vanishes identically contributes
            its left breakpoint followed by ``nan`` (scipy's convention).
        """
        return self.ppoly.roots(extrapolate=extrapolate)


_BASES: dict = {}


def not_a_knot_basis(x: np.ndarray) -> np.ndarray:
    """Coefficients of the not-a-knot cubic splines through the unit vectors on the grid ``x``.

    Parameters
    ----------
    x : ndarray, shape (n,)
        Strictly increasing breakpoints.

    Returns
    -------
    ndarray, shape (4, n − 1, n)
        ``basis[:, :, j]`` are the ``PPoly`` coefficients of the spline through ``e_j``; the spline
        through data ``y`` has coefficients ``basis @ y``. Cached per grid (up to 256 grids).
    """
    key = (x.size, float(x[0]), float(x[-1]), hash(x.tobytes()))
    basis = _BASES.get(key)
    if basis is None:
        basis = CubicSpline(x, np.eye(x.size)).c
        if len(_BASES) > 256:
            _BASES.clear()
        _BASES[key] = basis
    return basis


def interpolating_cubics(x: np.ndarray, columns: np.ndarray) -> list[FastCubic]:
    """Not-a-knot cubic splines through each column of ``columns`` on the grid ``x``.

    Parameters
    ----------
    x : ndarray, shape (n,)
        Strictly increasing breakpoints.
    columns : ndarray, shape (n, m)
        The data, one quantity per column.

    Returns
    -------
    list of FastCubic
        ``m`` splines, equal to ``CubicSpline(x, columns[:, j])`` to rounding inside the grid (measured
        2e-14 of the data's scale; one product with the cached :func:`not_a_knot_basis` instead of ``m``
        tridiagonal solves).
    """
    x = np.ascontiguousarray(x, dtype=float)
    coef = np.tensordot(not_a_knot_basis(x), np.asarray(columns, dtype=float), axes=1)  # (4, n-1, m)
    return [FastCubic(PPoly.construct_fast(np.ascontiguousarray(coef[:, :, j]), x)) for j in range(coef.shape[2])]


def casadi_spline(spline, x, window: tuple[int, int] | None = None):
    """A cubic ``PPoly`` (or :class:`FastCubic`) as a CasADi expression in ``x``.

    Each piece ``Σ c_k (x − x_i)^(3−k)`` is selected with ``if_else``; the end pieces extend beyond
    their interval.

    Parameters
    ----------
    spline : PPoly or FastCubic
        Breakpoints ``spline.x`` and coefficients ``spline.c`` (degree 3).
    x : casadi.SX or casadi.MX
        The symbolic argument.
    window : (int, int), optional
        Keep only the pieces ``first..last`` (a Newton solve started close to its solution needs only
        the pieces around it; the caller checks that the solution stayed inside the window).

    Returns
    -------
    casadi expression
    """
    first, last = (0, spline.x.size - 2) if window is None else window
    return casadi_piecewise(x, spline.x[first : last + 2], spline.c[:, first : last + 1])


def casadi_piecewise(x, breaks, coef):
    """A piecewise cubic ``Σ c_k (x − b_i)^(3−k)`` on ``b_i ≤ x < b_{i+1}`` as a CasADi expression, the first
    and last pieces extended beyond their intervals.

    Parameters
    ----------
    x : casadi.SX or casadi.MX
        The argument.
    breaks : array_like or casadi.SX, shape (K + 1,)
        Breakpoints; numbers, or symbols (a function of its spline, built once for all splines of K pieces).
    coef : array_like or casadi.SX, shape (4, K)
        Coefficients of each piece, highest power first (as ``PPoly.c``).

    Returns
    -------
    casadi expression
    """
    import casadi as ca

    K = coef.shape[1]
    expr = 0
    for i in range(K):
        d = x - breaks[i]
        piece = ((coef[0, i] * d + coef[1, i]) * d + coef[2, i]) * d + coef[3, i]
        lo_ok = 1 if i == 0 else (x >= breaks[i])
        hi_ok = 1 if i == K - 1 else (x < breaks[i + 1])
        expr = expr + ca.if_else(ca.logic_and(lo_ok, hi_ok), piece, 0)
    return expr
