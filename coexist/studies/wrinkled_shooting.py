"""Shooting through hoop-wrinkled segments (tension-field theory), one state at a time.

A study of issue 12, step 2 (docs/physics.md, section 10): the equations of a hoop-wrinkled segment,
integrated by scipy's ``solve_ivp`` (DOP853, located events) between taut segments, before they go
into the vectorised integrator of :mod:`coexist.shooting`.

**Relaxed energy.** With the geometric stretches ``λ1 = ds/dR̂``, ``ρ = r̂/R̂`` and the material ones
``λ1' ≥ λ1``, ``λ2' ≥ ρ``, ``W_rel(λ1, ρ; Φ̂) = min W*(λ1', λ2'; Φ̂)``. Where the hoop direction is
wrinkled (``T̂2(λ1, ρ) ≤ 0 < T̂1``) the material hoop stretch is the *natural width* ``λ2*(λ1; Φ̂)``, the
root of ``T̂2(λ1, λ2*) = ∂W*/∂λ2 = 0`` with ``∂T̂2/∂λ2 > 0`` (:func:`natural_width`; neo-Hookean
``λ2* = [λ1²(1 − Φ̂²λ1²)]^(−1/4)``), and ``W_rel = W*(λ1, λ2*(λ1))`` does not depend on ``ρ``.

**Equations of a hoop-wrinkled segment** (``' = d/dR̂``). Stationarity of
``Π̂ = 2π∫ W_rel R̂ dR̂ − p̂ V̂`` in ``r̂(R̂), ẑ(R̂)`` gives the membrane equations of section 1 with
``T̂2 = ∂W_rel/∂ρ = 0`` and ``T̂1 = dW_rel/dλ1 = T̂1(λ1, λ2*)`` (the term ``T̂2 dλ2*/dλ1`` vanishes),
the pressure acting on the geometric surface:

* ``(R̂ T̂1)' = T̂2 cos θ = 0``, so ``R̂ T̂1 = C`` in the segment;
* ``R̂ T̂1 θ' = p̂ λ1 ρ R̂ − T̂2 sin θ``, so ``θ' = p̂ λ1 ρ R̂ / C = p̂ λ1 r̂ / C``;
* ``ρ' = (λ1 cos θ − ρ)/R̂`` (``r̂' = λ1 cos θ``);
* ``λ1' = −T̂1 / (R̂ K)``, ``K = dT̂1/dλ1 = T̂11 − T̂12²/T̂22`` at ``(λ1, λ2*)``, from ``(R̂ T̂1)' = 0`` with
  ``dλ2*/dλ1 = −T̂12/T̂22`` (``T̂12 = ∂T̂2/∂λ1``); ``K > 0`` is needed (else pull-in);
* quadratures ``V̂' = π ρ² R̂² λ1 sin θ``, ``ẑ' = λ1 sin θ`` with the geometric stretches,
  ``Q̂' = 2π q̂(λ1, λ2*) R̂``, ``Ψ̂' = 2π W*(λ1, λ2*) R̂`` with the material ones.

``C`` is fixed where the segment starts: ``C = R̂s T̂1(λ1, ρ)`` at the switch. The equations hold
unchanged under ``R̂ → cR̂``, ``p̂ → p̂/c`` (``C → cC``; every switching condition is a condition on
stretches only), so the taut shooting's scaling trick carries over: integrate with a trial pressure
``p̂t`` until the *geometric* hoop stretch ``ρ`` reaches ``λpre`` at ``R̂*``; the unit membrane has
``p̂ = p̂t R̂*``, ``V̂ = V̂t/R̂*³``, ``Q̂ = Q̂t/R̂*²``, ``Ψ̂ = Ψ̂t/R̂*²``, ``ẑ = ẑt/R̂*``, radii ``R̂/R̂*``.

**Switching.** Taut → hoop-wrinkled where ``T̂2(λ1, λ2)`` falls to 0 (then ``λ2 = λ2*(λ1)``);
hoop-wrinkled → taut where the gap ``λ2*(λ1) − ρ`` falls back to 0. ``λ1, ρ, θ`` and ``T̂1`` are
continuous across both. Along a branch of states at fixed ``Φ̂`` they satisfy ``dΨ̂ = p̂ dV̂``
(they are equilibria of the relaxed energy), which ``tests/test_wrinkled_shooting.py`` checks.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from scipy.integrate import solve_ivp

from ..model import QUADRATURE_FACTORS, MembraneModel
from ..shooting import trial_pressure
from ..wrinkling import natural_width, natural_width_neo_hookean

__all__ = ["RelaxedState", "natural_width", "natural_width_neo_hookean", "shoot_relaxed"]


@dataclass
class RelaxedState:
    """One state of the relaxed (tension-field) membrane, scaled to the unit membrane.

    Attributes
    ----------
    pole_stretch, phi_hat : float
        ``λ0`` and ``Φ̂``.
    status : str
        ``"ok"``, or why there is no state: ``"no_clamp"`` (``ρ`` never reaches ``λpre``),
        ``"pull_in"`` (no natural width, or ``dT̂1ʷ/dλ1 ≤ 0`` in a wrinkled segment),
        ``"meridional_wrinkling"`` (``T̂1`` reaches 0: not covered here), ``"lost_ellipticity"``
        (``∂T̂1/∂λ1`` reaches 0 in a taut segment), ``"folded_back"`` (``θ > π``),
        ``"too_many_switches"``, ``"step_limit"``, ``"solver"`` (``solve_ivp`` failed),
        ``"wrinkled_at_pole"`` (``T̂0 ≤ 0``: no pressurised state with a taut pole, docs/physics.md).
    p_hat, v_hat, q_hat, psi_hat, apex_height : float
        ``p̂``, ``V̂``, ``Q̂`` (material area), ``Ψ̂``, ``ẑ`` at the pole.
    clamp_radius : float
        ``R̂*`` of the trial integration (the scale).
    p_trial : float
        Trial pressure ``p̂t``.
    wrinkled_radii : list of (float, float)
        Hoop-wrinkled intervals ``[R̂start, R̂end]`` of the unit membrane.
    wrinkled_fraction : float
        Their reference area over ``π``: ``Σ (R̂end² − R̂start²)``.
    segments : list of dict
        Per segment: ``kind`` (``"taut"`` or ``"wrinkled"``), ``R`` (start, end; trial radius),
        ``C`` (``R̂T̂1``, wrinkled only) and ``solution`` (scipy's dense output in the trial radius,
        rows ``λ1, ρ, θ, V̂/π, Q̂/2π, Ψ̂/2π, ẑ``).
    switches : list of dict
        Per switch: ``kind`` (``"wrinkle"`` or ``"unwrinkle"``), ``R`` (unit membrane), the state
        ``y`` there and the one-sided values ``left``, ``right`` of ``(λ1, ρ, θ, T̂1)`` from the dense
        outputs of the two segments and their own tension formulas.
    steps : int
        Right-hand side evaluations.
    """

    pole_stretch: float
    phi_hat: float
    status: str = "ok"
    p_hat: float = math.nan
    v_hat: float = math.nan
    q_hat: float = math.nan
    psi_hat: float = math.nan
    apex_height: float = math.nan
    clamp_radius: float = math.nan
    p_trial: float = math.nan
    wrinkled_radii: list = field(default_factory=list)
    wrinkled_fraction: float = math.nan
    segments: list = field(default_factory=list)
    switches: list = field(default_factory=list)
    steps: int = 0


class _BudgetExceeded(Exception):
    """The right-hand side evaluation budget of :func:`shoot_relaxed` is used up."""


def _event(fun, direction: float, terminal: bool = True):
    fun.direction = direction
    fun.terminal = terminal
    return fun


def shoot_relaxed(
    model: MembraneModel,
    pole_stretch: float,
    phi_hat: float = 0.0,
    *,
    rtol: float = 1e-11,
    atol_factor: float = 1e-2,
    p_trial: float | None = None,
    max_switches: int = 6,
    max_radius: float = 50.0,
    max_evaluations: int = 100_000,
) -> RelaxedState:
    """Shoot one state of the relaxed membrane from the pole to the clamp, through wrinkled segments.

    Taut segments solve the membrane equations (:meth:`MembraneModel.rhs`) from the series start at
    the pole (:meth:`MembraneModel.series_start` at ``R̂0 = min(1e-3, 0.1 rtol^¼)``); where the hoop
    tension ``T̂2(λ1, λ2)`` falls to 0 (a located terminal event) a hoop-wrinkled segment starts with
    ``C = R̂ T̂1`` (module docstring):

        ``λ1' = −T̂1/(R̂ K)``, ``ρ' = (λ1 cos θ − ρ)/R̂``, ``θ' = p̂t λ1 ρ / T̂1``,
        ``K = T̂11 − T̂12²/T̂22``, tensions at ``(λ1, λ2*(λ1))``,

    until the gap ``λ2*(λ1) − ρ`` falls back to 0 (taut again, with ``λ2 = ρ``) or the geometric hoop
    stretch reaches the clamp, ``ρ = λpre``, at ``R̂*``; then ``R̂ → R̂/R̂*``, ``p̂ = p̂t R̂*``.

    Parameters
    ----------
    model : MembraneModel
        The membrane.
    pole_stretch : float
        ``λ0 > λpre``.
    phi_hat : float
        ``Φ̂ ≥ 0``.
    rtol : float
        Relative tolerance of DOP853 (absolute: ``atol_factor · rtol`` times the size of each row at
        ``R̂ = 1`` from the series, as :mod:`coexist.shooting` does).
    atol_factor : float
        See ``rtol``.
    p_trial : float, optional
        Trial pressure; default the spherical-cap estimate :func:`coexist.shooting.trial_pressure`
        (so that ``R̂* ≈ 1``).
    max_switches : int
        Most switches between taut and wrinkled before giving up.
    max_radius : float
        Largest trial radius searched for the clamp.
    max_evaluations : int
        Budget of right-hand side evaluations (status ``"step_limit"`` when used up).

    Returns
    -------
    RelaxedState
    """
    l0, phi = float(pole_stretch), float(phi_hat)
    lam_pre = float(model.prestretch)
    if not l0 > lam_pre:
        raise ValueError(f"pole stretch {l0} must exceed the prestretch {lam_pre}")
    pt = float(trial_pressure(model, np.array([l0]), phi)[0]) if p_trial is None else float(p_trial)
    R0 = min(1e-3, 0.1 * rtol**0.25)
    start = np.array([float(v) for v in model.series_start(l0, pt, phi, R0)[:7]])
    unit = np.array([float(v) for v in model.series_start(l0, pt, phi, 1.0)[:7]])
    size = np.concatenate([[1.0, 1.0], np.abs(unit[2:])])
    atol = atol_factor * rtol * np.maximum(size, 1e-30)
    res = RelaxedState(pole_stretch=l0, phi_hat=phi, p_trial=pt)
    T0, alpha = (float(v) for v in model.pole(l0, phi)[:2])
    if not T0 > 0:
        res.status = "wrinkled_at_pole"
        return res
    if not alpha > 0:
        res.status = "lost_ellipticity"
        return res
    counter = [0]
    width = [math.nan]  # last natural width: the warm start of the next

    def tens(a, b):
        return [float(v) for v in model.tensions(a, b, phi)]

    def lam2s(l1):
        w = natural_width(model, l1, phi, guess=width[0] if math.isfinite(width[0]) else None)
        if math.isfinite(w):
            width[0] = w
        return w

    # --- taut: the model's equations ------------------------------------------------------------
    def count():
        counter[0] += 1
        if counter[0] > max_evaluations:
            raise _BudgetExceeded

    def taut_rhs(R, y):
        count()
        return np.array([float(v) for v in model.rhs(R, y[0], y[1], y[2], pt, phi)])

    taut_events = [
        _event(lambda R, y: y[1] - lam_pre, -1.0),  # 0: clamp
        _event(lambda R, y: tens(y[0], y[1])[1], -1.0),  # 1: hoop tension falls to 0: wrinkles
        _event(lambda R, y: tens(y[0], y[1])[0], -1.0),  # 2: meridional tension falls to 0
        _event(lambda R, y: tens(y[0], y[1])[2], -1.0),  # 3: ∂T̂1/∂λ1 falls to 0
        _event(lambda R, y: y[2] - math.pi, 1.0),  # 4: folds back
    ]
    taut_codes: tuple[str, ...] = ("clamp", "wrinkle", "meridional_wrinkling", "lost_ellipticity", "folded_back")

    # --- hoop-wrinkled: R T̂1 = C, tensions at the natural width ----------------------------------
    def wrinkled_parts(R, y):
        l1 = y[0]
        l2 = lam2s(l1)
        T1, _, T11, T12, _, _, T22 = tens(l1, l2)
        K = T11 - T12 * T12 / T22
        return l2, T1, K

    def wrinkled_rhs(R, y):
        count()
        l1, rho, th = y[0], y[1], y[2]
        l2, T1, K = wrinkled_parts(R, y)
        s, c = math.sin(th), math.cos(th)
        # Q̂'/2π and Ψ̂'/2π at the material stretches (the model's rows 4, 5 at λ2 = λ2*)
        mat = model.rhs(R, l1, l2, th, pt, phi)
        return np.array(
            [
                -T1 / (R * K),
                (l1 * c - rho) / R,
                pt * l1 * rho / T1,
                (rho * R) ** 2 * l1 * s,
                float(mat[4]),
                float(mat[5]),
                l1 * s,
            ]
        )

    def gap(R, y):
        w = lam2s(y[0])
        return (w if math.isfinite(w) else -1.0) - y[1]  # no width: as if taut again (caught below)

    wrinkled_events = [
        _event(lambda R, y: y[1] - lam_pre, -1.0),  # 0: clamp (geometric hoop stretch)
        _event(gap, -1.0),  # 1: the gap closes: taut again
        _event(lambda R, y: wrinkled_parts(R, y)[2], -1.0),  # 2: K = dT̂1ʷ/dλ1 falls to 0: pull-in
        _event(lambda R, y: y[2] - math.pi, 1.0),  # 3: folds back
    ]
    wrinkled_codes = ("clamp", "unwrinkle", "pull_in", "folded_back")

    R, y, kind = R0, start, "taut"
    segments: list[dict[str, Any]] = []
    switches: list[dict[str, Any]] = []
    status = "no_clamp"
    while True:
        if kind == "taut":
            fun, events, codes = taut_rhs, taut_events, taut_codes
        else:
            fun, events, codes = wrinkled_rhs, wrinkled_events, wrinkled_codes
            width[0] = math.nan
            C = R * tens(y[0], lam2s(y[0]))[0]
        try:
            with np.errstate(all="ignore"):
                sol = solve_ivp(
                    fun, (R, max_radius), y, method="DOP853", rtol=rtol, atol=atol, events=events, dense_output=True
                )
        except _BudgetExceeded:
            status = "step_limit"
            break
        seg: dict[str, Any] = {"kind": kind, "R": (R, float(sol.t[-1])), "solution": sol.sol}
        if kind == "wrinkled":
            seg["C"] = C
        segments.append(seg)
        if sol.status == -1:
            status = "solver"
            break
        hit = [k for k, te in enumerate(sol.t_events) if len(te)]
        if not hit:
            status = "no_clamp"
            break
        k = hit[0]
        R_new, y_new = float(sol.t_events[k][0]), np.array(sol.y_events[k][0], dtype=float)
        code = codes[k]
        if code == "clamp":
            status = "ok"
            R, y = R_new, y_new
            break
        if code not in ("wrinkle", "unwrinkle"):
            status = code
            break
        if len(switches) >= max_switches:
            status = "too_many_switches"
            break
        new_kind = "wrinkled" if code == "wrinkle" else "taut"
        switches.append({"kind": code, "R_trial": R_new, "y": y_new.copy()})
        R, y, kind = R_new, y_new, new_kind

    res.status = status
    res.segments = segments
    res.steps = counter[0]
    if status != "ok":
        return res
    Rs = R
    V, Q, Psi = (y[3 + i] * QUADRATURE_FACTORS[i] for i in range(3))
    res.clamp_radius = Rs
    res.p_hat = pt * Rs
    res.v_hat = V / Rs**3
    res.q_hat = Q / Rs**2
    res.psi_hat = Psi / Rs**2
    res.apex_height = y[6] / Rs
    res.wrinkled_radii = [(s["R"][0] / Rs, s["R"][1] / Rs) for s in segments if s["kind"] == "wrinkled"]
    res.wrinkled_fraction = float(sum(b**2 - a**2 for a, b in res.wrinkled_radii))
    # one-sided values at every switch, from the dense outputs of the two segments it joins
    for i, sw in enumerate(switches):
        Rw = sw["R_trial"]
        sides = []
        for seg in (segments[i], segments[i + 1]):
            yy = seg["solution"](Rw)
            l2 = yy[1] if seg["kind"] == "taut" else natural_width(model, yy[0], phi)
            sides.append(np.array([yy[0], yy[1], yy[2], tens(yy[0], l2)[0]]))
        sw["R"] = Rw / Rs
        sw["left"], sw["right"] = sides
    res.switches = switches
    return res
