"""Shooting from the pole to the clamp, for many pole stretches at once.

For a pole stretch ``λ0`` and voltage ``Φ̂`` the membrane equations are integrated from a series
start at the pole with a *trial* pressure ``p̂t`` until the hoop stretch returns to the clamp
value ``λ2 = λpre`` at some radius ``R*``. The equations are invariant under ``R → cR``,
``p → p/c`` (PHYSICS.md), so this is the exact clamped solution of a membrane of radius ``R*``,
and the membrane of unit radius carries

``p̂ = p̂t R*``,  ``V̂ = V̂t / R*³``,  ``Q̂ = Q̂t / R*²``,  ``Ψ̂ = Ψ̂t / R*²``,  ``ẑ = ẑt / R*``.

No iteration on the pressure is needed: one integration gives one point of the curve. The last
step lands exactly on the clamp by taking ``λ2`` as the independent variable (Hénon's trick).
The trial pressure comes from a spherical-cap estimate, so that ``R* ≈ 1`` and the tolerances
mean the same thing for every state.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from . import integrate as _int
from .errors import ModelRangeError, SceneError
from .model import QUADRATURE_FACTORS, MembraneModel
from .settings import SolverSettings

#: pole stretches closer than this (relative) to the clamp stretch are below double-precision resolution
FLAT_LIMIT = 5e-9
#: relative precision of a tension near the flat state, per unit of (λ0/λpre − 1): the integrator is
#: never asked for more than ROUNDOFF_TOLERANCE / (λ0/λpre − 1), which it could not deliver
ROUNDOFF_TOLERANCE = 1e-14
#: a Gent locking margin 1 − (I1 − 3)/Jlim below this at the pole counts as locked (the membrane is
#: then so stiff that no integration resolves it)
LOCKING_LIMIT = 1e-9

OK = 0
WRINKLED_AT_POLE = 10
WRINKLED = 11
LOCKED = 12
LOST_ELLIPTICITY = 13
NO_CLAMP = 14
STEP_LIMIT = 15
NOT_FINITE = 16
FOLDED_BACK = 17
NO_VOLTAGE = 18
BELOW_RESOLUTION = 19

#: a short tag and a sentence for every way a state can fail
REASONS = {
    OK: ("ok", "converged"),
    WRINKLED_AT_POLE: ("wrinkling", "the tension at the pole is not positive: the membrane wrinkles "
                       "(membrane theory does not hold)"),
    WRINKLED: ("wrinkling", "a tension turns negative between pole and clamp: the membrane wrinkles"),
    LOCKED: ("gent_locking", "the Gent chains lock (I1 - 3 reaches Jlim, or comes within 1e-9 of it)"),
    LOST_ELLIPTICITY: ("electromechanical_instability", "dT1/dλ1 vanishes: the membrane loses "
                       "stability to thinning (electromechanical instability)"),
    NO_CLAMP: ("no_equilibrium", "the membrane does not return to the clamp stretch within a radius "
               "of max_radius_factor (default 1000) times its estimated size: no equilibrium at this pole "
               "stretch within that search"),
    STEP_LIMIT: ("solver_budget", "the integration used up its step budget (SolverSettings.max_steps)"),
    NOT_FINITE: ("no_equilibrium", "the integration produced non-finite values"),
    FOLDED_BACK: ("no_equilibrium", "the meridian turns back on itself (θ > π)"),
    NO_VOLTAGE: ("no_equilibrium", "no voltage Φ̂ ≥ 0 holds this pole stretch at the requested pressure"),
    BELOW_RESOLUTION: ("out_of_range", "the pole stretch is within 5e-9 of the flat membrane: its deviation "
                       "from the clamp stretch is below what double precision resolves"),
}


def first_valid_run(ok) -> slice:
    """The first contiguous run of True in ``ok`` (which must hold at least one True)."""
    ok = np.asarray(ok, dtype=bool)
    first = int(np.argmax(ok))
    rest = np.flatnonzero(~ok[first:])
    return slice(first, first + int(rest[0]) if rest.size else ok.size)


def reason_tag(code: int) -> str:
    return REASONS[int(code)][0]


def reason_text(code: int) -> str:
    return REASONS[int(code)][1]


@dataclass
class MembraneStates:
    """Equilibrium states of one clamped zone, one entry per requested ``(λ0, Φ̂)``.

    Attributes
    ----------
    pole_stretch, phi_hat : ndarray
        The inputs.
    p_hat, v_hat, q_hat, psi_hat : ndarray
        Pressure ``pA/(μH)``, volume ``V/A³``, charge ``Q/(A²√(εμ))`` and potential
        ``Ψ/(μHA²)``, ``Ψ = F − ΦQ``. Entries whose ``status`` is not ``OK`` hold NaN and must not
        be used; :meth:`require_ok` raises for them.
    apex_height : ndarray
        Height of the pole above the clamp plane over ``A``.
    max_field : ndarray
        Largest true field ``Ê = Φ̂ λ1 λ2`` over the integration nodes.
    min_tension : ndarray
        Smallest of ``T̂1, T̂2`` over the integration nodes.
    clamp_radius : ndarray
        ``R*`` of the trial integration (diagnostic).
    status : ndarray of int
        ``OK`` or a failure code of :data:`REASONS`.
    fail_radius : ndarray
        Where a failed trajectory stopped, in units of the clamp radius estimated before the
        integration (its true clamp radius is unknown when it fails); NaN when ``OK``.
    steps : ndarray of int
        Integration steps taken per state (a diagnostic of cost).
    shapes : list or None
        With ``shape=True``: per state an array ``(R̂, r̂, ẑ)`` of the meridian.
    """

    pole_stretch: np.ndarray
    phi_hat: np.ndarray
    p_hat: np.ndarray
    v_hat: np.ndarray
    q_hat: np.ndarray
    psi_hat: np.ndarray
    apex_height: np.ndarray
    max_field: np.ndarray
    min_tension: np.ndarray
    clamp_radius: np.ndarray
    status: np.ndarray
    fail_radius: np.ndarray
    steps: np.ndarray
    shapes: list | None = field(default=None, repr=False)

    @property
    def ok(self) -> np.ndarray:
        return self.status == OK

    def require_ok(self) -> MembraneStates:
        """Raise :class:`ModelRangeError` naming the first failed input, else return self."""
        bad = np.flatnonzero(~self.ok)
        if bad.size:
            i = bad[0]
            raise ModelRangeError(
                f"no valid state at pole stretch {self.pole_stretch[i]:.6g}, Φ̂ = {self.phi_hat[i]:.6g}: "
                f"{reason_text(self.status[i])}",
                reason_tag(self.status[i]),
            )
        return self


def _cap_angle(l0):
    """Half-angle α of a spherical cap whose arc, ``λ0`` times the unit radius, spans a unit chord:
    ``sin α / α = 1/λ0`` on ``(0, π)``, by Newton's method from ``α ≈ √(6(1 − 1/λ0))`` (exact as
    ``λ0 → 1``; vectorised). Only an estimate is needed (it scales the trial pressure)."""
    target = 1.0 / l0
    a = np.minimum(np.sqrt(6.0 * (1.0 - target)), 3.0)
    for _ in range(8):
        s, c = np.sin(a), np.cos(a)
        g = s - target * a  # sin α − α/λ0, whose root is the same and better behaved
        a = np.clip(a - g / (c - target), 1e-300, math.pi * (1 - 1e-12))
    return a


def trial_pressure(model: MembraneModel, l0, phi):
    """Spherical-cap estimate of ``p̂`` at pole stretch ``λ0``: ``p̂ ≈ 2 T̂1(λ0, λ0) α / λ0²``.

    Only used to scale the trial integration so that it reaches the clamp near ``R̂ = 1``.
    """
    T0 = model.pole(l0, phi)[0]
    stretch = l0 / model.prestretch
    alpha = _cap_angle(np.maximum(stretch, 1 + 1e-12))
    return 2 * T0 * alpha / l0**2


def _check_inputs(model, l0, phi):
    if np.any(~np.isfinite(l0)) or np.any(l0 <= model.prestretch):
        bad = l0[~np.isfinite(l0) | (l0 <= model.prestretch)][0]
        raise SceneError(
            f"pole stretch must be finite and exceed the prestretch {model.prestretch:g}, got {bad:g}",
            "pole_stretch",
        )
    if np.any(~np.isfinite(phi)) or np.any(phi < 0):
        bad = phi[~np.isfinite(phi) | (phi < 0)][0]
        raise SceneError(f"Φ̂ must be a finite number >= 0, got {bad:g}", "phi_hat")
    if not model.has_voltage and np.any(phi != 0):
        raise SceneError("this model has no electrostatics: Φ̂ must be 0", "phi_hat")


def solve_states(model: MembraneModel, pole_stretch, phi_hat=0.0, settings: SolverSettings | None = None,
                 shape: bool = False) -> MembraneStates:
    """Equilibrium states of a clamped zone at the given pole stretches and voltages.

    Parameters
    ----------
    model : MembraneModel
    pole_stretch : array_like
        Pole stretches ``λ0 > λpre``.
    phi_hat : float or array_like
        Normalised voltages ``Φ̂ ≥ 0``, broadcast against ``pole_stretch``.
    settings : SolverSettings, optional
    shape : bool
        Also return the meridian ``(R̂, r̂, ẑ)`` of every state (costs extra output steps).

    Returns
    -------
    MembraneStates
        Failed states are flagged by ``status``; nothing in a flagged entry is to be trusted.
    """
    settings = settings or SolverSettings()
    l0, phi = np.broadcast_arrays(np.atleast_1d(np.asarray(pole_stretch, dtype=float)),
                                  np.asarray(phi_hat, dtype=float))
    l0 = np.array(l0, dtype=float).ravel()
    phi = np.array(phi, dtype=float).ravel()
    _check_inputs(model, l0, phi)
    n = l0.size
    lam_clamp = model.prestretch
    status = np.zeros(n, dtype=int)
    fail_radius = np.full(n, np.nan)

    with np.errstate(all="ignore"):
        T0, alpha, beta, W0, q0 = (np.broadcast_to(np.asarray(x, dtype=float), (n,)) for x in model.pole(l0, phi))
        margin0 = np.broadcast_to(np.asarray(model.tensions(l0, l0, phi)[4], dtype=float), (n,))
    status[l0 - model.prestretch < FLAT_LIMIT * model.prestretch] = BELOW_RESOLUTION
    status[(status == OK) & (margin0 <= LOCKING_LIMIT)] = LOCKED
    status[(status == OK) & ((T0 <= 0) | ~np.isfinite(T0))] = WRINKLED_AT_POLE
    status[(status == OK) & (alpha <= 0)] = LOST_ELLIPTICITY
    fail_radius[status != OK] = 0.0

    live = np.flatnonzero(status == OK)
    out = {k: np.full(n, np.nan) for k in ("p", "V", "Q", "Psi", "z", "R")}
    min_tension = np.where(status == OK, T0, np.nan)
    with np.errstate(all="ignore"):
        max_field = np.abs(np.asarray(model.tensions(l0, l0, phi)[5], dtype=float) * np.ones(n))
    steps = np.zeros(n, dtype=int)
    shapes = [None] * n if shape else None
    if live.size:
        with np.errstate(all="ignore"):
            _shoot(model, settings, l0, phi, T0, alpha, beta, W0, q0, live, lam_clamp, status, fail_radius,
                   out, min_tension, max_field, steps, shapes)
    bad = status != OK
    for k in out:
        out[k][bad] = np.nan
    R = out["R"]
    return MembraneStates(
        pole_stretch=l0, phi_hat=phi,
        p_hat=out["p"] * R, v_hat=out["V"] / R**3, q_hat=out["Q"] / R**2, psi_hat=out["Psi"] / R**2,
        apex_height=out["z"] / R, max_field=np.where(bad, np.nan, max_field),
        min_tension=np.where(bad, np.nan, min_tension), clamp_radius=R, status=status,
        fail_radius=fail_radius, steps=steps, shapes=shapes,
    )


def _shoot(model, settings, l0, phi, T0, alpha, beta, W0, q0, live, lam_clamp, status, fail_radius, out,
           min_tension, max_field, steps, shapes):
    """Integrate the live trajectories; fills ``out`` and the diagnostics in place."""
    l0, phi, T0, alpha, beta, W0, q0 = (a[live] for a in (l0, phi, T0, alpha, beta, W0, q0))
    p = trial_pressure(model, l0, phi)
    # series start at the pole: θ = cR, λ1 = λ0 + aR², λ2 = λ0 + bR² (derived in docs/series)
    c = p * l0**2 / (2 * T0)
    b = -(c**2) * (T0 + (3 * alpha - beta) * l0) / (16 * alpha)
    a = l0 * c**2 / 2 + 3 * b
    R0 = settings.series_radius
    y0 = np.vstack([
        l0 + a * R0**2, l0 + b * R0**2, c * R0,
        l0**3 * c * R0**4 / 4, q0 * R0**2 / 2, W0 * R0**2 / 2, l0 * c * R0**2 / 2,  # quadratures / factors
        p, phi,
    ])
    m = live.size
    # absolute tolerances that follow each trajectory's own scale (series values at R̂ = 1): a barely
    # inflated membrane has θ ~ δ, V̂ ~ δ, Ψ̂ ~ δ² for an apex deflection δ, and a fixed absolute
    # tolerance would swallow them
    size = np.vstack([np.ones(m), np.ones(m), np.abs(c), l0**3 * np.abs(c) / 4, np.abs(q0) / 2,
                      np.abs(W0) / 2, l0 * np.abs(c) / 2, np.ones(m), np.ones(m)])
    atol = settings.atol * np.maximum(size, 1e-30)
    # roundoff bounds what can be asked of a barely inflated membrane: its tensions are differences
    # of O(1) numbers that are O(λ0 − λpre), so their relative precision is ~ε/(λ0 − λpre)
    rtol = np.maximum(settings.rtol, ROUNDOFF_TOLERANCE / (l0 / lam_clamp - 1))
    local_min_T = T0.copy()
    local_max_E = max_field[live].copy()
    local_fail_R = np.full(m, np.nan)
    local_code = np.zeros(m, dtype=int)
    rows = [] if shapes is not None else None

    def f_radius(R, y):
        out = np.empty_like(y)
        out[7:] = 0.0
        return model.rhs_into(R, y[0], y[1], y[2], y[7], y[8], out)

    def check(R, y, cols):
        # generated functions return arrays shaped like their inputs (constants included)
        T1, T2, T11, _, margin, E = model.tensions(y[0], y[1], y[8])
        crossed = y[1] <= lam_clamp
        # a step that crosses the clamp is discarded: its state lies outside the membrane
        t_min = np.minimum(T1, T2)
        local_min_T[cols] = np.minimum(local_min_T[cols], np.where(crossed, np.inf, t_min))
        local_max_E[cols] = np.maximum(local_max_E[cols], np.where(crossed, 0.0, np.abs(E)))
        if rows is not None:
            rows.append((cols.copy(), R.copy(), y[1] * R, y[6].copy()))
        valid = crossed | ((t_min > 0) & (margin > 0) & (T11 > 0) & (np.abs(y[2]) <= math.pi))
        if valid.all():  # the common case: nothing to report
            return np.where(crossed, _int.CROSSED, _int.CONTINUE)
        code = np.zeros(cols.size, dtype=int)
        code[t_min <= 0] = WRINKLED
        code[crossed] = 0
        code[(code == 0) & (margin <= 0)] = LOCKED
        code[(code == 0) & (T11 <= 0)] = LOST_ELLIPTICITY
        code[(code == 0) & (np.abs(y[2]) > math.pi)] = FOLDED_BACK
        hit = code != 0
        local_fail_R[cols[hit]] = R[hit]
        local_code[cols[hit]] = code[hit]
        result = np.where(hit, _int.FAILED, _int.CONTINUE)
        result[crossed] = _int.CROSSED
        return result

    R_end = np.full(m, settings.max_radius_factor)
    res = _int.integrate(f_radius, np.full(m, R0), y0, R_end, rtol, atol,
                         settings.max_steps, event=check)
    steps[live] += res.steps
    code = np.where(res.status == _int.CROSSED, OK, local_code)
    code[res.status == _int.REACHED_END] = NO_CLAMP
    code[res.status == _int.STEP_LIMIT] = STEP_LIMIT
    code[(res.status >= _int.FAILED) & (local_code == 0)] = NOT_FINITE

    # final step onto the clamp with λ2 as the independent variable
    go = np.flatnonzero(code == OK)
    if go.size:
        yh = res.y[:, go]
        Rh = res.t[go]
        z0 = np.vstack([Rh, yh[0], yh[2:]])  # R, λ1, θ, V, Q, Ψ, z, p, φ

        def f_hoop(l2, z):
            d = np.empty((7, l2.size))
            d[:] = model.rhs(z[0], z[1], l2, z[2], z[7], z[8])
            inv = 1.0 / d[1]
            out = np.zeros_like(z)
            out[0] = inv
            out[1] = d[0] * inv
            out[2:7] = d[2:] * inv
            return out

        atol_h = np.vstack([np.full(go.size, settings.atol), atol[0, go], atol[2:, go]])
        # usually one step of the size of the remaining stretch lands on the clamp within tolerance;
        # the few that do not are integrated adaptively
        zf, err = _int.single_step(f_hoop, yh[1], z0, lam_clamp - yh[1], rtol[go][None, :], atol_h)
        landed = err <= 1.0
        steps[live[go]] += 1
        redo = np.flatnonzero(~landed)
        if redo.size:
            hop = _int.integrate(f_hoop, yh[1][redo], z0[:, redo], np.full(redo.size, lam_clamp), rtol[go][redo],
                                 atol_h[:, redo], settings.max_steps, h0=0.5 * np.abs(yh[1][redo] - lam_clamp))
            steps[live[go][redo]] += hop.steps
            zf[:, redo] = hop.y
            landed[redo] = hop.status == _int.REACHED_END
        bad_turn = ~landed | np.any(~np.isfinite(zf), axis=0) | (zf[0] <= Rh)
        code[go[bad_turn]] = NOT_FINITE
        good = go[~bad_turn]
        zg = zf[:, ~bad_turn]
        idx = live[good]
        out["R"][idx] = zg[0]
        out["p"][idx] = zg[7]
        fV, fQ, fPsi, _ = QUADRATURE_FACTORS
        out["V"][idx] = fV * zg[3]
        out["Q"][idx] = fQ * zg[4]
        out["Psi"][idx] = fPsi * zg[5]
        out["z"][idx] = zg[6]
        T1, T2 = model.tensions(zg[1], lam_clamp, zg[8])[:2]
        local_min_T[good] = np.minimum(local_min_T[good], np.minimum(T1, T2))
        wr = (np.minimum(T1, T2) <= 0)
        code[good[wr]] = WRINKLED
        local_fail_R[good[wr]] = zg[0][wr]
    status[live] = code
    fail_radius[live] = np.where(code == OK, np.nan, local_fail_R / np.where(np.isfinite(out["R"][live]),
                                                                              out["R"][live], 1.0))
    min_tension[live] = local_min_T
    max_field[live] = local_max_E
    if shapes is not None:
        _collect_shapes(rows, live, out, shapes, lam_clamp)


def _collect_shapes(rows, live, out, shapes, lam_clamp):
    """Assemble the meridian of each state from the accepted integration nodes, rescaled to R̂ = 1.

    Each shape is an array of rows ``(R̂, r̂, ẑ)`` from the pole to the clamp, ``ẑ`` measured
    up from the clamp plane.
    """
    per = {j: [(0.0, 0.0, 0.0)] for j in range(live.size)}
    for cols, R, r, z in rows:
        for j, c in enumerate(cols):
            per[int(c)].append((R[j], r[j], z[j]))
    for j, i in enumerate(live):
        Rs = out["R"][i]
        if not np.isfinite(Rs):
            continue
        pts = np.array(per[j])
        pts = pts[pts[:, 0] < Rs]
        ztot = out["z"][i]
        shape = np.vstack([pts, [Rs, lam_clamp * Rs, ztot]]) / Rs
        shape[:, 2] = ztot / Rs - shape[:, 2]
        shapes[i] = shape
