"""N identical zones sharing one pressure and one voltage, on a chamber of gas or a pressure reservoir.

Potential of the whole system at fixed voltage (PHYSICS.md, normalised by ``μHA²``):

``G(V̂1..V̂N) = Σ Ψ̂(V̂i) + G_gas(Σ V̂i)``

with ``G_gas = −n̂ ln(V̂c + ΣV̂i) + p̂atm ΣV̂i`` for an isothermal ideal gas of amount
``n̂ = NkT/(μHA²)`` in a rigid chamber ``V̂c`` (seed eq. 1), or ``G_gas = −p̂ ΣV̂i`` for a pressure
reservoir. Its stationary points are the equilibria (every zone at the gauge pressure of the gas)
and its Hessian ``diag(dp̂/dV̂(V̂i)) + n̂/(V̂c + ΣV̂i)²`` decides stability.

An equilibrium *configuration* puts ``N − k`` zones in one state (on branch ``a`` of the zone's
curve) and ``k`` in another (on a later branch ``b``); ``k = 0`` is the homogeneous state.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from .branches import Branch, ZoneCurve
from .errors import SceneError


@dataclass(frozen=True)
class GasChamber:
    """Isothermal ideal gas, fixed amount, rigid chamber: ``(V̂c + ΣV̂)(p̂atm + p̂) = n̂``.

    Parameters
    ----------
    chamber_volume : float
        ``V̂c = Vc/A³``.
    atmospheric_pressure : float
        ``p̂atm = Patm A/(μH)``.
    gas_amount : float
        ``n̂ = NkT/(μHA²)``, fixed when the valves close.
    """

    chamber_volume: float
    atmospheric_pressure: float
    gas_amount: float
    name = "isothermal-ideal-gas"

    def __post_init__(self):
        for key in ("chamber_volume", "atmospheric_pressure", "gas_amount"):
            v = getattr(self, key)
            if not (math.isfinite(v) and v > 0):
                raise SceneError(f"must be a positive number, got {v!r}", key)

    @classmethod
    def closed_at(cls, chamber_volume, atmospheric_pressure, closing_pressure, zone_volumes_total):
        """The gas that fills chamber and zones at gauge pressure ``p̂`` when the valves close."""
        n = (chamber_volume + zone_volumes_total) * (atmospheric_pressure + closing_pressure)
        return cls(float(chamber_volume), float(atmospheric_pressure), float(n))

    def pressure(self, total_volume):
        """Gauge pressure ``p̂ = n̂/(V̂c + ΣV̂) − p̂atm``."""
        return self.gas_amount / (self.chamber_volume + total_volume) - self.atmospheric_pressure

    def stiffness(self, total_volume):
        """``−dp̂/dΣV̂ = n̂/(V̂c + ΣV̂)²`` (the gas resists a change of the total volume)."""
        return self.gas_amount / (self.chamber_volume + total_volume) ** 2

    def free_energy(self, total_volume):
        """``−n̂ ln(V̂c + ΣV̂) + p̂atm ΣV̂``."""
        return -self.gas_amount * np.log(self.chamber_volume + total_volume) + self.atmospheric_pressure * total_volume


@dataclass(frozen=True)
class PressureReservoir:
    """Pressure control (no chamber in the scene): the gauge pressure is ``p̂`` whatever the volume."""

    pressure_hat: float
    name = "pressure-control"

    def pressure(self, total_volume):
        return self.pressure_hat + 0.0 * np.asarray(total_volume)

    def stiffness(self, total_volume):
        return 0.0 * np.asarray(total_volume)

    def free_energy(self, total_volume):
        return -self.pressure_hat * total_volume


@dataclass
class Equilibrium:
    """One equilibrium configuration of N zones at one voltage.

    ``k`` zones sit in the state ``bulged`` (pole-stretch variable ``u_bulged``) and ``N − k`` in
    ``unbulged``; ``k = 0`` is homogeneous on ``branch_unbulged``. ``stable`` is True when the
    Hessian of the total potential is positive definite (smallest eigenvalue ``min_eigenvalue``).
    """

    zones: int
    k: int
    branch_unbulged: int
    branch_bulged: int | None
    u_unbulged: float
    u_bulged: float | None
    pole_stretch_unbulged: float
    pole_stretch_bulged: float | None
    p_hat: float
    v_unbulged: float
    v_bulged: float | None
    free_energy: float
    min_eigenvalue: float
    stable: bool
    phi_hat: float = 0.0
    notes: list = field(default_factory=list)

    @property
    def zone_volumes(self) -> list:
        """Volumes of every zone, unbulged first."""
        return [self.v_unbulged] * (self.zones - self.k) + [self.v_bulged] * self.k

    @property
    def label(self) -> str:
        if self.k == 0:
            return "homogeneous"
        return f"{self.k} of {self.zones} bulged"

    def distance(self, other: Equilibrium) -> float:
        """Distance in sorted zone-volume space (used to follow a state along a ramp)."""
        a, b = np.sort(self.zone_volumes), np.sort(other.zone_volumes)
        return float(np.max(np.abs(a - b)))


def _hessian_min_eigenvalue(curve: ZoneCurve, gas, zones, k, uu, ub):
    total = (zones - k) * float(curve.v(uu)) + (k * float(curve.v(ub)) if k else 0.0)
    kappa = np.full(zones, float(curve.dp_dv(uu)))
    if k:
        kappa[zones - k:] = float(curve.dp_dv(ub))
    H = np.diag(kappa) + float(gas.stiffness(total)) * np.ones((zones, zones))
    return float(np.linalg.eigvalsh(H)[0])


def _make(curve, gas, zones, k, a: Branch, b: Branch | None, uu, ub):
    vu = float(curve.v(uu))
    vb = float(curve.v(ub)) if k else None
    total = (zones - k) * vu + (k * vb if k else 0.0)
    G = (zones - k) * float(curve.psi(uu)) + (k * float(curve.psi(ub)) if k else 0.0) + float(gas.free_energy(total))
    lam = curve.to_stretch
    ev = _hessian_min_eigenvalue(curve, gas, zones, k, uu, ub)
    return Equilibrium(
        zones=zones, k=k, branch_unbulged=a.index, branch_bulged=(b.index if b is not None else None),
        u_unbulged=float(uu), u_bulged=(float(ub) if k else None), pole_stretch_unbulged=float(lam(uu)),
        pole_stretch_bulged=(float(lam(ub)) if k else None), p_hat=float(curve.p(uu)), v_unbulged=vu, v_bulged=vb,
        free_energy=G, min_eigenvalue=ev, stable=bool(ev > 0), phi_hat=curve.phi_hat,
    )


def _sign_changes(y):
    """Indices i with a sign change (or an exact zero) between y[..., i] and y[..., i + 1]."""
    return np.nonzero((y[..., :-1] * y[..., 1:] < 0) | (y[..., :-1] == 0))


class _BranchInverse:
    """``u(P)`` on one monotone branch: linear interpolation of dense samples, polished by Newton."""

    def __init__(self, curve: ZoneCurve, branch: Branch, samples: int):
        self.curve, self.branch = curve, branch
        u = np.linspace(branch.start, branch.stop, samples)
        p = curve.p(u)
        order = np.argsort(p)
        self.p_sorted, self.u_sorted = p[order], u[order]

    def __call__(self, P):
        P = np.asarray(P, dtype=float)
        u = np.interp(P, self.p_sorted, self.u_sorted)
        lo, hi = self.branch.start, self.branch.stop
        for _ in range(1):  # linear interpolation of 400 samples is good to ~1e-6: one step reaches ~1e-12
            dp = self.curve.dp(u)
            step = np.where(dp != 0, (self.curve.p(u) - P) / np.where(dp != 0, dp, 1.0), 0.0)
            u = np.minimum(np.maximum(u - step, lo), hi)
        return u


def _refine(residual, lo, hi, iterations=40):
    """Vectorised bracketed secant (Illinois) for roots of ``residual`` in [lo, hi] (arrays)."""
    a, b = np.array(lo, dtype=float), np.array(hi, dtype=float)
    fa, fb = residual(a), residual(b)
    side = np.zeros_like(a)
    for _ in range(iterations):
        with np.errstate(all="ignore"):
            c = np.where(fb != fa, b - fb * (b - a) / (fb - fa), 0.5 * (a + b))
        c = np.where(np.isfinite(c) & (c > np.minimum(a, b)) & (c < np.maximum(a, b)), c, 0.5 * (a + b))
        fc = residual(c)
        left = np.sign(fc) == np.sign(fa)
        # replace the end with the same sign; Illinois halving of the kept end's value
        fb = np.where(left & (side == -1), 0.5 * fb, fb)
        fa = np.where(~left & (side == 1), 0.5 * fa, fa)
        a, fa = np.where(left, c, a), np.where(left, fc, fa)
        b, fb = np.where(left, b, c), np.where(left, fb, fc)
        side = np.where(left, -1, 1)
        if np.all((np.abs(b - a) <= 1e-12 * np.maximum(1.0, np.abs(b))) | (fc == 0)):
            break
    return np.where(np.abs(fa) < np.abs(fb), a, b)


def equilibria(curve: ZoneCurve, gas, zones: int, samples: int = 400) -> list[Equilibrium]:
    """Every equilibrium configuration of ``zones`` zones at the voltage of ``curve``.

    Homogeneous states: ``p̂(u) = p̂_gas(N V̂(u))`` on each usable branch. Mixed states: for each pair
    of usable branches ``a < b`` with overlapping pressure ranges and each ``k = 1..N−1``, the
    pressure ``P`` with ``P = p̂_gas((N−k)V̂(u_a(P)) + kV̂(u_b(P)))``, where ``u_a(P)``, ``u_b(P)`` invert
    the curve on each branch. Roots are bracketed on a dense sample and refined on the spline.
    """
    if not (isinstance(zones, (int, np.integer)) and zones >= 1):
        raise SceneError(f"zone count must be a positive integer, got {zones!r}", "zones")
    zones = int(zones)
    usable = [b for b in curve.branches if b.usable]
    found = []
    for a in usable:
        u = np.linspace(a.start, a.stop, samples)

        def hom(x):
            return curve.p(x) - gas.pressure(zones * curve.v(x))

        idx = _sign_changes(hom(u))[0]
        if idx.size:
            roots = _refine(hom, u[idx], u[idx + 1])
            for r in roots:
                found.append(_make(curve, gas, zones, 0, a, None, r, None))
    if zones < 2:
        return found
    inverses = {b.index: _BranchInverse(curve, b, samples) for b in usable}
    ks = np.arange(1, zones)[:, None]
    for ia, a in enumerate(usable):
        for b in usable[ia + 1:]:
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

            def mixed(Pv, kk=kk, ua_of=ua_of, ub_of=ub_of):
                return Pv - gas.pressure((zones - kk) * curve.v(ua_of(Pv)) + kk * curve.v(ub_of(Pv)))

            roots = _refine(mixed, P[cols], P[cols + 1])
            for k, Pr in zip(kk, roots):
                found.append(_make(curve, gas, zones, int(k), a, b, float(ua_of(Pr)), float(ub_of(Pr))))
    return found


def polish(model, gas, states: list, settings=None, iterations: int = 8) -> list:
    """Re-solve equilibria by direct shooting, all at once: exact to the solver tolerance.

    The equilibria found on interpolated curves carry the interpolation error (largest near the
    edges of the model's range). Here every state is corrected by Newton's method on the exact
    equilibrium conditions, evaluated by shooting (derivatives by forward differences in ``λ0``):

    - homogeneous: ``p̂(λ) = p̂_gas(N V̂(λ))``
    - mixed: ``p̂(λu) = p̂(λb)`` and ``p̂(λu) = p̂_gas((N−k)V̂(λu) + kV̂(λb))``

    Returns new :class:`Equilibrium` objects with ``notes`` saying ``polished`` (or why not: then
    the interpolated state is kept and says so).
    """
    from dataclasses import replace as _replace

    from .shooting import solve_states

    if not states:
        return []
    n = len(states)
    lu = np.array([s.pole_stretch_unbulged for s in states], dtype=float)
    lb = np.array([s.pole_stretch_bulged if s.k else np.nan for s in states], dtype=float)
    phi = np.array([s.phi_hat for s in states], dtype=float)
    zones = np.array([s.zones for s in states], dtype=float)
    k = np.array([s.k for s in states], dtype=float)
    mixed = k > 0
    done = np.zeros(n, dtype=bool)
    failed = np.zeros(n, dtype=bool)
    final = {key: np.full(n, np.nan) for key in ("pu", "vu", "psiu", "vb", "psib")}
    rel = 1e-7
    for _ in range(iterations):
        act = np.flatnonzero(~done & ~failed)
        if act.size == 0:
            break
        mx = act[mixed[act]]
        m = act.size
        j = mx.size
        # the states and, for the Newton matrix by forward differences, the states shifted by rel
        lam = np.concatenate([lu[act], lb[mx], lu[act] * (1 + rel), lb[mx] * (1 + rel)])
        ph = np.concatenate([phi[act], phi[mx], phi[act], phi[mx]])
        st = solve_states(model, lam, ph, settings)
        ok = st.ok
        pos = {i: t for t, i in enumerate(act)}
        idx = np.array([pos[i] for i in mx], dtype=int)
        okU = ok[:m] & ok[m + j:2 * m + j]
        okB = np.ones(m, dtype=bool)
        okB[idx] = ok[m:m + j] & ok[2 * m + j:]
        bad = ~(okU & okB)
        failed[act[bad]] = True
        pu, vu = st.p_hat[:m], st.v_hat[:m]
        pb, vb, dpb, dvb = (np.full(m, np.nan) for _ in range(4))
        pb[idx], vb[idx] = st.p_hat[m:m + j], st.v_hat[m:m + j]
        dpu = (st.p_hat[m + j:2 * m + j] - pu) / (lu[act] * rel)
        dvu = (st.v_hat[m + j:2 * m + j] - vu) / (lu[act] * rel)
        dpb[idx] = (st.p_hat[2 * m + j:] - pb[idx]) / (lb[mx] * rel)
        dvb[idx] = (st.v_hat[2 * m + j:] - vb[idx]) / (lb[mx] * rel)

        kk, nn = k[act], zones[act]
        total = (nn - kk) * vu + np.where(kk > 0, kk * np.nan_to_num(vb), 0.0)
        pg = gas.pressure(total)
        sg = gas.stiffness(total)  # −dp_gas/dV_total
        r2 = pu - pg
        is_mix = kk > 0
        # homogeneous: r = p(λ) − p_gas(N V(λ)), dr/dλ = p' + s N V'
        step_u = np.where(~is_mix, r2 / (dpu + sg * nn * dvu), 0.0)
        # mixed: [r1, r2] with r1 = p(λu) − p(λb)
        r1 = np.where(is_mix, pu - pb, 0.0)
        a11, a12 = dpu, -dpb
        a21, a22 = dpu + sg * (nn - kk) * dvu, sg * kk * dvb
        det = a11 * a22 - a12 * a21
        with np.errstate(all="ignore"):
            du = np.where(is_mix, (r1 * a22 - a12 * r2) / det, step_u)
            db = np.where(is_mix, (a11 * r2 - a21 * r1) / det, 0.0)
        # converged where the conditions already hold at the shot states: keep those, no further step
        tol = 1e-9 * np.maximum(1.0, np.abs(pu))
        conv = ~bad & (np.abs(r2) <= tol) & (np.abs(r1) <= tol)
        ci = act[conv]
        done[ci] = True
        final["pu"][ci], final["vu"][ci], final["psiu"][ci] = pu[conv], vu[conv], st.psi_hat[:m][conv]
        if j:
            psib = np.full(m, np.nan)
            psib[idx] = st.psi_hat[m:m + j]
            final["vb"][ci], final["psib"][ci] = vb[conv], psib[conv]
        good = ~bad & ~conv & np.isfinite(du) & np.isfinite(db)
        failed[act[~good & ~bad & ~conv]] = True
        lu[act[good]] -= du[good]
        lb[act[good & is_mix]] -= db[good & is_mix]
    out = []
    for i, s in enumerate(states):
        if not done[i]:
            out.append(_replace(s, notes=s.notes + ["not polished: kept the interpolated state"]))
            continue
        vu_i = float(final["vu"][i])
        vb_i = float(final["vb"][i]) if mixed[i] else None
        total = (s.zones - s.k) * vu_i + (s.k * vb_i if s.k else 0.0)
        G = (s.zones - s.k) * float(final["psiu"][i]) + (s.k * float(final["psib"][i]) if s.k else 0.0) \
            + float(gas.free_energy(total))
        out.append(_replace(
            s, pole_stretch_unbulged=float(lu[i]), pole_stretch_bulged=(float(lb[i]) if s.k else None),
            u_unbulged=float(np.sqrt(lu[i] - model.prestretch)),
            u_bulged=(float(np.sqrt(lb[i] - model.prestretch)) if s.k else None),
            p_hat=float(final["pu"][i]), v_unbulged=vu_i, v_bulged=vb_i, free_energy=G,
            notes=s.notes + ["polished"],
        ))
    return out


def continue_equilibrium(curve: ZoneCurve, gas, state: Equilibrium, iterations: int = 12):
    """The equilibrium of ``state``'s configuration on a new ``curve`` (the next voltage), by Newton's
    method on the spline from ``state``'s pole stretches; None if it does not converge there.

    Homogeneous: ``p̂(u) = p̂_gas(N V̂(u))``. Mixed: ``p̂(u_u) = p̂(u_b) = p̂_gas((N−k)V̂(u_u) + kV̂(u_b))``.
    Far cheaper than :func:`equilibria` (which finds every configuration); the ramp uses it to
    follow the state it is in and falls back to :func:`equilibria` when it fails.
    """
    N, k = state.zones, state.k
    lo, hi = curve.grid[0], curve.grid[-1]
    uu = float(curve.to_u(state.pole_stretch_unbulged))
    ub = float(curve.to_u(state.pole_stretch_bulged)) if k else 0.0
    if not (lo <= uu <= hi and (k == 0 or lo <= ub <= hi)):
        return None
    for _ in range(iterations):
        pu, vu, dpu, dvu = float(curve.p(uu)), float(curve.v(uu)), float(curve.dp(uu)), float(curve.dv(uu))
        if k:
            pb, vb, dpb, dvb = float(curve.p(ub)), float(curve.v(ub)), float(curve.dp(ub)), float(curve.dv(ub))
            total = (N - k) * vu + k * vb
        else:
            total = N * vu
        s = float(gas.stiffness(total))
        r2 = pu - float(gas.pressure(total))
        if k == 0:
            d = dpu + s * N * dvu
            if d == 0:
                return None
            step_u, step_b, r1 = r2 / d, 0.0, 0.0
        else:
            r1 = pu - pb
            a11, a12, a21, a22 = dpu, -dpb, dpu + s * (N - k) * dvu, s * k * dvb
            det = a11 * a22 - a12 * a21
            if det == 0 or not np.isfinite(det):
                return None
            step_u = (r1 * a22 - a12 * r2) / det
            step_b = (a11 * r2 - a21 * r1) / det
        uu, ub = uu - step_u, ub - step_b
        if not (lo <= uu <= hi and (k == 0 or lo <= ub <= hi)):
            return None
        if abs(step_u) + abs(step_b) <= 1e-12 * max(1.0, abs(uu) + abs(ub)) and abs(r1) + abs(r2) <= 1e-9:
            break
    else:
        return None

    # a state past a volume fold is unstable even under volume control: not a continuation
    if float(curve.dv(uu)) <= 0 or (k and float(curve.dv(ub)) <= 0):
        return None
    # the branches keep their indices from the state continued (no need to cut the new curve into
    # branches for that: the labels follow the state)
    a = Branch(state.branch_unbulged, lo, hi, bool(curve.dp(uu) > 0), True, (0.0, 0.0))
    b = Branch(state.branch_bulged, lo, hi, bool(curve.dp(ub) > 0), True, (0.0, 0.0)) if k else None
    return _make(curve, gas, N, k, a, b, uu, ub if k else None)
