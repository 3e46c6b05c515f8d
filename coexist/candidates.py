"""First guesses of every equilibrium of ``N`` zones at one voltage, found on an interpolated zone curve.

The continuation (:mod:`coexist.continuation`) needs a seed on each stable piece of every
configuration it has not reached along the ramp. Here a zone curve at one voltage
(:class:`~coexist.zone_curves.ZoneCurve`, cubic splines through directly shot states) is cut into its
monotone pieces, and every configuration ``(N − k, k)`` with its two groups on two pieces is
bracketed on a dense sample of the pressure and refined on the splines. Nothing found here is
reported: each candidate is only a starting point for Newton's method on the exact equations.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .errors import SceneError
from .numerics.roots import bracketed_root
from .zone_curves import Branch, ZoneCurve


@dataclass(frozen=True)
class Candidate:
    """A first guess: group sizes (ordered by pole stretch), each group's ``u = √(λ0 − λpre)``, the voltage."""

    counts: tuple
    u: tuple
    phi_hat: float


def _sign_changes(y):
    """Indices i with a sign change (or an exact zero) between y[..., i] and y[..., i + 1]."""
    return np.nonzero((y[..., :-1] * y[..., 1:] < 0) | (y[..., :-1] == 0))


def _refine(residual, lo, hi):
    """Roots of ``residual(x, idx)`` on the brackets ``[lo, hi]`` (arrays), to 1e-12: first guesses only."""
    return bracketed_root(residual, lo, hi, xtol=1e-12, rtol=1e-12).x


def _near_misses(y):
    """Interior samples ``(row, i)`` where ``|y|`` dips without a sign change: a pair of roots may hide there.

    Next to a fold two roots of ``y`` approach each other (their distance ``∝ √(Φ̂ − Φ̂fold)``) and
    can both lie between two samples, so that no sign change shows them. A sample ``i`` is kept when
    ``y[i − 1]``, ``y[i]`` and ``y[i + 1]`` share one sign, ``|y[i]|`` is the smallest of the three, and
    (heuristic threshold) ``|y[i]| < max(|y[i − 1] − y[i]|, |y[i + 1] − y[i]|)``: the dip is shallower
    than the change from one sample to the next, so the extremum between them may reach zero.
    """
    a, b, c = y[..., :-2], y[..., 1:-1], y[..., 2:]
    same = (a * b > 0) & (b * c > 0)
    dip = (np.abs(b) <= np.abs(a)) & (np.abs(b) <= np.abs(c))
    shallow = np.abs(b) < np.maximum(np.abs(a - b), np.abs(c - b))
    rows, i = np.nonzero(np.atleast_2d(same & dip & shallow))
    return rows, i + 1


#: golden-section rounds at most for the extremum of a near miss (:func:`_roots`): 1e-12 of the bracket takes 58
GOLDEN_ROUNDS = 100


def _roots(f, x, y):
    """Roots of the rows of ``f`` sampled as ``y`` (shape ``(R, n)``) on the grid ``x``: first guesses only.

    ``f(xv, rows)`` evaluates the rows ``rows`` at the points ``xv``. Every sign change is refined
    (:func:`_refine`). At every near miss (:func:`_near_misses`) the extremum of ``f`` (towards zero) between the
    neighbouring samples is located by golden-section search (to ``1e-12`` of the bracket, or the floats' spacing there,
    in at most :data:`GOLDEN_ROUNDS` rounds); if ``f``
    changes sign there, both roots are refined, otherwise the extremum itself is returned: the exact
    equations may still have a pair of equilibria there (the curve's interpolation error is larger
    than the dip), which :func:`coexist.simulation.equilibria_on_gas` looks for around it.

    Returns
    -------
    rows, roots : numpy.ndarray
        The row and the location of each root (or near miss).
    """
    y = np.atleast_2d(y)
    rows, cols = _sign_changes(y)
    out_rows, out_x = [rows], [_refine(lambda xv, idx: f(xv, rows[idx]), x[cols], x[cols + 1]) if rows.size else x[:0]]
    nr, ni = _near_misses(y)
    if nr.size:
        lo, hi = x[ni - 1].astype(float), x[ni + 1].astype(float)
        g = (np.sqrt(5.0) - 1.0) / 2.0
        # 1e-12 of the bracket, but not below the spacing of the floats there: a bracket of 3e-6 around P = 1.9
        # cannot shrink to 3e-18, and the search went on for ever (fit --kind equal_free_energy, two Gent 60 zones on
        # a 1e6 ml chamber, radius 22.0687 mm, hung); GOLDEN_ROUNDS bounds it in any case
        tol = np.maximum(1e-12 * (hi - lo), 4 * np.finfo(float).eps * np.maximum(np.abs(lo), np.abs(hi)))
        sign = np.sign(y[nr, ni])  # the dip goes towards zero: minimise sign · f
        for _ in range(GOLDEN_ROUNDS):
            if not np.any(hi - lo > tol):
                break
            x1, x2 = hi - g * (hi - lo), lo + g * (hi - lo)
            left = sign * f(x1, nr) < sign * f(x2, nr)
            hi = np.where(left, x2, hi)
            lo = np.where(left, lo, x1)
        xm = 0.5 * (lo + hi)
        fm = f(xm, nr)
        cross = np.sign(fm) != np.sign(y[nr, ni])
        out_rows.append(nr[~cross])
        out_x.append(xm[~cross])
        if np.any(cross):
            cr, cm, ci = nr[cross], xm[cross], ni[cross]
            for a, b in ((x[ci - 1], cm), (cm, x[ci + 1])):
                out_rows.append(cr)
                out_x.append(_refine(lambda xv, idx, cr=cr: f(xv, cr[idx]), a, b))
    return np.concatenate(out_rows), np.concatenate(out_x)


