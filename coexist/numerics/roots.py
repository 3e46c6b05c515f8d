"""Root finding and extremum search: the one home of every scalar root, Newton iteration and extremum
search in the library (the continuation's multi-dimensional corrector lives in
:mod:`coexist.continuation`).

All three work on many independent problems at once (arrays of brackets or starting points), because
the functions they are used on are batched shootings, where one call for ``m`` points costs little
more than one call for one. Tolerances are always passed in by the caller, derived from its
:class:`~coexist.settings.SolverSettings`; nothing here has a tolerance of its own.

- :func:`bracketed_root` — the Illinois method (regula falsi with the retained end's value halved when
  the same end is kept twice, Dowell & Jarratt 1971: superlinear, order ≈ 1.44, and never leaves the
  bracket), falling back to bisection where the secant is not defined;
- :func:`bisect` — bisection of a yes/no predicate (where a property starts to hold, e.g. validity);
- :func:`newton` — Newton's method with an optional bracket as safeguard and a stop where the steps
  stop shrinking (the function's own noise);
- :func:`chebyshev_extremum` — an extremum by Chebyshev interpolation on shrinking brackets.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

__all__ = ["BracketedRoot", "NewtonResult", "bisect", "bracketed_root", "chebyshev_extremum", "newton"]

_EPS = np.finfo(float).eps
#: a Newton step counts as stalled (noise-limited) only within this factor of the tolerance
STALL_WINDOW = 1e4


@dataclass
class BracketedRoot:
    """Result of :func:`bracketed_root` (arrays, one entry per problem).

    ``x`` is the last point evaluated for each problem (so a caller that records its evaluations by
    index holds the state at ``x``), ``f`` the value there; ``lo`` and ``hi`` are the final bracket ends,
    ``lo`` the one where ``f`` has the sign it had at the first ``lo`` (so ``lo`` need not be the
    smaller); ``converged`` says whether ``|f| ≤ ftol`` or the bracket shrank below the tolerance.
    """

    x: np.ndarray
    f: np.ndarray
    lo: np.ndarray
    hi: np.ndarray
    converged: np.ndarray
    iterations: int

    @property
    def width(self) -> np.ndarray:
        """Width ``|hi − lo|`` of the final brackets (a bound on the error of ``x``)."""
        return np.abs(self.hi - self.lo)


def _rounds(done: np.ndarray, max_iter: int):
    """``(round, indices of the open problems)`` for each round, at most ``max_iter``, until all are done."""
    for k in range(1, max_iter + 1):
        idx = np.flatnonzero(~done)
        if idx.size == 0:
            return
        yield k, idx


def _as_array(x) -> np.ndarray:
    return np.atleast_1d(np.array(x, dtype=float))


def bracketed_root(
    f: Callable[[np.ndarray, np.ndarray], np.ndarray],
    lo,
    hi,
    f_lo=None,
    f_hi=None,
    *,
    xtol=0.0,
    rtol: float = 0.0,
    ftol=0.0,
    max_iter: int = 100,
) -> BracketedRoot:
    """Roots of ``f`` on the brackets ``[lo, hi]`` by the Illinois method, all brackets at once.

    Parameters
    ----------
    f : callable
        ``f(x, idx) -> values`` for the points ``x`` of the problems ``idx`` (indices into ``lo``). A NaN
        value counts as lying on the ``hi`` side (an invalid state beyond the root); ``±inf`` counts by
        its sign.
    lo, hi : float or array_like
        Bracket ends with ``f(lo) · f(hi) ≤ 0``.
    f_lo, f_hi : float or array_like, optional
        ``f`` at the ends, if already known.
    xtol, rtol : float
        A problem has converged when its bracket is narrower than ``xtol + rtol |x|`` (and never less
        than ``4 ε |x|``, the resolution of floating point); ``xtol`` may be one value per problem.
    ftol : float or array_like
        ... or when ``|f(x)| ≤ ftol`` (one value, or one per problem).
    max_iter : int
        Evaluations per problem at most; problems still open are returned with ``converged`` False.

    Returns
    -------
    BracketedRoot

    Raises
    ------
    ValueError
        If some bracket has no sign change, or ``f`` is NaN at a lower end.

    Examples
    --------
    >>> r = bracketed_root(lambda x, idx: x**2 - 2.0, [0.0, -3.0], [3.0, 0.0], rtol=1e-14)
    >>> r.x.round(12).tolist(), bool(r.converged.all())
    ([1.414213562373, -1.414213562373], True)
    """
    with np.errstate(invalid="ignore"):
        return _illinois(f, lo, hi, f_lo, f_hi, xtol, rtol, ftol, max_iter)


def _illinois(f, lo, hi, f_lo, f_hi, xtol, rtol, ftol, max_iter) -> BracketedRoot:
    a, b = _as_array(lo), _as_array(hi)
    a, b = np.broadcast_arrays(a, b)
    a, b = a.astype(float).copy(), b.astype(float).copy()
    m = a.size
    everyone = np.arange(m)
    ftol_all = np.broadcast_to(np.asarray(ftol, dtype=float), (m,))
    xtol_all = np.broadcast_to(np.asarray(xtol, dtype=float), (m,))
    fa = _as_array(f(a, everyone) if f_lo is None else np.broadcast_to(f_lo, a.shape)).copy()
    fb = _as_array(f(b, everyone) if f_hi is None else np.broadcast_to(f_hi, a.shape)).copy()
    if np.any(np.isnan(fa)):
        bad = int(np.flatnonzero(np.isnan(fa))[0])
        raise ValueError(f"bracketed_root: f is NaN at the lower end {a[bad]:.17g} (it must be a valid point)")
    fb = np.where(np.isnan(fb), -np.sign(fa) * np.inf, fb)  # NaN: the hi side
    if np.any(np.sign(fa) * np.sign(fb) > 0):
        bad = int(np.flatnonzero(np.sign(fa) * np.sign(fb) > 0)[0])
        raise ValueError(
            f"bracketed_root: no sign change on [{a[bad]:.17g}, {b[bad]:.17g}] (f = {fa[bad]:.3g}, {fb[bad]:.3g})"
        )
    x = np.where(fa == 0, a, b)
    fx = np.where(fa == 0, fa, fb)
    done = (fa == 0) | (fb == 0)
    side = np.zeros(m)  # -1: the last new point replaced a; +1: it replaced b
    iterations = 0
    for iterations, idx in _rounds(done, max_iter):  # noqa: B007 (the count is returned)
        ai, bi, fai, fbi = a[idx], b[idx], fa[idx], fb[idx]
        with np.errstate(all="ignore"):
            c = bi - fbi * (bi - ai) / (fbi - fai)
        mid = 0.5 * (ai + bi)
        inside = np.isfinite(c) & (c > np.minimum(ai, bi)) & (c < np.maximum(ai, bi))
        c = np.where(inside, c, mid)
        fc = _as_array(f(c, idx))
        keep_sign_of_a = np.sign(fc) == np.sign(fai)  # NaN compares False: the hi side
        x[idx], fx[idx] = c, fc
        # Illinois: the end kept twice in a row has its value halved
        fbi = np.where(keep_sign_of_a & (side[idx] == -1), 0.5 * fbi, fbi)
        fai = np.where(~keep_sign_of_a & (side[idx] == 1), 0.5 * fai, fai)
        fc_side = np.where(np.isnan(fc), -np.sign(fai) * np.inf, fc)
        a[idx], fa[idx] = np.where(keep_sign_of_a, c, ai), np.where(keep_sign_of_a, fc_side, fai)
        b[idx], fb[idx] = np.where(keep_sign_of_a, bi, c), np.where(keep_sign_of_a, fbi, fc_side)
        side[idx] = np.where(keep_sign_of_a, -1.0, 1.0)
        tol = np.maximum(xtol_all[idx] + rtol * np.abs(c), 4 * _EPS * np.abs(c))
        conv = (np.abs(fc) <= ftol_all[idx]) | (np.abs(b[idx] - a[idx]) <= tol)
        done[idx[conv]] = True
    return BracketedRoot(x, fx, a, b, done, iterations)


def bisect(predicate: Callable[[float], bool | None], lo: float, hi: float, *, xtol: float, max_iter: int = 200):
    """Where ``predicate`` changes from its value at ``lo`` to its value at ``hi``, by bisection.

    Parameters
    ----------
    predicate : callable
        ``predicate(x) -> bool or None``: True where ``x`` is on the ``lo`` side, False on the ``hi`` side
        (neither end is evaluated). None means undecided (e.g. no valid state there): the search stops
        with the bracket it has.
    lo, hi : float
        The bracket; ``lo > hi`` is allowed.
    xtol : float
        Stop when ``|hi − lo| ≤ xtol``.
    max_iter : int

    Returns
    -------
    (lo, hi, decided) : tuple
        The final bracket, and False if the search stopped on an undecided point.

    Examples
    --------
    >>> lo, hi, decided = bisect(lambda x: x * x < 2.0, 0.0, 2.0, xtol=1e-12)
    >>> round(lo, 10), round(hi, 10), decided
    (1.4142135624, 1.4142135624, True)
    """
    lo, hi = float(lo), float(hi)
    for _ in range(max_iter):
        if abs(hi - lo) <= xtol:
            break
        mid = 0.5 * (lo + hi)
        if mid in (lo, hi):
            break
        side = predicate(mid)
        if side is None:
            return lo, hi, False
        if side:
            lo = mid
        else:
            hi = mid
    return lo, hi, True


@dataclass
class NewtonResult:
    """Result of :func:`newton` (arrays, one entry per problem).

    ``x`` is the last point evaluated (a caller that records its evaluations holds the state there),
    ``f`` the value there, ``step`` the size of the last Newton step from ``x`` (the error estimate of
    ``x`` when converged), ``converged`` whether the step fell below the tolerance or stopped shrinking.
    """

    x: np.ndarray
    f: np.ndarray
    step: np.ndarray
    converged: np.ndarray
    iterations: int


def newton(
    f_and_slope: Callable[[np.ndarray, np.ndarray], tuple],
    x0,
    *,
    xtol: float = 0.0,
    rtol: float = 0.0,
    lo=None,
    hi=None,
    sign_at_lo=None,
    max_iter: int = 50,
    stop_when_stalled: bool = True,
) -> NewtonResult:
    """Newton's method ``x ← x − f(x)/f'(x)`` for many scalar problems at once.

    Parameters
    ----------
    f_and_slope : callable
        ``f_and_slope(x, idx) -> (f, df/dx)`` at the points ``x`` of the problems ``idx``.
    x0 : float or array_like
        Starting points.
    xtol, rtol : float
        A problem has converged when its Newton step is at most ``xtol + rtol |x|``.
    lo, hi : float or array_like, optional
        A bracket: a step that would leave it is replaced by bisection of the bracket. With ``sign_at_lo``
        (the sign of ``f`` at ``lo``) the bracket shrinks onto the root as ``f`` is evaluated.
    max_iter : int
        Evaluations per problem at most.
    stop_when_stalled : bool
        Also stop (converged) once a step within ``10⁴`` times the tolerance is no smaller than half the
        previous one: the iteration has reached the noise of ``f`` (a converged solve of finite
        precision), where further steps only wander. (Far from the root Newton's steps may shrink
        slowly; that is not a stall.)

    Returns
    -------
    NewtonResult
        Problems whose slope vanished or that ran out of iterations have ``converged`` False.

    Examples
    --------
    >>> r = newton(lambda x, idx: (x**3 - 8.0, 3 * x**2), [1.0, 5.0], rtol=1e-15)
    >>> r.x.tolist(), bool(r.converged.all())
    ([2.0, 2.0], True)
    """
    x = _as_array(x0).copy()
    m = x.size
    lo_a = None if lo is None else np.broadcast_to(_as_array(lo), (m,)).astype(float).copy()
    hi_a = None if hi is None else np.broadcast_to(_as_array(hi), (m,)).astype(float).copy()
    fx = np.full(m, np.nan)
    step = np.full(m, np.inf)
    previous = np.full(m, np.inf)
    done = np.zeros(m, dtype=bool)
    converged = np.zeros(m, dtype=bool)
    iterations = 0
    for iterations, idx in _rounds(done, max_iter):  # noqa: B007 (the count is returned)
        xi = x[idx]
        fi, di = (_as_array(v) for v in f_and_slope(xi, idx))
        fx[idx] = fi
        with np.errstate(all="ignore"):
            si = -fi / di
        flat = ~np.isfinite(si)
        if lo_a is not None and hi_a is not None and sign_at_lo is not None:
            at_lo_side = np.sign(fi) == np.sign(sign_at_lo)
            lo_a[idx] = np.where(at_lo_side, xi, lo_a[idx])
            hi_a[idx] = np.where(at_lo_side, hi_a[idx], xi)
        step[idx] = np.abs(si)
        tol = xtol + rtol * np.abs(xi)
        conv = ~flat & (np.abs(si) <= tol)
        if stop_when_stalled:
            conv |= ~flat & (np.abs(si) >= 0.5 * previous[idx]) & (np.abs(si) <= STALL_WINDOW * tol)
        if lo_a is not None and hi_a is not None and sign_at_lo is not None:
            conv |= np.abs(hi_a[idx] - lo_a[idx]) <= tol  # the bracket has closed on the root
        previous[idx] = np.abs(si)
        converged[idx[conv]] = True
        done[idx[conv]] = True
        nxt = xi + np.where(flat, 0.0, si)
        if lo_a is not None and hi_a is not None:
            lo_i, hi_i = np.minimum(lo_a[idx], hi_a[idx]), np.maximum(lo_a[idx], hi_a[idx])
            outside = flat | ~((nxt > lo_i) & (nxt < hi_i))
            nxt = np.where(outside, 0.5 * (lo_i + hi_i), nxt)
            step[idx] = np.where(flat, np.abs(hi_i - lo_i), step[idx])
        else:
            done[idx[flat]] = True  # no slope and no bracket: nothing to go on
        x[idx[~conv]] = nxt[~conv]
    return NewtonResult(x, fx, step, converged, iterations)


def chebyshev_extremum(
    g: Callable[[np.ndarray], np.ndarray],
    lo,
    hi,
    maximum,
    *,
    ftol: float,
    xtol: float,
    nodes: int = 9,
    rounds: int = 6,
) -> tuple[np.ndarray, np.ndarray]:
    """Interior extrema of a smooth ``g``, one per bracket, by Chebyshev interpolation on shrinking brackets.

    Each round evaluates ``g`` at ``nodes`` Chebyshev points of every open bracket (one call for all),
    takes the extremum of the interpolant of degree ``nodes − 1`` (a root of its derivative, or a node),
    and shrinks the bracket 16-fold around it. A bracket is done after one round when the interpolant
    is resolved: its last two Chebyshev coefficients (which bound its error) are below ``ftol`` of the
    value, and the location error they imply (``n² · tail / half-width`` in the slope, over ``|g''|``) is
    below ``xtol``; otherwise, when the extremum's value and its location stop changing between rounds.

    Parameters
    ----------
    g : callable
        ``g(x) -> values`` for a flat array of points; non-finite values are an error.
    lo, hi : array_like
        Brackets that each hold one interior extremum.
    maximum : array_like of bool
        A maximum (else a minimum) in each bracket.
    ftol : float
        A bracket is done when its interpolated extremum changes by at most ``ftol · max(1, |g*|)``
        between rounds and its location by at most ``xtol · |x*|`` (the value is quadratic in the location
        error: on the value alone the location may be off by about the square root of ``ftol``).
    xtol : float
        ... or when it is narrower than ``xtol · |x*|``.
    nodes, rounds : int
        Interpolation points per bracket, rounds at most.

    Returns
    -------
    (x, g) : tuple of ndarray
        The located extrema and the interpolated values there.

    Raises
    ------
    ValueError
        If ``g`` is not finite at some node (names the bracket).

    Examples
    --------
    >>> x, g = chebyshev_extremum(lambda x: np.sin(x), [1.0], [2.0], [True], ftol=1e-15, xtol=1e-12)
    >>> round(float(x[0]), 6), round(float(g[0]), 15)
    (1.570796, 1.0)
    """
    a, b = _as_array(lo).copy(), _as_array(hi).copy()
    sign = np.where(np.asarray(maximum, dtype=bool).reshape(-1), 1.0, -1.0) * np.ones_like(a)
    m = a.size
    x_star = 0.5 * (a + b)
    g_star = np.full(m, np.nan)
    g_prev = np.full(m, np.nan)
    x_prev = np.full(m, np.nan)
    open_ = np.ones(m, dtype=bool)
    unit = np.cos(np.pi * (np.arange(nodes) + 0.5) / nodes)[::-1]
    for _ in range(rounds):
        idx = np.flatnonzero(open_)
        if idx.size == 0:
            break
        x = 0.5 * (a[idx] + b[idx])[:, None] + 0.5 * (b[idx] - a[idx])[:, None] * unit[None, :]
        values = np.asarray(g(x.ravel()), dtype=float).reshape(idx.size, nodes)
        for j, i in enumerate(idx):
            if not np.all(np.isfinite(values[j])):
                raise ValueError(f"chebyshev_extremum: g is not finite in [{a[i]:.10g}, {b[i]:.10g}]")
            cheb = np.polynomial.Chebyshev.fit(x[j], sign[i] * values[j], nodes - 1, domain=[a[i], b[i]])
            roots = cheb.deriv().roots()
            roots = roots[np.abs(roots.imag) < 1e-9 * (b[i] - a[i])].real
            roots = roots[(roots >= a[i]) & (roots <= b[i])]
            cand = np.concatenate([roots, x[j]])
            cv = cheb(cand)
            x_star[i] = cand[np.argmax(cv)]
            g_star[i] = sign[i] * cv.max()
            width = b[i] - a[i]
            # converged interpolant: its last two Chebyshev coefficients bound its error in g (value) and,
            # through g'' at the extremum, in the location (the derivative's error is ≲ n² tail / half-width)
            tail = abs(cheb.coef[-1]) + abs(cheb.coef[-2])
            curvature = abs(float(cheb.deriv(2)(x_star[i])))
            resolved = (
                tail <= ftol * max(1.0, abs(g_star[i]))
                and curvature > 0
                and nodes**2 * tail / (0.5 * width) <= curvature * xtol * abs(x_star[i])
            )
            # the value settles long before the location (it is quadratic in the location's error): a bracket whose
            # value has settled is done only once its location has moved by at most xtol too (other quantities are
            # read at the location: the pressure at a volume maximum moved by 1.3e-9 with the sampling before)
            settled = abs(g_star[i] - g_prev[i]) <= ftol * max(1.0, abs(g_star[i])) and abs(
                x_star[i] - x_prev[i]
            ) <= xtol * abs(x_star[i])
            if resolved or settled or width <= xtol * abs(x_star[i]):
                open_[i] = False
            g_prev[i], x_prev[i] = g_star[i], x_star[i]
            half = max(width / 16, xtol * abs(x_star[i]))
            a[i], b[i] = max(a[i], x_star[i] - half), min(b[i], x_star[i] + half)
    return x_star, g_star
