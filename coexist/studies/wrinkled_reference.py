"""An independent second method for wrinkled membranes: the relaxed energy, discretised and minimised.

Tension-field theory (docs/physics.md, "Wrinkling: tension-field theory"): where a tension would be
negative the membrane wrinkles, and its energy is the *relaxed* energy

    W_rel(λ1, λ2; Φ̂) = min over λ1' ≥ λ1, λ2' ≥ λ2 of W*(λ1', λ2'; Φ̂)

(the local minimum on the branch connected to the taut state: at fixed voltage ``W*`` is not bounded
below for a neo-Hookean membrane), with ``λ1, λ2`` the *geometric* stretches of the surface and
``λ1', λ2'`` the *material* ones (the electrostatic term uses the material area, the pressure acts on
the geometric surface).

Discretisation, written from scratch (nothing of the shooting is used; :mod:`coexist.effects` only
supplies the strain energy as a function of ``I = I1 − 3`` and the electrostatic energy of
``K = λ1²λ2²``):

* nodes at reference radii ``0 = R_0 < … < R_n = 1``, unknowns ``r_i, z_i``; ``r_0 = 0`` (pole on the
  axis, ``z_0`` free), ``r_n = λpre``, ``z_n = 0`` (clamp);
* per element (one-point midpoint rule) the geometric stretches ``λ1 = |x_{i+1} − x_i|/ΔR`` and
  ``λ2 = (r_i + r_{i+1})/(R_i + R_{i+1})``, and two more unknowns, the material stretches ``a_i``
  (hoop) and ``b_i`` (meridional) with the constraints ``a_i ≥ λ2`` (linear) and
  ``b_i² ΔR² ≥ |x_{i+1} − x_i|²`` (smooth); at the optimum ``W*(b_i, a_i)`` is exactly the relaxed
  energy of the element, a constraint is active where the membrane is taut in that direction and
  inactive where it is wrinkled (its multiplier is the tension, zero there);
* total potential at fixed pressure and voltage
  ``Π̂ = Σ W*(b_i, a_i; Φ̂) 2π R_mid ΔR − p̂ V̂``, ``V̂ = Σ (π/3)(r_i² + r_i r_{i+1} + r_{i+1}²)(z_i − z_{i+1})``
  (exact for the piecewise-linear meridian: cone frusta between the membrane and the clamp plane),
  or at fixed volume (``min Ψ̂`` subject to ``V̂ = V̂target``; ``p̂`` is then the multiplier), which
  also reaches states that are saddles under pressure control;
* minimised by IPOPT through CasADi (exact sparse Hessian).

Normalisation as the shooting (docs/physics.md, section 1): ``R̂ = R/A``, ``p̂ = pA/(μH)``,
``V̂ = V/A³``, ``Φ̂ = (Φ/H)√(ε/μ)``, ``Ψ̂ = Ψ/(μHA²)``, ``Q̂ = Q/(A²√(εμ))``.
The errors are ``O(h²)`` in ``p̂, V̂`` and the pole stretch (midpoint rule); the ends of a wrinkled
region are located by linear interpolation of the *formal* tension (the taut formula evaluated at the
geometric stretch across the wrinkles, positive where taut, negative where wrinkled) between element
midpoints.
"""

from __future__ import annotations

import functools
import math
from typing import Any

import casadi as ca
import numpy as np

from ..effects import area_invariant, first_invariant
from ..model import MembraneModel