class _BranchInverse:
    """``u(P)`` on one monotone piece of the curve, by linear interpolation of dense samples."""

    def __init__(self, curve: ZoneCurve, branch: Branch, samples: int):
        u = np.linspace(branch.start, branch.stop, samples)
        p = curve.p(u)
        order = np.argsort(p)
        self.p_sorted, self.u_sorted = p[order], u[order]

    def __call__(self, P):
        return np.interp(np.asarray(P, dtype=float), self.p_sorted, self.u_sorted)


def candidate_equilibria(curve: ZoneCurve, gas, zones: int, bulged=None, samples: int = 400) -> list[Candidate]:
    """First guesses of the equilibria of ``zones`` zones at the voltage of ``curve``.

    Homogeneous: ``p̂(u) = p̂_gas(N V̂(u))`` on each piece that is stable at fixed volume. Two groups:
    for each pair of such pieces with overlapping pressures and each ``k`` in ``bulged`` (default
    ``1..N−1``), the pressure ``P = p̂_gas((N−k)V̂(u_a(P)) + kV̂(u_b(P)))``. Roots are bracketed by
    sign changes on the samples; where the residual dips towards zero between samples without a sign
    change (a pair of roots next to a fold may hide there, :func:`_roots`), the extremum of the dip is a
    candidate too (or both roots, if the dip crosses zero on the splines).

    Parameters
    ----------
    curve : ZoneCurve
        One zone's curve at the voltage ``Φ̂`` of the candidates.
    gas : GasChamber or PressureReservoir
        What holds the pressure (its ``pressure(ΣV̂)``).
    zones : int
        Number of zones ``N ≥ 1``.
    bulged : iterable of int, optional
        The ``k`` (zones on the second piece) to look for; values outside ``1..N−1`` are ignored.
    samples : int
        Samples per piece (and per shared pressure range) on which roots are bracketed.

    Returns
    -------
    list of Candidate
        Homogeneous candidates (``counts = (N,)``) first, then two-group ones (``(N − k, k)``, the
        first group on the piece of smaller ``u``); refined to 1e-12 on the splines.

    Raises
    ------
    SceneError
        If ``zones`` is not a positive integer.
    """
    if not (isinstance(zones, (int, np.integer)) and zones >= 1):
        raise SceneError(f"zone count must be a positive integer, got {zones!r}", "zones")
    zones = int(zones)
    usable = [b for b in curve.branches if b.usable]
    out = []
    for a in usable:
        u = np.linspace(a.start, a.stop, samples)

        def hom(x, idx=None):
            return curve.p(x) - gas.pressure(zones * curve.v(x))

        for r in _roots(hom, u, hom(u))[1]:
            out.append(Candidate((zones,), (float(r),), curve.phi_hat))
    if zones < 2:
        return out
    ks = np.arange(1, zones) if bulged is None else np.asarray(sorted(set(int(k) for k in bulged)), dtype=int)
    ks = ks[(ks >= 1) & (ks < zones)][:, None]
    if ks.size == 0:
        return out
    inverses = {b.index: _BranchInverse(curve, b, samples) for b in usable}
    for ia, a in enumerate(usable):
        for b in usable[ia + 1 :]:
            lo = max(a.p_range[0], b.p_range[0])
            hi = min(a.p_range[1], b.p_range[1])
            if not hi > lo:
                continue
            ua_of, ub_of = inverses[a.index], inverses[b.index]
            P = np.linspace(lo, hi, samples)
            va, vb = curve.v(ua_of(P)), curve.v(ub_of(P))
            R = P[None, :] - gas.pressure((zones - ks) * va[None, :] + ks * vb[None, :])

            def mixed(Pv, rows, ua_of=ua_of, ub_of=ub_of):
                k = ks[rows, 0]
                return Pv - gas.pressure((zones - k) * curve.v(ua_of(Pv)) + k * curve.v(ub_of(Pv)))

            rows, roots = _roots(mixed, P, R)
            for k, Pr in zip(ks[rows, 0], roots):
                out.append(Candidate((zones - int(k), int(k)), (float(ua_of(Pr)), float(ub_of(Pr))), curve.phi_hat))
    return out
