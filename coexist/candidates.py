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
    ``1..N−1``), the pressure ``P = p̂_gas((N−k)V̂(u_a(P)) + kV̂(u_b(P)))``.

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

        idx = _sign_changes(hom(u))[0]
        if idx.size:
            for r in _refine(hom, u[idx], u[idx + 1]):
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
            rows, cols = _sign_changes(R)
            if rows.size == 0:
                continue
            kk = ks[rows, 0]

            def mixed(Pv, idx, kk=kk, ua_of=ua_of, ub_of=ub_of):
                k = kk[idx]
                return Pv - gas.pressure((zones - k) * curve.v(ua_of(Pv)) + k * curve.v(ub_of(Pv)))

            for k, Pr in zip(kk, _refine(mixed, P[cols], P[cols + 1])):
                out.append(Candidate((zones - int(k), int(k)), (float(ua_of(Pr)), float(ub_of(Pr))), curve.phi_hat))
    return out