#: IPOPT options: silent, tight, and a small first barrier parameter: with the default (adaptive,
#: ~1) the barrier terms ``μ/gap`` of the 2n active constraints outweigh the element energies (each
#: ``~1/n``) and push the material stretches over the electromechanical barrier, where the relaxed
#: energy of a neo-Hookean membrane at fixed voltage has no minimum (runaway)
IPOPT_OPTIONS: dict[str, Any] = {
    "ipopt.print_level": 0,
    "ipopt.sb": "yes",
    "print_time": 0,
    "ipopt.tol": 1e-10,
    "ipopt.acceptable_tol": 1e-8,
    "ipopt.max_iter": 300,
    "ipopt.bound_relax_factor": 0.0,  # the constraints λ' ≥ λ hold exactly (default relaxes them by 1e-8)
    "ipopt.mu_strategy": "monotone",
    "ipopt.mu_init": 1e-9,
    "ipopt.bound_push": 1e-10,
    "ipopt.bound_frac": 1e-10,
    "ipopt.slack_bound_push": 1e-10,
    "ipopt.slack_bound_frac": 1e-10,
    "show_eval_warnings": False,  # a Gent trial step beyond locking evaluates to NaN; IPOPT backs off
}
#: a material stretch this many times the largest geometric stretch counts as running away (no
#: relaxed state: at fixed voltage a neo-Hookean W* is unbounded below, electromechanical pull-in)
RUNAWAY_FACTOR = 20.0
#: IPOPT return statuses counted as converged (with the objective scaled by n, the last digits of the
#: KKT error at tol 1e-10 are sometimes out of reach: IPOPT then stops on a search direction below
#: machine precision at the solution)
CONVERGED = ("Solve_Succeeded", "Solved_To_Acceptable_Level", "Search_Direction_Becomes_Too_Small")
#: elements of the first, coarse solve when no starting shape is given (its result starts the fine one)
COARSE = 40


def mesh(n: int, kind: str = "uniform") -> np.ndarray:
    """Reference radii ``R_0 = 0 < … < R_n = 1``.

    Parameters
    ----------
    n : int
        Number of elements.
    kind : str
        ``uniform`` or ``graded`` (``R(t) = t²/2 + (1 − cos πt)/4``: finer at the pole and the clamp).

    Returns
    -------
    ndarray
        ``n + 1`` radii.
    """
    t = np.linspace(0.0, 1.0, n + 1)
    if kind == "uniform":
        return t
    if kind == "graded":
        R = 0.5 * t**2 + 0.25 * (1 - np.cos(np.pi * t))
        R[-1] = 1.0
        return R
    raise ValueError(f"unknown mesh kind {kind!r}")


def _energy(model: MembraneModel, l1, l2, phi):
    """``W*(λ1, λ2; Φ̂)`` built from the model's effects (CasADi or numpy)."""
    w = model.elasticity.energy_of_invariant(first_invariant(l1, l2))
    return w + model.electrostatics.energy_of_invariant(area_invariant(l1, l2), phi)


@functools.lru_cache(maxsize=8)
def _tension_functions(model: MembraneModel) -> ca.Function:
    l1, l2, phi = ca.SX.sym("l1"), ca.SX.sym("l2"), ca.SX.sym("phi")
    W = _energy(model, l1, l2, phi)
    T1, T2 = ca.gradient(W, l1), ca.gradient(W, l2)
    return ca.Function("tensions", [l1, l2, phi], [W, T1, T2])


def tensions(model: MembraneModel, l1, l2, phi):
    """``(W*, T̂1, T̂2)`` at material stretches ``λ1, λ2`` (numpy arrays, CasADi derivatives).

    Parameters
    ----------
    model : MembraneModel
        The membrane.
    l1, l2 : array_like
        Stretches.
    phi : float or array_like
        Normalised voltage (one, or one per stretch: e.g. per element of a patterned zone, ``Φ̂/n`` or 0).

    Returns
    -------
    tuple of 3 ndarray
    """
    l1, l2 = np.broadcast_arrays(np.asarray(l1, dtype=float), np.asarray(l2, dtype=float))
    f = _tension_functions(model).map(l1.size)
    if np.ndim(phi):
        phi = np.broadcast_to(np.asarray(phi, dtype=float), l1.shape).ravel()[None, :]
    out = f(l1.ravel()[None, :], l2.ravel()[None, :], phi)
    return tuple(np.asarray(x).reshape(l1.shape) for x in out)


