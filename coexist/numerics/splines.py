"""Cubic splines for the many small evaluations of the solvers, and their CasADi form.

The states of a zone along its curve are smooth functions of ``u``; the solvers evaluate splines
through them thousands of times with a few points per call. scipy's ``PPoly.__call__`` costs about
12 µs of overhead per call, so :class:`FastCubic` evaluates the same polynomial pieces with a handful
of numpy operations (measured 10× faster per small call; ``tests/test_numerics.py`` checks it against
``PPoly`` to rounding, extrapolation included).

Not-a-knot interpolation is linear in the data: the splines through ``m`` quantities on one grid
are one tensor product with the splines through the unit vectors (:func:`not_a_knot_basis`, cached
per grid), which is how a family of curves on a shared grid is built at the cost of one.

The not-a-knot slopes are solved here with numpy (the equations of :class:`scipy.interpolate.CubicSpline`,
which ``tests/test_numerics.py`` compares them with), because importing :mod:`scipy.interpolate` costs
0.35 s, half of a ramp's whole process.
"""

from __future__ import annotations

from bisect import bisect_right

import numpy as np

from .sets import unique_sorted

__all__ = [
    "CubicBundle",
    "FastCubic",
    "casadi_piecewise",
    "casadi_spline",
    "interpolating_cubics",
    "not_a_knot_basis",
]