def element_layers(pattern, Rm: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Per element (midpoint ``Rm``) the layer count ``n`` and the electrode flag ``e`` (1 or 0) of a patterned
    zone: the region whose reference radii hold the midpoint (docs/physics.md, section 12). No pattern: one
    layer with electrode everywhere.

    Parameters
    ----------
    pattern : ZonePattern or None
        The regions (:class:`coexist.patterned.ZonePattern`).
    Rm : ndarray
        Element midpoints.

    Returns
    -------
    layers, electrode : ndarray
    """
    if pattern is None:
        return np.ones(Rm.size), np.ones(Rm.size)
    outer = np.array([r.outer for r in pattern.regions])
    k = np.minimum(np.searchsorted(outer, Rm), outer.size - 1)
    layers = np.array([float(r.layers) for r in pattern.regions])[k]
    electrode = np.array([1.0 if r.electrode else 0.0 for r in pattern.regions])[k]
    return layers, electrode


@functools.lru_cache(maxsize=32)
def _solver(model: MembraneModel, n: int, kind: str, control: str, pattern=None):
    """The NLP on one mesh; parameters ``(Φ̂, p̂ or V̂target)``. A patterned zone: an element of a region of
    ``n`` layers carries ``n W*(b, a; e Φ̂/n)`` (``e`` its electrode flag), the pressure term unchanged."""
    R = mesh(n, kind)
    dR = np.diff(R)
    Rm = 0.5 * (R[:-1] + R[1:])
    layers, electrode = element_layers(pattern, Rm)
    lam_pre = model.prestretch
    # unknowns: r_1..r_{n-1}, z_0..z_{n-1}, a_0..a_{n-1}, b_0..b_{n-1}
    r_in = ca.SX.sym("r", n - 1)
    z_in = ca.SX.sym("z", n)
    a = ca.SX.sym("a", n)
    b = ca.SX.sym("b", n)
    phi, par = ca.SX.sym("phi"), ca.SX.sym("par")
    r = ca.vertcat(0, r_in, lam_pre)
    z = ca.vertcat(z_in, 0)
    dr, dz = r[1:] - r[:-1], z[1:] - z[:-1]
    l2geo = (r[:-1] + r[1:]) / (2 * Rm)
    if pattern is None:
        W = _energy(model, b, a, phi)
    else:
        W = ca.DM(layers) * _energy(model, b, a, phi * ca.DM(electrode / layers))
    psi = ca.dot(W, ca.DM(2 * math.pi * Rm * dR))
    vol = math.pi / 3 * ca.sum1((r[:-1] ** 2 + r[:-1] * r[1:] + r[1:] ** 2) * (z[:-1] - z[1:]))
    x = ca.vertcat(r_in, z_in, a, b)
    g_hoop = a - l2geo
    g_mer = b**2 - (dr**2 + dz**2) / ca.DM(dR**2)
    g = [g_hoop, g_mer]
    if control == "pressure":
        f = psi - par * vol
    else:
        f = psi
        g.append(vol - par)
    nlp = {"x": x, "p": ca.vertcat(phi, par), "f": f, "g": ca.vertcat(*g)}
    # the objective scaled by n: each element's energy and the multipliers of its constraints (its
    # tensions times its weight 2πR ΔR ~ 1/n) are then O(1), and so the complementarity gap μ/multiplier
    # of a taut element's active constraint does not grow with n
    scaling: dict[str, Any] = {"ipopt.obj_scaling_factor": float(n), "ipopt.nlp_scaling_method": "none"}
    solver = ca.nlpsol("s", "ipopt", nlp, {**IPOPT_OPTIONS, **scaling})
    aux = ca.Function("aux", [x, ca.vertcat(phi, par)], [psi, vol, l2geo, ca.sqrt(dr**2 + dz**2) / ca.DM(dR)])
    return solver, aux, R


def _initial_guess(model: MembraneModel, R: np.ndarray, initial, height: float):
    """Nodes ``r, z`` from a previous result (dict with ``R, r, z``), an array ``(R̂, r̂, ẑ)`` (a shooting
    shape), or a parabolic cap of the given height."""
    if initial is None:
        return model.prestretch * R, height * (1 - R**2)
    if isinstance(initial, dict):
        R0, r0, z0 = (np.asarray(initial[k], dtype=float) for k in ("R", "r", "z"))
    else:
        R0, r0, z0 = (np.asarray(v, dtype=float) for v in initial)
    return np.interp(R, R0, r0), np.interp(R, R0, z0)


def _root(x0: float, s0: float, x1: float, s1: float) -> float:
    """Root of the line through ``(x0, s0)``, ``(x1, s1)``."""
    return x0 + (x1 - x0) * s0 / (s0 - s1)


def _regions(Rm: np.ndarray, s: np.ndarray, R: np.ndarray) -> list[tuple[float, float]]:
    """Intervals of reference radius where ``s < 0``.

    An end is the root of the line through the two nearest midpoints on the *taut* side (``s ≥ 0``),
    where ``s`` is the tension itself and smooth up to the end (``O(h²)``), kept between the two
    midpoints that straddle it; with one taut midpoint only, the root between the straddling ones.
    """
    neg = s < 0
    m = len(s)
    out: list[tuple[float, float]] = []

    def end(t: int, w: int) -> float:
        # t: last taut midpoint, w: first wrinkled one beside it; t2: the taut one beyond t
        t2 = t + (t - w)
        if 0 <= t2 < m and not neg[t2] and s[t2] != s[t]:
            x = _root(Rm[t2], s[t2], Rm[t], s[t])
            lo, hi = sorted((Rm[t], Rm[w]))
            return float(min(max(x, lo), hi))
        return float(_root(Rm[t], s[t], Rm[w], s[w]))

    i = 0
    while i < m:
        if not neg[i]:
            i += 1
            continue
        j = i
        while j + 1 < m and neg[j + 1]:
            j += 1
        lo = R[0] if i == 0 else end(i - 1, i)
        hi = R[-1] if j == m - 1 else end(j + 1, j)
        out.append((float(lo), float(hi)))
        i = j + 1
    return out


def _patterned_regions(pattern, R: np.ndarray, Rm: np.ndarray, s: np.ndarray) -> list[tuple[float, float]]:
    """:func:`_regions` region by region of a patterned zone (the formal tensions jump at its interfaces, so a
    zero is never extrapolated across one; an interval that reaches an interface ends there), intervals that
    meet at an interface merged."""
    outer = np.array([r.outer for r in pattern.regions])
    k_el = np.minimum(np.searchsorted(outer, Rm), outer.size - 1)
    out: list[tuple[float, float]] = []
    for k in range(outer.size):
        el = np.flatnonzero(k_el == k)
        if not el.size:
            continue
        nodes = R[el[0] : el[-1] + 2]
        for lo, hi in _regions(Rm[el], s[el], nodes):
            if out and abs(out[-1][1] - lo) <= 1e-12:
                out[-1] = (out[-1][0], hi)
            else:
                out.append((lo, hi))
    return out


def relaxed_state(
    model: MembraneModel,
    p_hat: float | None = None,
    phi_hat: float = 0.0,
    *,
    volume: float | None = None,
    n: int = 200,
    mesh_kind: str = "uniform",
    initial=None,
    height: float = 0.3,
    pattern=None,
) -> dict:
    """The equilibrium of the relaxed energy of the discretised membrane (a local minimum).

    Parameters
    ----------
    model : MembraneModel
        Elasticity, electrostatics and prestretch ``λpre`` (clamp at ``R̂ = 1``, ``r̂ = λpre``).
    p_hat : float, optional
        Pressure ``p̂`` (pressure control: minimise ``Ψ̂ − p̂V̂``).
    phi_hat : float
        Normalised voltage ``Φ̂``.
    volume : float, optional
        Volume ``V̂`` instead of ``p̂`` (volume control: minimise ``Ψ̂`` at ``V̂``; ``p̂`` is the multiplier).
    n : int
        Number of elements.
    mesh_kind : str
        ``uniform`` or ``graded`` (:func:`mesh`).
    initial : dict or sequence of 3 arrays, optional
        Starting shape: a previous result, or ``(R̂, r̂, ẑ)`` (e.g. a shooting shape). Default: a
        parabolic cap of height ``height`` (``0`` for a flat start), solved first on
        :data:`COARSE` elements, whose result then starts the requested mesh.
    height : float
        Height of the default starting cap.
    pattern : ZonePattern, optional
        A patterned, layered zone (:class:`coexist.patterned.ZonePattern`): an element whose midpoint lies in a
        region of ``n`` layers carries ``n W*(b, a; Φ̂/n)`` with electrode, ``n W*(b, a; 0)`` without (docs/physics.md
        section 12), the pressure term unchanged; its charge is that of the electrode's elements. Put the
        interfaces on nodes (``fk n`` whole on a uniform mesh) for ``O(h²)`` errors. Default: one layer with
        electrode everywhere.

    Returns
    -------
    dict
        ``status`` (``"ok"``, ``"runaway"`` where a material stretch runs away — no relaxed state, the
        electromechanical pull-in of a neo-Hookean membrane — or IPOPT's return status), ``p_hat``,
        ``v_hat``, ``psi_hat``, ``q_hat``, ``apex_height``, ``pole_stretch`` (``r_1/R_1``), nodes ``R, r,
        z``, element midpoints ``Rm``, material stretches ``lam1, lam2``, geometric ``lam1_geo,
        lam2_geo``, tensions ``T1, T2`` (at the material stretches), formal tensions ``T1_formal,
        T2_formal`` (taut formula at the geometric stretch across, negative where wrinkled), the
        regions ``hoop_wrinkled_radii``, ``meridional_wrinkled_radii`` (lists of ``(R_start, R_end)``),
        ``slack_radii``, ``wrinkled_radii`` (where any tension vanishes), ``wrinkled_fraction`` (its
        reference area over ``π``), ``hoop_wrinkled_fraction``, ``iterations``. With a ``pattern`` the
        tensions are those of one layer of each element's stack (at its ``Φ̂/n`` or 0).
    """
    if (p_hat is None) == (volume is None):
        raise ValueError("give exactly one of p_hat and volume")
    control = "pressure" if volume is None else "volume"
    if initial is None and n > COARSE:
        initial = relaxed_state(
            model, p_hat, phi_hat, volume=volume, n=COARSE, mesh_kind=mesh_kind, height=height, pattern=pattern
        )
    solver, aux, R = _solver(model, int(n), mesh_kind, control, pattern)
    Rm = 0.5 * (R[:-1] + R[1:])
    dR = np.diff(R)
    layers, electrode = element_layers(pattern, Rm)
    phi_el = float(phi_hat) * electrode / layers  # the per-layer voltage of every element
    r0, z0 = _initial_guess(model, R, initial, height)
    r0[0], r0[-1], z0[-1] = 0.0, model.prestretch, 0.0
    l2g = (r0[:-1] + r0[1:]) / (2 * Rm)
    l1g = np.hypot(np.diff(r0), np.diff(z0)) / dR
    if isinstance(initial, dict) and "lam1" in initial:  # material stretches of a previous result
        a0 = np.maximum(np.interp(Rm, initial["Rm"], initial["lam2"]), l2g)
        b0 = np.maximum(np.interp(Rm, initial["Rm"], initial["lam1"]), l1g)
    else:
        a0, b0 = l2g * (1 + 1e-6), l1g * (1 + 1e-6)
    x0 = np.concatenate([r0[1:-1], z0[:-1], a0, b0])
    nn = int(n)
    lbx = np.concatenate([np.full(nn - 1, 1e-9), np.full(nn, -np.inf), np.full(nn, 0.05), np.full(nn, 0.05)])
    cap = RUNAWAY_FACTOR * max(float(model.prestretch), float(np.max(l1g)), float(np.max(l2g)), 2.0)
    ubx = np.concatenate([np.full(nn - 1, np.inf), np.full(nn, np.inf), np.full(2 * nn, cap)])
    lbg = np.zeros(2 * nn + (control == "volume"))
    ubg = np.full(2 * nn + (control == "volume"), np.inf)
    if control == "volume":
        ubg[-1] = 0.0
    par = float(p_hat) if control == "pressure" else float(volume)  # type: ignore[arg-type]
    sol = solver(x0=x0, p=[phi_hat, par], lbx=lbx, ubx=ubx, lbg=lbg, ubg=ubg)
    stats = solver.stats()
    x = np.asarray(sol["x"]).ravel()
    r = np.concatenate([[0.0], x[: nn - 1], [model.prestretch]])
    z = np.concatenate([x[nn - 1 : 2 * nn - 1], [0.0]])
    a = x[2 * nn - 1 : 3 * nn - 1]
    b = x[3 * nn - 1 :]
    psi, vol, l2geo, l1geo = (np.asarray(v).ravel() for v in aux(x, [phi_hat, par]))
    if control == "volume":
        p_out = -float(np.asarray(sol["lam_g"]).ravel()[-1])
    else:
        p_out = float(p_hat)  # type: ignore[arg-type]
    phi_t = phi_hat if pattern is None else phi_el
    W, T1, T2 = tensions(model, b, a, phi_t)
    _, _, T2f = tensions(model, b, l2geo, phi_t)
    _, T1f, _ = tensions(model, l1geo, a, phi_t)
    # formal tensions: taut where the material stretch equals the geometric one (the constraint is
    # active, its gap at the interior-point solution ~1e-10), so there the formal tension is the tension
    if pattern is None:
        hoop = _regions(Rm, T2f, R)
        mer = _regions(Rm, T1f, R)
        slack = _regions(Rm, np.maximum(T1f, T2f), R)
        anyw = _regions(Rm, np.minimum(T1f, T2f), R)
    else:  # the formal tensions jump at an interface: their zeros are located inside each region
        hoop = _patterned_regions(pattern, R, Rm, T2f)
        mer = _patterned_regions(pattern, R, Rm, T1f)
        slack = _patterned_regions(pattern, R, Rm, np.maximum(T1f, T2f))
        anyw = _patterned_regions(pattern, R, Rm, np.minimum(T1f, T2f))

    def fraction(regions):
        return float(sum(hi**2 - lo**2 for lo, hi in regions))

    ipopt_status = str(stats["return_status"])
    status = "ok" if ipopt_status in CONVERGED else ipopt_status
    if np.max(np.maximum(a, b)) > 0.99 * cap:
        status = "runaway"
    if pattern is None:
        q = float(phi_hat) * float(np.sum(b**2 * a**2 * 2 * math.pi * Rm * dR))
    else:  # the electrode's elements: per layer q̂ = (Φ̂/n) λ1²λ2², the stack's charge with no factor
        q = float(np.sum(phi_el * b**2 * a**2 * 2 * math.pi * Rm * dR))
    return {
        "status": status,
        "control": control,
        "p_hat": p_out,
        "v_hat": float(vol[0]),
        "psi_hat": float(psi[0]),
        "q_hat": q,
        "phi_hat": float(phi_hat),
        "apex_height": float(z[0]),
        "pole_stretch": float(r[1] / R[1]),
        "R": R,
        "r": r,
        "z": z,
        "Rm": Rm,
        "lam1": b,
        "lam2": a,
        "lam1_geo": l1geo,
        "lam2_geo": l2geo,
        "T1": T1,
        "T2": T2,
        "T1_formal": T1f,
        "T2_formal": T2f,
        "hoop_wrinkled_radii": hoop,
        "meridional_wrinkled_radii": mer,
        "slack_radii": slack,
        "wrinkled_radii": anyw,
        "wrinkled_fraction": fraction(anyw),
        "hoop_wrinkled_fraction": fraction(hoop),
        "iterations": int(stats["iter_count"]),
        "ipopt_status": ipopt_status,
    }


def flat_threshold_neo_hookean(prestretch: float) -> float:
    """``Φ̂c = √(λpre⁻² − λpre⁻⁸)``: the voltage at which a clamped flat neo-Hookean membrane at ``p̂ = 0``
    loses its (equibiaxial) tension ``T̂ = λ − λ⁻⁵ − Φ̂²λ³``.

    Parameters
    ----------
    prestretch : float
        ``λpre ≥ 1``.

    Returns
    -------
    float
    """
    lam = float(prestretch)
    return math.sqrt(lam**-2 - lam**-8)