class FastCubic:
    """A cubic piecewise polynomial (scipy's ``PPoly`` layout) with a lean evaluator.

    ``s(u) = ((c0 d + c1) d + c2) d + c3`` with ``d = u − x_i`` on the piece ``x_i ≤ u < x_{i+1}``; the
    end pieces extend beyond the grid, as scipy's do.

    Parameters
    ----------
    ppoly : scipy.interpolate.PPoly or any object with ``x`` and ``c``
        Breakpoints ``x`` (n,) and coefficients ``c`` (k ≤ 4, n − 1), highest power first; lower
        degrees are padded with zero coefficients.

    Examples
    --------
    >>> import numpy as np
    >>> from scipy.interpolate import CubicSpline
    >>> x = np.linspace(0.0, 1.0, 6)
    >>> s = FastCubic(CubicSpline(x, x**3))
    >>> round(float(s(0.5)), 12), round(float(s.derivative()(0.5)), 12)
    (0.125, 0.75)
    """

    def __init__(self, ppoly):
        self.x = np.asarray(ppoly.x, dtype=float)
        c = np.asarray(ppoly.c, dtype=float)
        self.c = np.vstack([np.zeros((4 - c.shape[0], c.shape[1])), c])  # degree <= 3
        self._c0, self._c1, self._c2, self._c3 = (np.ascontiguousarray(r) for r in self.c)
        self._last = self.x.size - 2

    @classmethod
    def from_coefficients(cls, c: np.ndarray, x: np.ndarray) -> FastCubic:
        """The spline with coefficients ``c`` (4, n − 1) on breakpoints ``x`` (n,).

        Parameters
        ----------
        c : ndarray, shape (k, n − 1)
            Coefficients of each piece, highest power first (k ≤ 4).
        x : ndarray, shape (n,)
            Breakpoints.

        Returns
        -------
        FastCubic
            The spline.
        """
        spline = cls.__new__(cls)
        FastCubic.__init__(spline, _Pieces(x, c))
        return spline

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
            ``s'(u) = (3 c0 d + 2 c1) d + c2`` on the same breakpoints.
        """
        return FastCubic.from_coefficients(np.vstack([3 * self._c0, 2 * self._c1, self._c2]), self.x)

    def roots(self, extrapolate: bool = False) -> np.ndarray:
        """Real roots inside the grid (or also on the end pieces continued beyond it).

        A spline of degree ≤ 2 (``c0 = 0``, the derivative of a cubic) is solved in closed form
        (``q = −(b + sign(b)√(b² − 4ac))/2``, roots ``q/a`` and ``c/q``, without cancellation); a cubic
        by scipy's ``PPoly.roots``.

        Parameters
        ----------
        extrapolate : bool, optional
            Also return roots of the end pieces continued beyond the grid (default False).

        Returns
        -------
        ndarray, shape (k,)
            The roots of ``s(u) = 0`` in increasing order, each once.
        """
        if np.any(self._c0 != 0):
            from scipy.interpolate import PPoly

            roots = PPoly.construct_fast(self.c, self.x).roots(extrapolate=extrapolate)
            return np.sort(roots[np.isfinite(roots)])
        a, b, c = self._c1, self._c2, self._c3
        h = np.diff(self.x)
        found = []
        with np.errstate(all="ignore"):
            disc = b * b - 4 * a * c
            q = -0.5 * (b + np.copysign(np.sqrt(np.maximum(disc, 0.0)), b))
            quad = (a != 0) & (disc >= 0)
            for d in (np.where(quad, q / a, np.nan), np.where(quad & (q != 0), c / q, np.nan)):
                found.append(d)
            lin = (a == 0) & (b != 0)
            found.append(np.where(lin, -c / b, np.nan))
        d = np.concatenate(found)
        piece = np.tile(np.arange(h.size), len(found))
        slack = 1e-12 * h[piece]  # a root on a breakpoint may land a rounding outside both pieces
        lo = np.where(extrapolate & (piece == 0), -np.inf, -slack)
        hi = np.where(extrapolate & (piece == h.size - 1), np.inf, h[piece] + slack)
        keep = np.isfinite(d) & (d >= lo) & (d <= hi)
        d = np.where(extrapolate, d[keep], np.clip(d[keep], 0.0, h[piece[keep]])) if keep.any() else d[keep]
        roots = unique_sorted(self.x[piece[keep]] + d)
        if roots.size > 1:  # a root on a breakpoint is found by both of its pieces
            roots = roots[np.concatenate([[True], np.diff(roots) > 1e-14 * np.maximum(1.0, np.abs(roots[1:]))])]
        return roots


#: up to this many points a :class:`CubicBundle` evaluates in Python floats
_FEW_POINTS = 8


class CubicBundle:
    """Several cubics on one grid, evaluated together with their first and second derivatives from one interval
    search: what a small system evaluated thousands of times (the gradient flow of
    :func:`coexist.ramp.gradient_flow`) needs, at the cost of about one spline call instead of five.

    For each spline ``s = ((c0 d + c1) d + c2) d + c3`` (``d = u − x_i``): ``s``, ``s' = (3 c0 d + 2 c1) d + c2``
    and ``s'' = 6 c0 d + 2 c1``.

    Parameters
    ----------
    splines : sequence of FastCubic
        Splines sharing their breakpoints.

    Raises
    ------
    ValueError
        If the splines do not share their breakpoints.

    Examples
    --------
    >>> import numpy as np
    >>> x = np.linspace(0.0, 1.0, 8)
    >>> both = CubicBundle(interpolating_cubics(x, np.column_stack([x**3, x**2])))
    >>> val, d1, d2 = both(np.array([0.5]))
    >>> np.round([val[0, 0], d1[0, 0], d2[0, 0], val[1, 0], d1[1, 0], d2[1, 0]], 12).tolist()
    [0.125, 0.75, 3.0, 0.25, 1.0, 2.0]
    """

    def __init__(self, splines):
        first = splines[0]
        if any(not np.array_equal(s.x, first.x) for s in splines[1:]):
            raise ValueError("CubicBundle needs splines on one grid")
        self.x, self._last = first.x, first._last
        # (4, pieces, k): the coefficients of every spline, piece by piece
        self._c = np.stack([np.vstack([s._c0, s._c1, s._c2, s._c3]) for s in splines], axis=-1)
        # the same as Python floats, for a few points (numpy's per-operation cost dominates there)
        self._x_list = self.x.tolist()
        self._pieces = [list(zip(*(c.tolist() for c in self._c[:, i, :]))) for i in range(self._c.shape[1])]

    def __call__(self, u) -> tuple:
        """``(values, first, second)`` at ``u`` (shape ``(m,)``), each of shape ``(k, m)``: one row per spline."""
        u = np.asarray(u, dtype=float)
        if u.ndim != 1:
            raise ValueError(f"CubicBundle takes a 1-D array of points, not shape {u.shape}")
        if 0 < u.size <= _FEW_POINTS:
            return self._few(u.tolist())
        i = np.minimum(np.maximum(self.x.searchsorted(u, "right") - 1, 0), self._last)
        d = (u - self.x[i])[None, :]
        c0, c1, c2, c3 = (c.T for c in self._c[:, i, :])
        values = ((c0 * d + c1) * d + c2) * d + c3
        slopes = (3 * c0 * d + 2 * c1) * d + c2
        return values, slopes, 6 * c0 * d + 2 * c1

    def _few(self, points: list) -> tuple:
        """:meth:`__call__` for a few points, in floats (the same arithmetic, a point at a time)."""
        values, slopes, second = [], [], []
        for uj in points:
            i = min(max(bisect_right(self._x_list, uj) - 1, 0), self._last)
            d = uj - self._x_list[i]
            values.append([((c0 * d + c1) * d + c2) * d + c3 for c0, c1, c2, c3 in self._pieces[i]])
            slopes.append([(3 * c0 * d + 2 * c1) * d + c2 for c0, c1, c2, _ in self._pieces[i]])
            second.append([6 * c0 * d + 2 * c1 for c0, c1, _, _ in self._pieces[i]])
        return np.array(values).T, np.array(slopes).T, np.array(second).T


class _Pieces:
    """Breakpoints and coefficients, the two attributes :class:`FastCubic` reads."""

    def __init__(self, x, c):
        self.x, self.c = x, c


_BASES: dict = {}


def not_a_knot_basis(x: np.ndarray) -> np.ndarray:
    """Coefficients of the not-a-knot cubic splines through the unit vectors on the grid ``x``.

    The slopes ``m`` at the breakpoints solve ``A m = B y``: for interior points
    ``h_i m_{i−1} + 2(h_{i−1} + h_i) m_i + h_{i−1} m_{i+1} = 3(h_i δ_{i−1} + h_{i−1} δ_i)``, and at each end
    the not-a-knot condition (continuous third derivative across the second breakpoint), with
    ``h_i = x_{i+1} − x_i`` and ``δ_i = (y_{i+1} − y_i)/h_i``; each piece is then the cubic Hermite
    polynomial of its end values and slopes.

    Parameters
    ----------
    x : ndarray, shape (n,)
        Strictly increasing breakpoints, ``n ≥ 4``.

    Returns
    -------
    ndarray, shape (4, n − 1, n)
        ``basis[:, :, j]`` are the ``PPoly`` coefficients of the spline through ``e_j``; the spline
        through data ``y`` has coefficients ``basis @ y``. Cached per grid (up to 256 grids).
    """
    key = (x.size, float(x[0]), float(x[-1]), hash(x.tobytes()))
    basis = _BASES.get(key)
    if basis is None:
        basis = _not_a_knot_coefficients(np.asarray(x, dtype=float), np.eye(x.size))
        if len(_BASES) > 256:
            _BASES.clear()
        _BASES[key] = basis
    return basis


def _solve_not_a_knot(A: np.ndarray, r: np.ndarray) -> np.ndarray:
    """Solve the tridiagonal not-a-knot system ``A m = r`` (``r`` with many columns) by elimination.

    The first and last rows (the not-a-knot conditions) are not diagonally dominant; eliminating ``m0``
    from the second row with the first (and ``m_{n−1}`` from the last but one with the last) leaves a
    strictly diagonally dominant tridiagonal system for ``m1 … m_{n−2}`` (its first row
    ``(h0 + h1) m1 + h0 m2``), which the Thomas algorithm solves stably without pivoting; ``m0`` and
    ``m_{n−1}`` follow from the end rows. Written out rather than through LAPACK because a multithreaded
    BLAS spent 0.1 s per call starting its threads, on the first splines of every process.
    """
    n = A.shape[0]
    lower = np.array([A[i, i - 1] for i in range(1, n - 1)])  # sub-diagonal of rows 1 … n−2
    diag = np.array([A[i, i] for i in range(1, n - 1)])
    upper = np.array([A[i, i + 1] for i in range(1, n - 1)])
    rhs = r[1 : n - 1].copy()
    # eliminate m0 (row 0: A00 m0 + A01 m1 = r0) from row 1, and m_{n−1} from row n−2
    f = A[1, 0] / A[0, 0]
    diag[0] -= f * A[0, 1]
    rhs[0] -= f * r[0]
    f = A[n - 2, n - 1] / A[n - 1, n - 1]
    diag[-1] -= f * A[n - 1, n - 2]
    rhs[-1] -= f * r[n - 1]
    k = n - 2
    c = np.empty(k)
    d = np.empty_like(rhs)
    c[0] = upper[0] / diag[0]
    d[0] = rhs[0] / diag[0]
    for i in range(1, k):
        denom = diag[i] - lower[i] * c[i - 1]
        c[i] = upper[i] / denom
        d[i] = (rhs[i] - lower[i] * d[i - 1]) / denom
    inner = np.empty_like(rhs)
    inner[-1] = d[-1]
    for i in range(k - 2, -1, -1):
        inner[i] = d[i] - c[i] * inner[i + 1]
    m = np.empty_like(r)
    m[1 : n - 1] = inner
    m[0] = (r[0] - A[0, 1] * inner[0]) / A[0, 0]
    m[n - 1] = (r[n - 1] - A[n - 1, n - 2] * inner[-1]) / A[n - 1, n - 1]
    return m


def _not_a_knot_coefficients(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """``PPoly`` coefficients (4, n − 1, m) of the not-a-knot splines through the columns of ``y`` (n, m)."""
    n = x.size
    if n < 4:
        raise ValueError(f"a not-a-knot spline here needs at least 4 breakpoints, got {n}")
    h = np.diff(x)
    delta = np.diff(y, axis=0) / h[:, None]  # (n-1, m)
    A = np.zeros((n, n))
    r = np.zeros((n, y.shape[1]))
    i = np.arange(1, n - 1)
    A[i, i - 1] = h[i]
    A[i, i] = 2 * (h[i - 1] + h[i])
    A[i, i + 1] = h[i - 1]
    r[i] = 3 * (h[i][:, None] * delta[i - 1] + h[i - 1][:, None] * delta[i])
    d = h[0] + h[1]
    A[0, 0], A[0, 1] = h[1], d
    r[0] = ((h[0] + 2 * d) * h[1] * delta[0] + h[0] ** 2 * delta[1]) / d
    d = h[-1] + h[-2]
    A[-1, -1], A[-1, -2] = h[-2], d
    r[-1] = (h[-1] ** 2 * delta[-2] + (2 * d + h[-1]) * h[-2] * delta[-1]) / d
    m = _solve_not_a_knot(A, r)
    hh = h[:, None]
    t = (m[:-1] + m[1:] - 2 * delta) / hh
    return np.stack([t / hh, (delta - m[:-1]) / hh - t, m[:-1], y[:-1]])


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
    return [FastCubic.from_coefficients(np.ascontiguousarray(coef[:, :, j]), x) for j in range(coef.shape[2])]


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
