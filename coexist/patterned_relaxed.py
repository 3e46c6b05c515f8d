"""Patterned zones that wrinkle: the tension-field relaxation carried region by region and across interfaces.

A patterned zone (:mod:`coexist.patterned`, docs/physics.md section 12) whose taut state would need a negative
hoop tension somewhere — typically on the electrode side of an electrode edge at low inflation, where the
passive annulus holds back the active disc — wrinkles there. This module shoots such zones with the relaxed
equations of :mod:`coexist.wrinkling` in every region (docs/physics.md section 12, "Wrinkled regions"):

* region ``k`` (``nk`` layers, per-layer voltage ``φk = Φ̂/nk`` with electrode, ``0`` without, pressure
  ``p̂t/nk``) is integrated by :func:`coexist.wrinkling.shoot_relaxed` from its start node to its end radius
  ``s fk`` (``stop_radius``), or to the clamp ``ρ = λpre`` in the last region, switching taut ↔ hoop-wrinkled
  inside the region exactly as a uniform zone does (switches located inside the step);
* at an interface ``ρ``, ``θ`` (and the quadratures) are continuous and the meridional force per reference hoop
  length is, ``n⁻ T̂1ʳ⁻ = n⁺ T̂1ʳ⁺``, with the *relaxed* meridional tension ``T̂1ʳ = T̂1(λ1, ρ; φ)`` on a taut side
  and ``T̂1ʷ(λ1; φ) = T̂1(λ1, λ2*(λ1); φ)`` on a wrinkled one (:func:`relaxed_interface_stretch`); the far side is
  taut where the formal hoop tension ``T̂2(λ1⁺, ρ; φ⁺)`` at the taut root is not negative, else wrinkled;
* the interface scale ``s`` (interfaces at ``s fk``) is solved per state by a safeguarded secant iteration on
  ``G(σ) = ln R*(e^σ) − σ`` (:func:`solve_patterned_relaxed`), as :func:`coexist.patterned.solve_patterned_states`
  does with Newton's method; as there, no iterate goes below the scale at which the zone is flat
  (:data:`coexist.patterned.SCALE_FLOOR`: a state still too large there is below the flat zone's pole stretch,
  ``BELOW_FLAT``).

Exact derivatives (``derivatives=True``, :func:`_relaxed_derivative_pass`): one more relaxed shooting at the
converged ``σ`` carries the variational equations to ``(s, λ0, Φ̂)`` through every region's taut and wrinkled
segments (:func:`coexist.wrinkling.shoot_relaxed`, with the saltation at every switch) and across every interface
(the Jacobian of ``n⁻T̂1ʳ⁻ = n⁺T̂1ʳ⁺`` on the modes the two sides have, the interface moving with ``s``); ``s``
follows ``(λ0, Φ̂)`` by the implicit function theorem on ``G = 0``, as in :func:`coexist.patterned._derivative_pass`.
:func:`shoot_zone_relaxed` returns them with the states, so the N-zone layer follows a patterned zone through its
wrinkled states to their pull-in, as it follows a uniform one.
"""

from __future__ import annotations

import math

import numpy as np

from . import validation
from .errors import SceneError
from .model import QUADRATURE_FACTORS, MembraneModel
from .patterned import (
    LAST_REGION_REACH,
    MAX_FAILED_TRIALS,
    MAX_SCALE_ITERATIONS,
    MAX_SCALE_STEP,
    SCALE_FLOOR,
    SLOPE_CEILING,
    PatternedModel,
    PatternedStates,
    ZonePattern,
    _after_failed_trial,
    _at_floor,
    _below_floor_detail,
    _bracket_closed,
    _closed_bracket_detail,
    _keep_bracketed,
    _Layout,
    _layout,
    _merge,
    _meridional_tension,
    _patterned,
    _pole_region_scale,
    _pole_start,
    _sub_layout,
    _take_patterned,
    _take_pole,
    _trial,
    _trial_log_slopes,
    _uniform,
    _widen_bracket,
    interface_stretch,
)
from .settings import SolverSettings
from .shooting import (
    BELOW_FLAT,
    BELOW_RESOLUTION,
    FLAT_LIMIT,
    LOCKED,
    LOCKING_LIMIT,
    LOST_ELLIPTICITY,
    NO_CLAMP,
    NOT_FINITE,
    OK,
    PULL_IN,
    WRINKLED,
    WRINKLED_AT_POLE,
    MembraneStates,
    checked_state_inputs,
    clamped_derivatives,
    reason_text,
    solve_states,
)
from .wrinkling import STOPPED, TAUT, _natural_width_tensions, natural_width, shoot_relaxed
from .wrinkling import WRINKLED as WRINKLED_MODE

__all__ = [
    "NO_RELAXED_DERIVATIVES",
    "describe_wrinkles",
    "relax_wrinkled",
    "relaxed_interface_stretch",
    "relaxed_meridional_tension",
    "shoot_zone_relaxed",
    "solve_patterned_relaxed",
]

#: the reason relaxed patterned states had no derivatives before they were computed (no longer raised nor put into
#: ``failure_detail``; kept for code that imports it)
NO_RELAXED_DERIVATIVES = (
    "a wrinkled patterned zone has no exact derivatives yet (its relaxed states are computed without the "
    "variational equations), so it is out of the range of curves' limit points, equilibria and the ramp"
)
#: Newton iterations of the relaxed interface jump at most
JUMP_ITERATIONS = 80
#: the least share of the way to the estimate of a pull-in that a step of the relaxed interface root stays short of it
#: (:class:`_pull_in_secant`)
PULL_IN_SHORT = 1e-3
#: ... and the widest bracket (relative to its upper end) in which it does so: wider ones are bisected as before (the
#: roots of a wrinkled side past its first maximum, on its Gent-stiffened branch, were all found by the bisection while
#: their NaN-ended brackets were still 0.375 wide or wider, in the three tests that showed them and a neo-Hookean ring's
#: shape: helper-94)
PULL_IN_BRACKET = 0.125
#: internal codes of an iterate (never a state's status), as in :mod:`coexist.patterned`
_EARLY_CLAMP = 90
_FAR_CLAMP = 91


# --- the interface -----------------------------------------------------------------------------------------


def relaxed_meridional_tension(model: MembraneModel, l1, rho, phi, wrinkled, width_guess=None):
    """The relaxed meridional tension ``T̂1ʳ`` of one layer and its slope ``dT̂1ʳ/dλ1`` at fixed ``ρ``.

    Taut (``wrinkled`` False): ``T̂1(λ1, ρ; φ)`` and ``T̂11``. Hoop-wrinkled: ``T̂1ʷ(λ1) = T̂1(λ1, w; φ)`` at the
    natural width ``w = λ2*(λ1; φ)`` (``T̂2(λ1, w) = 0``, :func:`coexist.wrinkling.natural_width`) and
    ``K = T̂11 − T̂12²/T̂22`` (docs/physics.md section 10); ``ρ`` does not enter.

    Parameters
    ----------
    model : MembraneModel
    l1, rho, phi : ndarray
        Meridional stretch, geometric hoop stretch and per-layer voltage.
    wrinkled : ndarray of bool
        Which side is hoop-wrinkled.
    width_guess : ndarray, optional
        Starting natural widths.

    Returns
    -------
    T1, dT1, w : ndarray
        The tension, its slope and the material hoop stretch (``ρ`` where taut, the natural width where
        wrinkled; NaN where there is none: pull-in).
    """
    T1, slope, w, _ = _relaxed_tension(model, l1, rho, phi, wrinkled, width_guess)
    return T1, slope, w


def _relaxed_tension(model: MembraneModel, l1, rho, phi, wrinkled, width_guess=None):
    """:func:`relaxed_meridional_tension` ``(T1, dT1, w)`` and the locking margin at ``(λ1, w)`` (``model.tensions``'s
    fifth output), from one evaluation of the tensions.

    Where every column is wrinkled (one-dimensional), the tensions are those of the natural width's own last
    evaluation (:func:`coexist.wrinkling._natural_width_tensions`): the same points in the same order, so the same
    numbers, without evaluating them again (twice more with the margin of a wrinkled far side: 1 in 8 of the
    evaluations of a tension-field ring's `coexist coexistence`)."""
    l1, rho, phi, wrinkled = np.broadcast_arrays(
        np.asarray(l1, dtype=float), np.asarray(rho, dtype=float), np.asarray(phi, dtype=float), wrinkled
    )
    w = np.array(rho, dtype=float, copy=True)
    tensions = None
    if np.any(wrinkled):
        guess = None if width_guess is None else np.broadcast_to(width_guess, l1.shape)[wrinkled]
        # (a boolean index gives one-dimensional float copies, as _natural_width_tensions takes them)
        w[wrinkled], at_width = _natural_width_tensions(model, l1[wrinkled], phi[wrinkled], guess)
        if l1.ndim == 1 and wrinkled.all():
            tensions = at_width
    if tensions is None:
        tensions = model.tensions(l1, w, phi)
    T1, _, T11, T12, margin, _, T22 = (np.asarray(a, dtype=float) * np.ones(l1.shape) for a in tensions)
    with np.errstate(all="ignore"):
        slope = np.where(wrinkled, T11 - T12 * T12 / T22, T11)
    return T1, slope, w, margin


def _increasing_root(fun, target, x0):
    """Roots of ``fun(x)[0] = target`` on the branch where ``fun`` increases, from ``x0``: the bracket widened
    from ``x0`` (halving its lower end, doubling its upper one while the slope is positive), then Newton's
    method with bisection where a step leaves the bracket. NaN where no such root is bracketed (a NaN value
    counts as beyond the root). Returns ``(x, ok)``.

    Where the bracket's upper end has no value (NaN: the wrinkled far side's pull-in, no natural width) and the
    lower end lies below the target where ``fun`` falls, a step that Newton's method cannot take is the secant root
    of ``r = g/g'`` (``g = fun − target``) through the last two such points instead of the bisection, when ``r``
    shrinks towards the upper end (:class:`_pull_in_secant`): towards a pull-in where ``g → −∞`` like a power
    ``−C(λp − x)^(−α)``, ``r ≈ (λp − x)/α`` vanishes linearly at the pull-in ``λp``, so the iterates reach it
    superlinearly (the bisection had halved down to it at roundoff, ~50 evaluations of ``fun``, each a natural-width
    solve, for the NaN: 13 s of the 15 s of a neo-Hookean ring's ``coexist shape``, helper-94). Every iterate
    stays inside the bracket and the iteration still ends only where a step is at roundoff, so a value at or above
    the target met on the way (a rising root before the pull-in) is taken up by Newton's method as before."""
    x0 = np.asarray(x0, dtype=float)
    ok = np.ones(x0.shape, dtype=bool)

    def ends(a, b):
        g_b, d_b = fun(b)[:2]
        return fun(a)[0] - target, g_b - target, d_b

    with np.errstate(all="ignore"):
        lo, hi, g_lo, g_hi, _ = _widen_bracket(ends, 0.5 * x0, 2.0 * x0)
        # a NaN at the upper end (no natural width there) is beyond the root: the bracket stays
        ok &= (g_lo < 0) & ~(g_hi <= 0) & np.isfinite(g_lo)
        if not ok.any():
            # no root bracketed anywhere: the answer is NaN whatever Newton's method does (it had bisected every
            # column to roundoff against its unbracketed end, ~50 evaluations of ``fun`` for nothing: all 1190 calls
            # of a tension-field ring's wrinkled far side past its pull-in, 83 of a 88 s `coexist shape`)
            return np.full(x0.shape, np.nan), ok
        x = np.clip(x0, lo, hi)
        x = np.where((x > lo) & (x < hi), x, 0.5 * (lo + hi))
        pull_in = _pull_in_secant(x0.shape, np.isnan(g_hi))
        for _ in range(JUMP_ITERATIONS):
            x_at, (g_at, d_at) = x, fun(x)[:2]
            g, d = g_at - target, d_at
            lo = np.where(g < 0, x, lo)
            hi = np.where(~(g < 0), x, hi)
            step = g / d
            nxt = x - step
            settled = (g == 0) | (np.abs(step) <= 4e-16 * np.abs(x))
            bad = ~np.isfinite(nxt) | (nxt <= lo) | (nxt >= hi) | ~(d > 0)
            nxt = np.where(bad & ~settled, pull_in.step(x, g, step, lo, hi, bad & ~settled), nxt)
            nxt = np.where(settled, x, nxt)
            done = np.abs(nxt - x) <= 4e-16 * np.abs(x)
            x = nxt
            if done.all():
                break
        # where every column settled on its last iterate, that evaluation is the final one (it had been repeated)
        g, d = (g_at, d_at) if np.array_equal(x, x_at, equal_nan=True) else fun(x)[:2]
        ok &= np.isfinite(x) & (d > 0) & (np.abs(g - target) <= 1e-13 * np.maximum(1.0, np.abs(target)))
    return np.where(ok, x, np.nan), ok


class _pull_in_secant:
    """The step of :func:`_increasing_root` where Newton's cannot be taken: the bisection of ``[lo, hi]``, or where
    ``hi`` has no value (NaN) and ``lo`` is the last of two points below the target where ``g`` falls, with ``r = g/g'``
    shrinking from the first to the second (towards the pull-in), a step towards the estimate ``e`` of the pull-in:
    the secant root of ``r`` through them (``hi`` if beyond it), less the change of that estimate since the last
    step and at least :data:`PULL_IN_SHORT` of ``e − lo`` (so that the step stays below the pull-in, where the next
    point gives the next estimate), at most half of it, and at least two units in the last place above ``lo``; the
    bisection after a step that went past the pull-in (NaN) all the same."""

    def __init__(self, shape, hi_nan):
        self.hi_nan = np.array(hi_nan, dtype=bool)
        self.xa, self.ra, self.xb, self.rb, self.est = (np.full(shape, np.nan) for _ in range(5))
        self.aimed = np.zeros(shape, dtype=bool)  # the last step was one towards the estimate

    def step(self, x, g, r, lo, hi, need):
        self.hi_nan = np.where(g < 0, self.hi_nan, np.isnan(g))  # hi was moved to x where g is not below
        overshot = self.aimed & np.isnan(g)
        falling = (g < 0) & (r > 0)  # g < 0 and g' < 0
        self.xa, self.ra = np.where(falling, self.xb, self.xa), np.where(falling, self.rb, self.ra)
        self.xb, self.rb = np.where(falling, x, self.xb), np.where(falling, r, self.rb)
        est = np.minimum(self.xb - self.rb * (self.xb - self.xa) / (self.rb - self.ra), hi)
        use = need & self.hi_nan & ~overshot & (hi - lo <= PULL_IN_BRACKET * hi)
        use &= (self.xb == lo) & (self.xa < self.xb) & (self.rb < self.ra) & (est > lo)
        back = np.clip(np.abs(est - self.est), PULL_IN_SHORT * (est - lo), 0.5 * (est - lo))
        back = np.where(np.isfinite(back), back, 0.5 * (est - lo))
        # at least two units in the last place above lo: where the estimate is lo itself to rounding, that point (NaN)
        # closes the bracket (a far upper end had been bisected down to it, ~20 more evaluations)
        aim = np.maximum(est - back, lo + 2.0 * np.spacing(lo))
        use &= aim < hi
        self.est = np.where(use, est, self.est)
        self.aimed = use
        return np.where(use, aim, 0.5 * (lo + hi))


def relaxed_interface_stretch(model: MembraneModel, l1_in, w_in, wrinkled_in, rho, phi_in, n_in, phi_out, n_out):
    """``λ1⁺`` and the mode across an interface of a relaxed patterned zone: ``n⁺ T̂1ʳ⁺ = n⁻ T̂1ʳ⁻``.

    ``T̂1ʳ`` is the relaxed meridional tension (:func:`relaxed_meridional_tension`), ``ρ`` continuous. The far side
    is taut where the root of the taut equation ``n⁺ T̂1(λ1⁺, ρ; φ⁺) = n⁻ T̂1ʳ⁻`` (:func:`coexist.patterned.
    interface_stretch` where the near side is taut) leaves a formal hoop tension ``T̂2(λ1⁺, ρ; φ⁺) ≥ 0``; else
    it is hoop-wrinkled, ``λ1⁺`` the root of ``n⁺ T̂1ʷ(λ1⁺; φ⁺) = n⁻ T̂1ʳ⁻`` with its natural width ``w⁺ ≥ ρ``
    (docs/physics.md section 12, "Wrinkled regions": ``T̂1ʳ(·, ρ)`` is continuous and increasing, so exactly
    one of the two roots is consistent).

    Parameters
    ----------
    model : MembraneModel
        One layer.
    l1_in, w_in : ndarray
        ``λ1⁻`` and the near side's material hoop stretch (``ρ`` taut, the natural width wrinkled).
    wrinkled_in : ndarray of bool
        Whether the near side is hoop-wrinkled.
    rho : ndarray
        The geometric hoop stretch at the interface.
    phi_in, phi_out, n_in, n_out : ndarray
        Per-layer voltages and layer counts of both sides.

    Returns
    -------
    l1_out : ndarray
        ``λ1⁺`` (NaN where no consistent root).
    wrinkled_out : ndarray of bool
        Whether the far side is hoop-wrinkled (also where it would have to be but has no root: the wrinkled side's
        ``T̂1ʷ`` stays below the force, its pull-in).
    w_out : ndarray
        The far side's material hoop stretch.
    force : ndarray
        ``n⁻ T̂1ʳ⁻``, the meridional force per reference hoop length.
    ok : ndarray of bool
    """
    l1_in, w_in, wrinkled_in, rho, phi_in, n_in, phi_out, n_out = np.broadcast_arrays(
        *(np.asarray(a, dtype=float) for a in (l1_in, w_in, wrinkled_in, rho, phi_in, n_in, phi_out, n_out))
    )
    wr_in = wrinkled_in > 0
    T1_in, _, w_near = relaxed_meridional_tension(model, l1_in, rho, phi_in, wr_in, width_guess=w_in)
    force = n_in * T1_in
    target = force / n_out
    taut_l1 = np.full(l1_in.shape, np.nan)
    plain = ~wr_in
    if plain.any():  # the patterned jump itself (the same numbers as a taut patterned zone)
        taut_l1[plain] = interface_stretch(
            model, l1_in[plain], rho[plain], phi_in[plain], n_in[plain], phi_out[plain], n_out[plain]
        )[0]
    if wr_in.any():
        sel = wr_in

        def taut_side(x):  # locked points beyond every root (T̂1 → +∞ at the locking stretch)
            return _meridional_tension(model, x, rho[sel], phi_out[sel])

        taut_l1[sel] = _increasing_root(taut_side, target[sel], l1_in[sel])[0]
    with np.errstate(all="ignore"):
        T2_formal = np.asarray(model.tensions(taut_l1, rho, phi_out)[1]) * np.ones(l1_in.shape)
    taut_ok = np.isfinite(taut_l1) & (T2_formal >= 0)
    l1_out = np.where(taut_ok, taut_l1, np.nan)
    wrinkled_out = np.zeros(l1_in.shape, dtype=bool)
    w_out = np.where(taut_ok, rho, np.nan)
    need = np.flatnonzero(~taut_ok)
    if need.size:
        last_width = np.full(need.size, np.nan)  # the natural widths of the last evaluation: the next one's start

        def wrinkled_side(x):
            T1, K, w, margin = _relaxed_tension(
                model, x, rho[need], phi_out[need], np.ones(x.shape, dtype=bool), width_guess=last_width
            )
            last_width[:] = np.where(np.isfinite(w), w, last_width)
            # locked at its natural width (stretched along the meridian): beyond every root, as for a taut side
            with np.errstate(all="ignore"):
                locked = np.isfinite(w) & ~(margin > 0)
            return np.where(locked, np.inf, T1), np.where(locked, np.inf, K)

        start = np.where(np.isfinite(taut_l1[need]), taut_l1[need], l1_in[need])
        x, found = _increasing_root(wrinkled_side, target[need], start)
        w = np.full(need.size, np.nan)
        if found.any():
            w[found] = natural_width(model, x[found], phi_out[need][found], guess=rho[need][found])
        good = found & (w >= rho[need])
        l1_out[need[good]] = x[good]
        wrinkled_out[need] = good | np.isfinite(taut_l1[need])  # a taut root with a negative hoop tension
        w_out[need[good]] = w[good]
    ok = np.isfinite(l1_out)
    del w_near
    return l1_out, wrinkled_out, w_out, force, ok


# --- one pass over the regions ---------------------------------------------------------------------------------


def _blank_start(m: int, rows: int, atol) -> dict:
    """The start nodes of the next region's relaxed shooting (:func:`coexist.wrinkling.shoot_relaxed`'s
    ``start``) for ``m`` columns of ``rows`` rows, all NaN (taut) until the interface fills them."""
    blank = {k: np.full(m, np.nan) for k in ("R", "h", "min_T", "max_E")}
    return {**blank, "y": np.full((rows, m), np.nan), "atol": atol, "mode": np.full(m, TAUT)}


def _relaxed_pass(model, settings, lay, l0, p_t, sigma, pole, stops=None):
    """One relaxed shooting of every state with the interfaces at ``s fk`` (``s = e^σ``).

    With ``stops`` (increasing reference fractions in ``[0, 1]``, the interface fractions among them) the
    meridian is also recorded there (:func:`_record_stops`, for a profile): ``rows`` ``(stops, 7, m)`` holds the
    state rows (trial scaling; row 1 the geometric hoop stretch ``ρ``) at the radii ``radii`` ``(stops, m)``:
    ``stop · s`` inside a region (a stop of the shooting, which restarts there: the trajectory differs from the
    one without stops by the integration's tolerance), the interface's inner side at an interface fraction, the
    pole's series below the series radius, and the clamp (``ρ = λpre``, ``z`` the state's) at 1.

    Returns a dict: ``status`` (0 where the clamp was reached in the last region, :data:`_EARLY_CLAMP` where
    before it, :data:`_FAR_CLAMP` where not within ``LAST_REGION_REACH·s``, else a failure code), ``R`` (the
    clamp radius, or where the clamp stretch was met early), the quadratures ``p, V, Q, Psi, z`` (trial scaling,
    with their factors), ``minT`` (smallest stack tension ``n T̂``, relaxed), ``maxE``, ``steps``, ``failR``,
    ``intervals`` (per state the wrinkled intervals, trial scaling, contiguous ones merged), ``stiffness``
    (smallest ``K/T̂11`` at the bands' outer ends), ``edges`` (``(m, K − 1, 2, 5)``: both sides of every interface
    as ``(R̂, r̂, ẑ, θ, n T̂1ʳ)``), ``edge_modes`` (``(m, K − 1, 2)``, 1 where wrinkled) and ``detail`` (the region
    of a failure)."""
    K = lay.f.size
    m = l0.size
    s = np.exp(sigma)
    # the pole region's start (its series radius: per state where :func:`coexist.patterned._pole_start` gives one)
    y0, atol0, _series, T0, E0, *series_radius = pole
    R0 = np.broadcast_to(series_radius[0] if series_radius else settings.series_radius, (m,)).astype(float)
    res = {
        "status": np.zeros(m, dtype=int),
        "R": np.full(m, np.nan),
        "steps": np.zeros(m, dtype=int),
        "failR": np.full(m, np.nan),
        "minT": lay.n[0] * T0,
        "maxE": E0.copy(),
        "stiffness": np.full(m, np.inf),
        "edges": np.full((m, K - 1, 2, 5), np.nan),
        "edge_modes": np.zeros((m, K - 1, 2), dtype=int),
        "region": np.zeros(m, dtype=int),
    }
    for name in ("p", "V", "Q", "Psi", "z"):
        res[name] = np.full(m, np.nan)
    intervals: list[list] = [[] for _ in range(m)]
    start = {
        "R": R0.copy(),
        "y": y0.copy(),
        "h": R0.copy(),
        "min_T": T0.copy(),
        "max_E": E0.copy(),
        "atol": atol0.copy(),
        "mode": np.full(m, TAUT),
    }
    live = np.arange(m)
    fV, fQ, fPsi, _ = QUADRATURE_FACTORS
    if stops is not None:
        res["rows"], res["radii"] = _series_stops(model, lay, l0, p_t, s, stops, R0)
    for k in range(K):
        if live.size == 0:
            break
        last = k == K - 1
        stop = s[live] * (min(LAST_REGION_REACH, settings.max_radius_factor) if last else lay.f[k])
        sub = {key: (v[..., live] if isinstance(v, np.ndarray) else v) for key, v in start.items()}
        if stops is not None:
            sub = _record_stops(model, settings, l0[live], lay, k, s[live], sub, stops, res, live)
        shots = shoot_relaxed(model, settings, l0[live], lay.phi[k, live], start=sub, stop_radius=stop)
        res["steps"][live] += shots.steps
        end = shots.end
        assert end is not None
        st = shots.status
        n_k = lay.n[k, live]
        res["minT"][live] = np.minimum(res["minT"][live], n_k * shots.min_tension)
        res["maxE"][live] = np.maximum(res["maxE"][live], shots.max_field)
        band = shots.band_stiffness if shots.band_stiffness is not None else np.full(live.size, np.inf)
        res["stiffness"][live] = np.fmin(res["stiffness"][live], np.where(np.isfinite(band), band, np.inf))
        for j, i in enumerate(live):
            for a, b in end["intervals"][j]:
                if intervals[i] and abs(intervals[i][-1][1] - a) <= 1e-14 * max(1.0, abs(a)):
                    intervals[i][-1] = (intervals[i][-1][0], b)  # a band that goes on across the interface
                else:
                    intervals[i].append((a, b))
        failed = (st != OK) & (st != STOPPED)
        res["status"][live[failed]] = st[failed]
        res["failR"][live[failed]] = shots.fail_radius[failed]
        res["region"][live[failed]] = k
        if last:
            landed = st == OK
            res["status"][live[st == STOPPED]] = _FAR_CLAMP
            i = live[landed]
            res["R"][i] = shots.out["R"][landed]
            res["p"][i] = shots.out["p"][landed] * n_k[landed]
            res["V"][i] = shots.out["V"][landed]
            res["Q"][i] = shots.out["Q"][landed]
            res["Psi"][i] = shots.out["Psi"][landed] * n_k[landed]
            res["z"][i] = shots.out["z"][landed]
            if stops is not None:  # the clamp: ρ = λpre, the height's origin
                res["rows"][-1, 1, i], res["rows"][-1, 6, i] = model.prestretch, res["z"][i]
                res["radii"][-1, i] = res["R"][i]
            break
        early = st == OK
        res["status"][live[early]] = _EARLY_CLAMP
        res["R"][live[early]] = shots.out["R"][early]
        go = np.flatnonzero(st == STOPPED)
        cols = live[go]
        if go.size == 0:
            live = cols
            break
        ye = end["y"][:, go]  # rows: state (7), width, p̂t/nk, φk
        if stops is not None:  # the interface's inner side
            at = np.flatnonzero(stops == lay.f[k])
            if at.size:
                res["rows"][at[0]][:, cols] = ye[:7]
                res["radii"][at[0], cols] = end["R"][go]
        wr_in = end["mode"][go] == WRINKLED_MODE
        n_in, n_out = lay.n[k, cols], lay.n[k + 1, cols]
        phi_in, phi_out = lay.phi[k, cols], lay.phi[k + 1, cols]
        R_i = end["R"][go]
        l1p, wr_out, w_out, force, ok = relaxed_interface_stretch(
            model, ye[0], ye[7], wr_in, ye[1], phi_in, n_in, phi_out, n_out
        )
        # no root: pull-in where the far side would wrinkle (or the near one is), else past the taut instability
        res["status"][cols[~ok]] = np.where(wr_in[~ok] | wr_out[~ok], PULL_IN, LOST_ELLIPTICITY)
        res["region"][cols[~ok]] = k + 1
        T1_out, _, _ = relaxed_meridional_tension(model, l1p, ye[1], phi_out, wr_out, width_guess=w_out)
        for side, (l1, N, wr) in enumerate(((ye[0], force, wr_in), (l1p, n_out * T1_out, wr_out))):
            res["edges"][cols, k, side] = np.stack([R_i, ye[1] * R_i, ye[6], ye[2], N], axis=-1)
            res["edge_modes"][cols, k, side] = wr.astype(int)
            del l1
        keep = np.flatnonzero(ok)
        cols = cols[keep]
        ye = ye[:, keep]
        y_next = np.vstack([ye[:7], p_t[cols] / n_out[keep], phi_out[keep]])
        y_next[0] = l1p[keep]
        y_next[5] = ye[5] * n_in[keep] / n_out[keep]  # the Ψ̂ row holds Ψ̂/(2π n) of the current region
        # the far side's first node: its relaxed tensions (taut: both; wrinkled: the meridional one)
        T1s, T2s, _, _, _, Es, _ = (
            np.asarray(a) * np.ones(keep.size)
            for a in model.tensions(y_next[0], np.where(wr_out[keep], w_out[keep], ye[1]), phi_out[keep])
        )
        minT_start = np.where(wr_out[keep], T1s, np.minimum(T1s, T2s))
        res["minT"][cols] = np.minimum(res["minT"][cols], n_out[keep] * minT_start)
        span = s[cols] * ((LAST_REGION_REACH if k + 1 == K - 1 else lay.f[k + 1]) - lay.f[k])
        start = _blank_start(m, 9, atol0.copy())
        start["R"][cols] = R_i[keep]
        start["y"][:, cols] = y_next
        start["h"][cols] = np.minimum(0.05 * s[cols], 0.25 * span)
        start["min_T"][cols] = minT_start
        start["max_E"][cols] = np.abs(Es)
        start["mode"][cols] = np.where(wr_out[keep], WRINKLED_MODE, TAUT)
        live = cols
    res["intervals"] = intervals
    return res


#: the first step after a stop of :func:`_record_stops`, as a fraction of the interface scale (the step control
#: takes it from there)
RESTART_STEP = 0.01


def _series_stops(model, lay, l0, p_t, s, stops, R0):
    """The recorded rows of :func:`_relaxed_pass` with ``stops``, NaN but below the pole's series radius ``R0``
    (there the series itself, as the taut profile has it): ``(rows, radii)``."""
    m = l0.size
    rows = np.full((stops.size, 7, m), np.nan)
    radii = np.outer(stops, s)
    for i in range(stops.size - 1):
        cols = np.flatnonzero(radii[i] < R0)
        if cols.size:
            vals = model.series_start(l0[cols], p_t[cols] / lay.n[0, cols], lay.phi[0, cols], radii[i, cols])[:7]
            rows[i][:, cols] = np.vstack([np.broadcast_to(np.asarray(v, dtype=float), (cols.size,)) for v in vals])
    return rows, radii


def _record_stops(model, settings, l0, lay, k, s, sub, stops, res, live) -> dict:
    """Shoot region ``k`` of the states ``live`` (from their start ``sub``) through the ``stops`` strictly inside it,
    recording the rows there (``res["rows"]``, ``res["radii"]``), and return the start at the last one (``sub``
    itself without any). A stop the shooting does not reach (a failure, or the clamp met early) raises
    :class:`~coexist.errors.SolverError` naming the state: the state without stops reached the region's end."""
    from .errors import SolverError

    inner = lay.f[k - 1] if k else 0.0
    for i in np.flatnonzero((stops > inner) & (stops < lay.f[k])):
        target = stops[i] * s
        go = np.flatnonzero(target > sub["R"])  # not inside the pole's series radius
        if go.size == 0:
            continue
        part = {key: (v[..., go] if isinstance(v, np.ndarray) else v) for key, v in sub.items()}
        shots = shoot_relaxed(model, settings, l0[go], lay.phi[k, live[go]], start=part, stop_radius=target[go])
        missed = np.flatnonzero(shots.status != STOPPED)
        if missed.size:
            j = int(go[missed[0]])
            raise SolverError(
                f"profile at pole stretch {l0[j]:.6g}, Φ̂ = {lay.phi[k, live[j]] * lay.n[k, live[j]]:.6g}: the "
                f"re-integration of the wrinkled patterned state stopped before R̂ = {stops[i]:.6g} "
                f"({reason_text(int(shots.status[missed[0]])) if shots.status[missed[0]] != OK else 'at the clamp'})"
            )
        end = shots.end
        assert end is not None
        res["rows"][i][:, live[go]] = end["y"][:7]
        res["radii"][i, live[go]] = end["R"]
        sub = {key: (v.copy() if isinstance(v, np.ndarray) else v) for key, v in sub.items()}
        sub["R"][go] = end["R"]
        sub["y"][:, go] = np.vstack([end["y"][:7], end["y"][8:10]])  # without the width (a wrinkled start's own)
        sub["h"][go] = RESTART_STEP * s[go]
        sub["min_T"][go] = np.minimum(sub["min_T"][go], shots.min_tension)
        sub["max_E"][go] = np.maximum(sub["max_E"][go], shots.max_field)
        sub["mode"] = np.asarray(sub["mode"], dtype=int).copy()
        sub["mode"][go] = end["mode"]
    return sub


def relaxed_profile_rows(model: MembraneModel, pattern: ZonePattern, states: PatternedStates, stops, settings):
    """The meridian of relaxed patterned states (:func:`solve_patterned_relaxed`) at the reference fractions
    ``stops``, shot again at their converged interface scale with stops there (:func:`_relaxed_pass`).

    Parameters
    ----------
    model : MembraneModel
        One layer of the membrane (tension-field).
    pattern : ZonePattern
        The regions (more than one).
    states : PatternedStates
        Converged states of :func:`solve_patterned_relaxed` (all valid).
    stops : ndarray
        Increasing fractions of the clamp radius, 0 and 1 and every interface fraction among them.
    settings : SolverSettings
        The tolerances the states were solved with.

    Returns
    -------
    dict
        :func:`_relaxed_pass`'s result with ``rows`` and ``radii`` (trial scaling), and ``rtol`` per state.
    """
    model = _tension_field(model)
    l0 = np.asarray(states.pole_stretch, dtype=float)
    phi = np.asarray(states.phi_hat, dtype=float)
    lay = _layout(pattern, phi)
    p_t, rtol = _trial(model, settings, lay, l0)
    pole = _pole_start(model, settings, lay, l0, p_t)
    # the interface scale: the first interface's R̂ (the solver's s f0 / R*) times R*, over f0
    s = states.interfaces[:, 0, 0, 0] * states.clamp_radius / lay.f[0]
    with np.errstate(all="ignore"):
        res = _relaxed_pass(model, settings, lay, l0, p_t, np.log(s), pole, stops=np.asarray(stops, dtype=float))
    res["rtol"] = rtol
    return res


# --- the derivative pass -------------------------------------------------------------------------------------


def _relaxed_slopes(model, l1, rho, phi, wrinkled):
    """The partial derivatives of one layer's relaxed meridional tension ``T̂1ʳ(λ1, ρ; φ)``:
    ``(∂/∂λ1, ∂/∂ρ, ∂/∂φ)`` and the material hoop stretch.

    Taut: ``(T̂11, T̂12, ∂T̂1/∂φ)`` at ``(λ1, ρ)``. Hoop-wrinkled, ``T̂1ʷ(λ1; φ) = T̂1(λ1, w; φ)`` with
    ``T̂2(λ1, w; φ) = 0``: ``(K, 0, ∂T̂1/∂φ + T̂12 dw/dφ)`` at ``(λ1, w)``, ``K = T̂11 − T̂12²/T̂22``,
    ``dw/dφ = −(∂T̂2/∂φ)/T̂22`` (:meth:`~coexist.model.MembraneModel.wrinkle_aux`)."""
    from .patterned import _dT1_dphi

    l1, rho, phi = np.broadcast_arrays(*(np.asarray(a, dtype=float) for a in (l1, rho, phi)))
    wrinkled = np.broadcast_to(np.asarray(wrinkled, dtype=bool), l1.shape)
    w = rho.copy()
    if wrinkled.any():
        w[wrinkled] = natural_width(model, l1[wrinkled], phi[wrinkled], guess=rho[wrinkled])
    _, _, T11, T12, _, _, T22 = (np.asarray(a, dtype=float) * np.ones(l1.shape) for a in model.tensions(l1, w, phi))
    c = _dT1_dphi(model, l1, w, phi)
    a, b = T11.copy(), T12.copy()
    if wrinkled.any():
        dw_dphi = np.asarray(model.wrinkle_aux(l1[wrinkled], w[wrinkled], phi[wrinkled])[3]) * np.ones(
            w[wrinkled].shape
        )
        a[wrinkled] = T11[wrinkled] - T12[wrinkled] ** 2 / T22[wrinkled]
        b[wrinkled] = 0.0
        c[wrinkled] = c[wrinkled] + T12[wrinkled] * dw_dphi
    return a, b, c, w


def _rhs_of_mode(model, R, y, wrinkled, w):
    """The first five rows ``(λ1, λ2 or ρ, θ, V̂/π, Q̂/2π)'`` of the relaxed right-hand side at the rows ``y``
    (``p̂t`` and ``φ`` in rows ``−2, −1``): taut, or hoop-wrinkled at the natural width ``w``."""
    out = np.empty((5, R.size))
    taut = ~wrinkled
    if taut.any():
        f = model.rhs(R[taut], y[0, taut], y[1, taut], y[2, taut], y[-2, taut], y[-1, taut])
        out[:, taut] = np.vstack([np.asarray(v, dtype=float) * np.ones(taut.sum()) for v in f[:5]])
    if wrinkled.any():
        sel = wrinkled
        f = model.wrinkled_rhs(R[sel], y[0, sel], y[1, sel], y[2, sel], y[-2, sel], y[-1, sel], w[sel])
        out[:, sel] = np.vstack([np.asarray(v, dtype=float) * np.ones(sel.sum()) for v in f[:5]])
    return out


def _relaxed_derivative_pass(model, settings, lay, l0, p_t, sigma, pole):
    """The exact derivatives of converged relaxed states (interfaces at ``s fk``, ``s = e^σ``, ``ln R*(s) = σ``).

    One more relaxed shooting at the converged ``σ`` with the variational equations
    (:func:`coexist.wrinkling.shoot_relaxed` with ``derivatives=True``: taut and hoop-wrinkled segments, the
    saltation at every switch inside a region), each state twice: its rows 7–11 carry
    ``Z = ∂(λ1, λ2 or ρ, θ, V̂/π, Q̂/2π)/∂a`` at fixed ``R̂`` for ``a = s`` (zero in the pole region) or ``a = λ0``
    (from the pole's series), rows 12–16 carry ``U = nk ∂(…)/∂Φ̂`` (``U' = (∂f/∂y)U + ∂f/∂φk``; in a region
    without electrode its charge row is held at its value from the region's start, as in
    :func:`coexist.patterned._pass`). Across an interface at ``R̂i = s fk`` (``ρ, θ``, the quadratures
    continuous; ``λ1⁺ = g(λ1⁻, ρ; Φ̂)`` from ``n⁻T̂1ʳ⁻ = n⁺T̂1ʳ⁺`` on the sides' modes, :func:`_relaxed_slopes`
    giving ``T̂1ʳ``'s partials ``(aλ, aρ, aφ)``):

        g1 = n⁻aλ⁻/(n⁺aλ⁺),  g2 = (n⁻aρ⁻ − n⁺aρ⁺)/(n⁺aλ⁺),  gΦ = (e⁻aφ⁻ − e⁺aφ⁺)/(n⁺aλ⁺),

    ``Z⁺ = D(Z⁻ + f⁻fk) − f⁺fk`` for ``a = s`` (the interface moves with ``s``; ``f∓`` the relaxed right-hand
    sides of the two sides' modes), ``Z⁺ = D Z⁻`` for ``λ0``, ``Z⁺ = D Z⁻ + gΦ e_λ1`` for ``Φ̂`` (``D``: ``g1, g2``
    on the ``λ1`` row, the identity on the others). At the clamp ``∂R*/∂a = −Z_ρ/ρ'`` and ``∂w/∂a = Z_w + w'
    ∂R*/∂a`` (:func:`coexist.wrinkling.shoot_relaxed`); the scale follows ``(λ0, Φ̂)`` by the implicit function
    theorem on ``G = ln R* − σ = 0``: ``dσ/da = −(∂R*/∂a/R*)/((s/R*) ∂R*/∂s − 1)`` (as
    :func:`coexist.patterned._derivative_pass`).

    Returns
    -------
    dict
        ``R``, ``dR_dl0, dV_dl0, dQ_dl0, dR_dphi, dV_dphi, dQ_dphi`` (trial membrane, with the factors π, 2π),
        ``status`` (0 where both shots landed with the same modes at the interfaces as each other) and ``steps``.
    """
    K = lay.f.size
    m = l0.size
    mm = 2 * m
    two = np.concatenate([np.arange(m), np.arange(m)])
    lam = np.arange(mm) >= m  # columns carrying λ0 in rows 7–11 (the others s); all carry Φ̂ in rows 12–16
    L = _sub_layout(lay, two)
    s = np.exp(sigma)[two]
    pt = p_t[two]  # the trial pressure of each column
    y0, atol0, series, T0, E0, *series_radius = _take_pole(pole, two)
    R0 = np.broadcast_to(series_radius[0] if series_radius else settings.series_radius, (mm,)).astype(float)
    e1 = 1.0 if lay.electrode[0] else 0.0
    Y = np.vstack([y0[:7], np.zeros((10, mm)), y0[7:9]])
    for i in range(5):
        Y[7 + i] = np.where(lam, series[7 + i], 0.0)
        Y[12 + i] = e1 * series[12 + i]
    atol = np.vstack([atol0[:7], np.full((10, mm), np.inf), atol0[7:9]])
    start = {
        "R": R0.copy(),
        "y": Y,
        "h": R0.copy(),
        "min_T": T0.copy(),
        "max_E": E0.copy(),
        "atol": atol,
        "mode": np.full(mm, TAUT),
    }
    status = np.zeros(mm, dtype=int)
    steps = np.zeros(mm, dtype=int)
    modes = np.full((mm, max(K - 1, 1), 2), -1)
    u_q = np.zeros(mm)  # U's charge row through a region without electrode
    res = {k: np.full(mm, np.nan) for k in ("R", "dR_a", "dV_a", "dQ_a", "dR_phi", "dV_phi", "dQ_phi")}
    fQ = QUADRATURE_FACTORS[1]
    live = np.arange(mm)
    for k in range(K):
        if live.size == 0:
            break
        last = k == K - 1
        stop = s[live] * (min(LAST_REGION_REACH, settings.max_radius_factor) if last else lay.f[k])
        sub = {key: (v[..., live] if isinstance(v, np.ndarray) else v) for key, v in start.items()}
        shots = shoot_relaxed(model, settings, l0[two][live], L.phi[k, live], True, start=sub, stop_radius=stop)
        steps[live] += shots.steps
        st = shots.status
        n_k = L.n[k, live]
        if last:
            landed = st == OK
            status[live[~landed]] = np.where(st[~landed] == STOPPED, NO_CLAMP, st[~landed])
            i, o = live[landed], shots.out
            res["R"][i] = o["R"][landed]
            res["dR_a"][i], res["dV_a"][i], res["dQ_a"][i] = (o[f"d{q}_dl0"][landed] for q in "RVQ")
            dQ_phi = o["dQ_dphi"][landed] if lay.electrode[k] else fQ * u_q[i]  # Q̂' = 0 without electrode
            res["dR_phi"][i] = o["dR_dphi"][landed] / n_k[landed]
            res["dV_phi"][i] = o["dV_dphi"][landed] / n_k[landed]
            res["dQ_phi"][i] = dQ_phi / n_k[landed]
            break
        end = shots.end
        assert end is not None
        status[live[st != STOPPED]] = np.where(st[st != STOPPED] == OK, NOT_FINITE, st[st != STOPPED])
        go = np.flatnonzero(st == STOPPED)
        cols = live[go]
        ye = end["y"][:, go]  # rows: state (7), Z (5), U (5), width, p̂t/nk, φk
        wr_in = end["mode"][go] == WRINKLED_MODE
        n_in, n_out = L.n[k, cols], L.n[k + 1, cols]
        phi_in, phi_out = L.phi[k, cols], L.phi[k + 1, cols]
        R_i = end["R"][go]
        l1p, wr_out, w_out, _, ok = relaxed_interface_stretch(
            model, ye[0], ye[17], wr_in, ye[1], phi_in, n_in, phi_out, n_out
        )
        status[cols[~ok]] = np.where(wr_in[~ok] | wr_out[~ok], PULL_IN, LOST_ELLIPTICITY)
        modes[cols, k, 0], modes[cols, k, 1] = wr_in, wr_out
        keep = np.flatnonzero(ok)
        cols, ye, R_i = cols[keep], ye[:, keep], R_i[keep]
        wr_in, wr_out, l1p, w_out = wr_in[keep], wr_out[keep], l1p[keep], w_out[keep]
        n_in, n_out, phi_in, phi_out = n_in[keep], n_out[keep], phi_in[keep], phi_out[keep]
        a_in, b_in, c_in, w_in = _relaxed_slopes(model, ye[0], ye[1], phi_in, wr_in)
        a_out, b_out, c_out, _ = _relaxed_slopes(model, l1p, ye[1], phi_out, wr_out)
        e_in = 1.0 if lay.electrode[k] else 0.0
        e_out = 1.0 if lay.electrode[k + 1] else 0.0
        g1 = n_in * a_in / (n_out * a_out)
        g2 = (n_in * b_in - n_out * b_out) / (n_out * a_out)
        g_phi = (e_in * c_in - e_out * c_out) / (n_out * a_out)
        y_next = np.vstack([ye[:17], pt[cols] / n_out, phi_out])
        y_next[0] = l1p
        y_next[5] = ye[5] * n_in / n_out  # the Ψ̂ row holds Ψ̂/(2π n) of the current region
        f_in = _rhs_of_mode(model, R_i, np.vstack([ye[:7], ye[18:20]]), wr_in, w_in)
        f_out = _rhs_of_mode(model, R_i, np.vstack([y_next[:7], y_next[17:19]]), wr_out, w_out)
        fk = np.where(lam[cols], 0.0, lay.f[k])  # the interface moves with s, not with λ0
        Z = ye[7:12] + f_in * fk
        y_next[7] = g1 * Z[0] + g2 * Z[1] - f_out[0] * fk
        for r in range(1, 5):
            y_next[7 + r] = Z[r] - f_out[r] * fk
        U = ye[12:17].copy()
        if not lay.electrode[k]:
            U[4] = u_q[cols]
        Zp = U / n_in
        Zp[0] = g1 * Zp[0] + g2 * Zp[1] + g_phi
        y_next[12:17] = n_out * Zp
        if not lay.electrode[k + 1]:
            u_q[cols] = y_next[16]
        span = s[cols] * ((LAST_REGION_REACH if k + 1 == K - 1 else lay.f[k + 1]) - lay.f[k])
        start = _blank_start(mm, 19, atol)
        start["R"][cols] = R_i
        start["y"][:, cols] = y_next
        start["h"][cols] = np.minimum(0.05 * s[cols], 0.25 * span)
        start["min_T"][cols] = 1.0  # not used: only the derivatives are kept
        start["max_E"][cols] = 0.0
        start["mode"][cols] = np.where(wr_out, WRINKLED_MODE, TAUT)
        live = cols
    R, Rl = res["R"][:m], res["R"][m:]
    same = (np.abs(Rl - R) <= 1e-12 * np.abs(R)) & np.all(modes[:m] == modes[m:], axis=(1, 2))
    both = (status[:m] == 0) & (status[m:] == 0)
    st_out = np.where(both & same, 0, np.maximum(status[:m], status[m:]))
    st_out[(st_out == 0) & ~(both & same)] = NOT_FINITE
    sig = np.exp(sigma)
    Rs, Vs, Qs = res["dR_a"][:m], res["dV_a"][:m], res["dQ_a"][:m]
    slope = sig / R * Rs - 1.0
    out = {"R": R, "status": st_out, "steps": steps[:m] + steps[m:], "slope": slope}
    for a, (Ra, Va, Qa) in (
        ("l0", (res["dR_a"][m:], res["dV_a"][m:], res["dQ_a"][m:])),
        ("phi", (res["dR_phi"][:m], res["dV_phi"][:m], res["dQ_phi"][:m])),
    ):
        ds = -sig * (Ra / R) / slope
        out[f"dsigma_d{a}"] = ds / sig  # (at fixed p̂t: a continuation's start, coexist.patterned.ScaleStarts)
        out[f"dR_d{a}"] = Ra + Rs * ds
        out[f"dV_d{a}"] = Va + Vs * ds
        out[f"dQ_d{a}"] = Qa + Qs * ds
    return out


# --- the states ----------------------------------------------------------------------------------------------


def describe_wrinkles(pattern: ZonePattern, intervals) -> str:
    """Where a relaxed patterned state is wrinkled, in words: each interval ``R̂start ≤ R/A ≤ R̂end`` with the
    region(s) it lies in and, where it ends at an electrode edge, on which side of the edge.

    Parameters
    ----------
    pattern : ZonePattern
    intervals : list of (float, float)
        The state's ``wrinkled_radii`` (unit membrane).

    Returns
    -------
    str
        ``"taut"`` for no interval.
    """
    if not intervals:
        return "taut"
    edges = [r.outer for r in pattern.regions[:-1]]
    parts = []
    for a, b in intervals:
        mid = 0.5 * (a + b)
        k = next(i for i, r in enumerate(pattern.regions) if mid <= r.outer or i == len(pattern.regions) - 1)
        reg = pattern.regions[k]
        text = f"wrinkled for {a:.6g} ≤ R/A ≤ {b:.6g} in region {k + 1} ({reg.describe()})"
        near = [e for e in edges if min(abs(a - e), abs(b - e)) <= 1e-9]
        for e in near:
            text += f", on its side of the edge at R/A = {e:g}"
        if abs(b - 1.0) <= 1e-9:
            text += ", at the clamp"
        parts.append(text)
    return "; ".join(parts)


def _tension_field(model: MembraneModel) -> MembraneModel:
    validation.membrane_model(model)
    if isinstance(model, PatternedModel):
        model = model.uniform
    if not model.tension_field:
        raise SceneError(
            'relaxed patterned states need a tension-field membrane (wrinkling = "tension-field"), not '
            f"{model.wrinkling!r}",
            "wrinkling",
        )
    return model


def solve_patterned_relaxed(
    model: MembraneModel,
    pattern: ZonePattern,
    pole_stretch,
    phi_hat=0.0,
    settings: SolverSettings | None = None,
    scale_guess=None,
    derivatives: bool = False,
    starts=None,
) -> PatternedStates:
    """The relaxed (tension-field) states of a patterned zone: taut where both tensions are positive, hoop-wrinkled
    where the taut state would need a negative hoop tension.

    Region ``k`` obeys the relaxed one-layer equations of docs/physics.md section 10 at ``p̂t/nk`` and
    ``φk = ek Φ̂/nk``, switching taut ↔ hoop-wrinkled inside it (:func:`coexist.wrinkling.shoot_relaxed`); at an
    interface ``ρ, θ`` and the quadratures are continuous and ``n⁻T̂1ʳ⁻ = n⁺T̂1ʳ⁺``
    (:func:`relaxed_interface_stretch`). The interface scale ``s`` solves ``G(σ) = ln R*(e^σ) − σ = 0``
    (``σ = ln s``) per state by secant steps (the first with the uniform zone's slope ``−1``), kept inside the
    bracket the iterates build (bisection where a step leaves it; an iterate whose trajectory meets the clamp
    stretch before the last region bounds ``s`` above and proposes that radius, one that does not reach the
    clamp within ``8s`` bounds it below). It stops at ``|G| ≤ rtol``. No iterate goes below the scale whose first
    interface lies :data:`~coexist.patterned.SCALE_FLOOR` series radii from the pole (where the zone is flat): a
    state whose iterates meet the clamp stretch too near down to it is ``BELOW_FLAT`` (its pole stretch is below
    the flat zone's), as in :func:`coexist.patterned.solve_patterned_states`. The unit membrane has ``p̂ = p̂t R*``,
    ``V̂ = V̂t/R*³``, ``Q̂ = Q̂t/R*²`` (the electrode's charge), ``Ψ̂ = Σ nk ∫ W_rel dA``, ``wrinkled_radii`` the
    wrinkled intervals over ``R*`` (a band that crosses an interface is one interval).

    Parameters
    ----------
    model : MembraneModel
        One layer of the membrane, with ``wrinkling="tension-field"`` (or a :class:`~coexist.patterned.
        PatternedModel` of such a membrane; the pattern used is ``pattern``).
    pattern : ZonePattern
        The regions.
    pole_stretch, phi_hat, settings
        As for :func:`coexist.patterned.solve_patterned_states`.
    scale_guess : array_like, optional
        Starting ``ln s`` per state; default that of the pole region's uniform zone.
    derivatives : bool
        Also return the exact first derivatives of ``p̂, V̂, Q̂`` to ``λ0`` and ``Φ̂``
        (:class:`~coexist.shooting.StateDerivatives`; ``Ψ̂``'s follow from ``dΨ̂ = p̂ dV̂ − Q̂ dΦ̂``): one more
        relaxed shooting at the converged interface scale with the variational equations carried through every
        region's taut and wrinkled segments (the saltation at every switch), mapped across every relaxed
        interface, and the scale's own dependence from the implicit function theorem on ``G = 0``
        (:func:`_relaxed_derivative_pass`). About 1.2–1.35 times the cost of the states alone (measured CPU time,
        20 wrinkled states of an inner circle and of a ring).
    starts : coexist.patterned.ScaleStarts, optional
        A continuation's store of converged states (without ``scale_guess``): a state near a kept relaxed one
        starts from its scale (to first order) with its exact slope as the secant's first; the converged states
        are kept. A start only: every state is the one whose own residual is within the tolerance.

    Returns
    -------
    PatternedStates
        With ``wrinkled_radii`` and ``wrinkled_stiffness`` (``K/T̂11`` at the outer ends of the bands, as for a
        uniform zone; ``inf`` when taut); ``min_tension`` is 0 for a wrinkled state; ``interfaces`` holds the
        relaxed force ``n T̂1ʳ`` on both sides; ``derivatives`` when asked for (NaN where a state failed).
        Failed states carry their status and ``failure_detail``.

    Raises
    ------
    SceneError
        For a membrane that refuses wrinkling, and as :func:`~coexist.patterned.solve_patterned_states`.
    """
    model = _tension_field(model)
    validation.instance(pattern, ZonePattern, "pattern", "a ZonePattern (e.g. ZonePattern.inner_circle(0.5))")
    settings, l0, phi = checked_state_inputs(model, pole_stretch, phi_hat, settings)
    if len(pattern.regions) == 1:  # a uniform zone: solve_states of the tension-field membrane, scaled
        return _one_region(model, pattern, l0, phi, settings, derivatives)
    m = l0.size
    lay = _layout(pattern, phi)
    status = np.zeros(m, dtype=int)
    with np.errstate(all="ignore"):
        T0, alpha, _, _, _ = (np.asarray(x, dtype=float) * np.ones(m) for x in model.pole(l0, lay.phi[0]))
        margin0 = np.asarray(model.tensions(l0, l0, lay.phi[0])[4]) * np.ones(m)
    status[l0 - model.prestretch < FLAT_LIMIT * model.prestretch] = BELOW_RESOLUTION
    status[(status == OK) & (margin0 <= LOCKING_LIMIT)] = LOCKED
    status[(status == OK) & ((T0 <= 0) | ~np.isfinite(T0))] = WRINKLED_AT_POLE
    status[(status == OK) & (alpha <= 0)] = LOST_ELLIPTICITY
    detail: list = [None if s == OK else f"{reason_text(s)} (at the pole)" for s in status]
    live = np.flatnonzero(status == OK)
    K = len(pattern.regions)
    keys = ("R", "p", "V", "Q", "Psi", "z", "minT", "maxE", "failR", "stiffness", "sigma")
    out = {k: np.full(m, np.nan) for k in keys}
    edges = np.full((m, K - 1, 2, 5), np.nan)
    radii: list = [[] for _ in range(m)]
    steps = np.zeros(m, dtype=int)
    warm_started = np.zeros(m, dtype=bool)
    if live.size:
        slope0 = None
        if scale_guess is not None:
            g = validation.real_array(scale_guess, "scale_guess")
            sigma0 = np.broadcast_to(g, (m,)).astype(float).copy()
        else:
            sigma0 = np.full(m, np.nan)
            warm = None if starts is None else starts.start(model, pattern, l0, phi, "relaxed")
            if warm is not None:  # the nearest kept relaxed state: its scale to first order, its exact slope
                sigma0, slope0 = warm[0], warm[1]["slope"]
            cold = ~np.isfinite(sigma0)
            warm_started = ~cold
            if cold.all():
                sigma0 = _pole_region_scale(model, settings, lay, l0)
            elif cold.any():
                sigma0[cold] = _pole_region_scale(model, settings, _sub_layout(lay, cold), l0[cold])
        with np.errstate(all="ignore"):
            _secant(model, pattern, settings, lay, l0, sigma0, live, status, out, steps, detail, edges, radii, slope0)
    exact_slope = np.full(m, np.nan)
    dsig = {"l0": np.full(m, np.nan), "phi": np.full(m, np.nan)}
    d_out = None
    if derivatives:
        d_out = {k: np.full(m, np.nan) for k in ("dR_dl0", "dV_dl0", "dQ_dl0", "dR_dphi", "dV_dphi", "dQ_dphi")}
        ok = np.flatnonzero(status == OK)
        if ok.size:
            sub = _sub_layout(lay, ok)
            p_t, _ = _trial(model, settings, sub, l0[ok])
            with np.errstate(all="ignore"):
                pole = _pole_start(model, settings, sub, l0[ok], p_t)
                dp = _relaxed_derivative_pass(model, settings, sub, l0[ok], p_t, out["sigma"][ok], pole)
            steps[ok] += dp["steps"]
            for k in d_out:
                d_out[k][ok] = dp[k]
            if starts is not None:  # (as coexist.patterned._solve keeps them)
                exact_slope[ok] = dp["slope"]
                for a, v in _trial_log_slopes(model, settings, pattern, l0[ok], phi[ok]).items():
                    dsig[a][ok] = dp[f"dsigma_d{a}"] - v
            # the derivative pass shoots the converged state again: its clamp radius must be the state's (to the
            # integration tolerance), or the derivatives belong to another state
            other = np.abs(dp["R"] - out["R"][ok]) > 100 * settings.rtol * np.abs(out["R"][ok])
            lost = ok[(dp["status"] != 0) | ~np.all(np.isfinite([dp[k] for k in d_out]), axis=0) | other]
            for i in lost:  # not expected: the same relaxed shooting as the converged state's
                status[i] = NOT_FINITE
                detail[i] = (
                    f"{reason_text(NOT_FINITE)} (the relaxed shooting with the variational equations does not "
                    "reproduce the converged state)"
                )
    bad = status != OK
    R = out["R"]
    wrinkled = np.array([bool(r) for r in radii])
    states = MembraneStates(
        pole_stretch=l0,
        phi_hat=phi,
        p_hat=np.where(bad, np.nan, out["p"] * R),
        v_hat=np.where(bad, np.nan, out["V"] / R**3),
        q_hat=np.where(bad, np.nan, out["Q"] / R**2),
        psi_hat=np.where(bad, np.nan, out["Psi"] / R**2),
        apex_height=np.where(bad, np.nan, out["z"] / R),
        max_field=np.where(bad, np.nan, out["maxE"]),
        min_tension=np.where(bad, np.nan, np.where(wrinkled, 0.0, out["minT"])),
        clamp_radius=np.where(bad, np.nan, R),
        status=status,
        fail_radius=np.where(bad, out["failR"], np.inf),
        steps=steps,
        wrinkled_radii=[[] if b else r for r, b in zip(radii, bad)],
        wrinkled_stiffness=np.where(bad, np.nan, out["stiffness"]),
    )
    if d_out is not None:
        states.derivatives = clamped_derivatives(d_out, out["p"], R, states.v_hat, states.q_hat, bad)
    edges[bad] = np.nan
    if starts is not None:
        good = np.flatnonzero(~bad & np.isfinite(out["sigma"]))
        values = {"l0": l0[good], "phi": phi[good], "sigma": out["sigma"][good], "slope": exact_slope[good]}
        values |= {"dsig_dl0": dsig["l0"][good], "dsig_dphi": dsig["phi"][good], "jump": {}}
        starts.keep(model, pattern, values, "relaxed")
        # a warm-started state that failed is solved once more from the cold start (a start must never lose a
        # state), unless a band pulled in (measured on a ring: 68 of 68 the same cold, and their retries cost a
        # third of the relaxed shooting)
        again = warm_started & bad & (status != PULL_IN)
        if again.any():
            retry = solve_patterned_relaxed(model, pattern, l0[again], phi[again], settings, derivatives=derivatives)
            return _merge(l0, ~again, _take_patterned(_patterned(states, detail, edges), ~again), retry)
    return _patterned(states, detail, edges)


def _one_region(model, pattern, l0, phi, settings, derivatives=False) -> PatternedStates:
    """A one-region pattern: :func:`coexist.patterned._uniform` (``solve_states`` of the tension-field membrane at
    ``Φ̂/n``, which relaxes its wrinkled states, scaled to the stack), with the ``wrinkled_stiffness`` it does not
    carry over (the wrinkled states shot once more: a uniform zone's ``K/T̂11`` needs no scaling, it is a ratio)."""
    st = _uniform(model, pattern, l0, phi, settings, derivatives)
    stiffness = np.where(st.ok, np.inf, np.nan)
    wr = np.flatnonzero(st.ok & np.array([bool(r) for r in (st.wrinkled_radii or [[]] * l0.size)]))
    if wr.size:
        region = pattern.regions[0]
        per_layer = phi[wr] / region.layers if region.electrode else np.zeros(wr.size)
        again = solve_states(model, l0[wr], per_layer, settings)
        if again.wrinkled_stiffness is not None:
            stiffness[wr] = again.wrinkled_stiffness
    st.wrinkled_stiffness = stiffness
    return st


def _secant(
    model, pattern, settings, lay_all, l0_all, sigma0, live, status, out, steps, detail, edges_out, radii, slope0=None
):
    """The safeguarded secant iteration on ``σ = ln s`` for the live states; fills the outputs in place.
    ``slope0`` (per state, NaN where none): the first step's slope ``dG/dσ`` (a kept neighbour's, exact), instead of
    ``−1`` (the uniform zone's); the secant's own slope replaces it from the second step on.

    No iterate goes below the interface scale whose first interface lies :data:`~coexist.patterned.SCALE_FLOOR`
    series radii from the pole (its pole region would end inside the series radius, integrated backwards towards the
    singular pole), as in :func:`coexist.patterned._newton`: a state whose iterates meet the clamp stretch too near
    (``G < 0``, or before the last region) down to that scale, where the zone is flat, has a pole stretch below the
    flat zone's, ``BELOW_FLAT``; one left open after :data:`~coexist.patterned.MAX_SCALE_ITERATIONS` with ``G < 0``
    at every iterate takes one trial there to know. Measured on a Gent 97 inner circle (``f = 0.3``, three passive
    layers, prestretch 1.2, flat pole stretch 1.4151 at ``Φ̂ = 0.1``): its states below the flat one had gone on to
    interface scales ~1e-5 (the pole region integrated backwards) and "solver_budget" after ~24000 steps, or crept
    down for all 30 iterations to "not_finite"."""
    m = live.size
    l0 = l0_all[live]
    lay = _sub_layout(lay_all, live)
    p_t, rtol = _trial(model, settings, lay, l0)
    tol = np.maximum(rtol, 4e-16)
    pole = _pole_start(model, settings, lay, l0, p_t)
    # the smallest scale tried (SCALE_FLOOR): the pole region, integrated from the series radius pole[5] to s f1, ends
    # SCALE_FLOOR series radii from the pole; a state whose iterates reach the clamp stretch too near down to it has
    # no equilibrium
    floor = np.log(SCALE_FLOOR * pole[5] / lay.f[0])
    floor_tried = np.zeros(m, dtype=bool)
    floor_reach = np.full(m, np.nan)  # where the trial at the floor met the clamp stretch, over s (< 1: too near)
    sigma = sigma0[live].copy()
    lo, hi = np.full(m, -np.inf), np.full(m, np.inf)
    prev_sigma, prev_G = np.full(m, np.nan), np.full(m, np.nan)
    good_sigma = np.full(m, np.nan)
    failures = np.zeros(m, dtype=int)
    last_code = np.zeros(m, dtype=int)
    open_ = np.ones(m, dtype=bool)
    final = np.zeros(m, dtype=int)
    first_slope = np.full(m, -1.0)
    if slope0 is not None:
        s0 = np.asarray(slope0, dtype=float)[live]
        first_slope = np.where(np.isfinite(s0) & (s0 < SLOPE_CEILING), s0, -1.0)
    for _ in range(MAX_SCALE_ITERATIONS):
        idx = _at_floor(
            np.flatnonzero(open_), sigma, (floor, floor_tried, floor_reach), last_code, final, detail, live, open_
        )
        if idx.size == 0:
            break
        sub = _Layout(n=lay.n[:, idx], phi=lay.phi[:, idx], f=lay.f, electrode=lay.electrode)
        res = _relaxed_pass(model, settings, sub, l0[idx], p_t[idx], sigma[idx], _take_pole(pole, idx))
        steps[live[idx]] += res["steps"]
        okp = res["status"] == 0
        G = np.where(okp, np.log(res["R"]) - sigma[idx], np.nan)
        at = np.flatnonzero(sigma[idx] == floor[idx])
        if at.size:  # the trials at the floor: where the clamp stretch was met, over its scale
            met = (okp[at] | (res["status"][at] == _EARLY_CLAMP)) & np.isfinite(res["R"][at])
            near = np.where(met, res["R"][at], np.nan) / np.exp(sigma[idx[at]])
            floor_reach[idx[at]] = np.where(near < 1.0, near, np.nan)
        conv = okp & (np.abs(G) <= tol[idx])
        for j in np.flatnonzero(conv):
            i, gi = idx[j], live[idx[j]]
            Rs = res["R"][j]
            out["R"][gi] = Rs
            for key in ("V", "Q", "Psi", "z", "minT", "maxE", "stiffness"):
                out[key][gi] = res[key][j]
            out["p"][gi] = p_t[i]
            out["sigma"][gi] = sigma[i]
            radii[gi] = [(a / Rs, b / Rs) for a, b in res["intervals"][j]]
            edge = res["edges"][j].copy()
            edge[..., :3] /= Rs
            edges_out[gi] = edge
            open_[i] = False
        for j in np.flatnonzero(~conv):
            i = idx[j]
            code = int(res["status"][j])
            if okp[j]:
                good_sigma[i] = sigma[i]
                if G[j] > 0:
                    lo[i] = sigma[i]
                else:
                    hi[i] = sigma[i]
                slope = first_slope[i]
                if np.isfinite(prev_G[i]) and prev_sigma[i] != sigma[i]:
                    secant = (G[j] - prev_G[i]) / (sigma[i] - prev_sigma[i])
                    if np.isfinite(secant) and secant < SLOPE_CEILING:
                        slope = secant
                prev_sigma[i], prev_G[i] = sigma[i], G[j]
                nxt = sigma[i] + float(np.clip(-G[j] / slope, -MAX_SCALE_STEP, MAX_SCALE_STEP))
            elif code == _EARLY_CLAMP and np.isfinite(res["R"][j]) and res["R"][j] > 0:
                hi[i] = sigma[i]
                nxt = math.log(res["R"][j])
            elif code == _FAR_CLAMP:
                lo[i] = sigma[i]
                nxt = sigma[i] + MAX_SCALE_STEP
            else:
                last_code[i] = code
                failures[i] += 1
                if failures[i] >= MAX_FAILED_TRIALS:
                    final[i] = code
                    detail[live[i]] = (
                        f"{reason_text(code)} (in region {int(res['region'][j]) + 1}, at every one of "
                        f"{MAX_FAILED_TRIALS} placements of the interfaces tried, the last at interface scale "
                        f"{math.exp(sigma[i]):.6g})"
                    )
                    open_[i] = False
                    continue
                nxt = _after_failed_trial(i, sigma, lo, hi, good_sigma)
            nxt = _keep_bracketed(nxt, lo[i], hi[i])
            if _bracket_closed(lo[i], hi[i]):
                final[i] = last_code[i] if last_code[i] else NO_CLAMP
                detail[live[i]] = _closed_bracket_detail(final[i], hi[i], "relaxed state")
                open_[i] = False
            sigma[i] = nxt
    # a state left open whose every iterate met the clamp too near (G < 0, none above 0) and that has not reached
    # the floor (its residual nearly constant, the steps small: a pole stretch just below the flat zone's): one
    # trial at the floor says whether it lies below the flat zone
    last = np.flatnonzero(open_ & np.isinf(lo) & np.isfinite(good_sigma) & ~floor_tried)
    if last.size:
        sub = _Layout(n=lay.n[:, last], phi=lay.phi[:, last], f=lay.f, electrode=lay.electrode)
        res = _relaxed_pass(model, settings, sub, l0[last], p_t[last], floor[last], _take_pole(pole, last))
        steps[live[last]] += res["steps"]
        reach = np.where(res["status"] == 0, res["R"] / np.exp(floor[last]), np.nan)
        for i, r in zip(last[reach < 1.0], reach[reach < 1.0]):
            final[i] = BELOW_FLAT
            detail[live[i]] = _below_floor_detail(BELOW_FLAT, math.exp(floor[i]), r)
            open_[i] = False
    for i in np.flatnonzero(open_):
        final[i] = last_code[i] if last_code[i] else NOT_FINITE
        detail[live[i]] = (
            f"{reason_text(final[i])} (the interfaces of the relaxed state were not placed at their fractions of the "
            f"clamp radius within {MAX_SCALE_ITERATIONS} iterations)"
        )
    status[live] = final


# --- the dispatch ----------------------------------------------------------------------------------------------


def shoot_zone_relaxed(
    model, pole_stretch, phi_hat, settings, shape=False, derivatives=False, formal=False, starts=None
):
    """:func:`coexist.shooting.solve_states` of a tension-field :class:`~coexist.patterned.PatternedModel`: the
    taut patterned states (:func:`~coexist.patterned.shoot_zone`), the ``WRINKLED`` ones shot again relaxed
    (:func:`solve_patterned_relaxed`), as :func:`~coexist.shooting.solve_states` does for a uniform zone.

    With ``derivatives=True`` the relaxed states carry their exact derivatives too (:func:`solve_patterned_relaxed`),
    so the N-zone layer (curves' limit points, equilibria, the continuation) follows a zone through its wrinkled
    states; ``formal=True`` is the taut patterned shooting unchanged.

    Parameters
    ----------
    model : PatternedModel
        With ``wrinkling="tension-field"``.
    pole_stretch, phi_hat, settings, shape, derivatives, formal, starts
        As for :func:`~coexist.shooting.solve_states`.

    Returns
    -------
    PatternedStates
        ``wrinkled_radii`` and ``wrinkled_stiffness`` set for every state (empty and ``inf`` when taut).
    """
    from .patterned import shoot_zone

    if len(model.pattern.regions) == 1 and not formal and not shape:  # a uniform zone: solve_states relaxes it
        settings, l0, phi = checked_state_inputs(model.uniform, pole_stretch, phi_hat, settings)
        return _one_region(model.uniform, model.pattern, l0, phi, settings, derivatives)
    taut = shoot_zone(model, pole_stretch, phi_hat, settings, shape, derivatives, formal, starts)
    if formal:
        return taut
    return relax_wrinkled(model.uniform, model.pattern, taut, settings, derivatives, starts)


def relax_wrinkled(model, pattern: ZonePattern, taut: PatternedStates, settings=None, derivatives=False, starts=None):
    """The taut patterned states ``taut`` with their ``WRINKLED`` ones shot again relaxed (in place).

    Parameters
    ----------
    model : MembraneModel
        One layer of a tension-field membrane.
    pattern : ZonePattern
    taut : PatternedStates
        From :func:`coexist.patterned.solve_patterned_states` (or :func:`~coexist.patterned.shoot_zone`).
    settings : SolverSettings, optional
    derivatives : bool
        Whether ``taut`` carries derivatives: the relaxed states then get theirs too (exact,
        :func:`_relaxed_derivative_pass`).
    starts : coexist.patterned.ScaleStarts, optional
        A continuation's store of converged states (:func:`solve_patterned_relaxed`).

    Returns
    -------
    PatternedStates
        ``taut``, with ``wrinkled_radii`` and ``wrinkled_stiffness`` set for every state.
    """
    n = taut.status.size
    if taut.wrinkled_radii is None:
        taut.wrinkled_radii = [[] for _ in range(n)]
    if taut.wrinkled_stiffness is None:
        taut.wrinkled_stiffness = np.where(taut.ok, np.inf, np.nan)
    again = np.flatnonzero(taut.status == WRINKLED)
    if not again.size:
        return taut
    rel = solve_patterned_relaxed(
        model, pattern, taut.pole_stretch[again], taut.phi_hat[again], settings, derivatives=derivatives, starts=starts
    )
    for name, value in rel.__dict__.items():
        mine = taut.__dict__.get(name)
        if isinstance(value, np.ndarray) and isinstance(mine, np.ndarray) and mine.shape[:1] == (n,):
            mine[again] = value
    if derivatives and taut.derivatives is not None and rel.derivatives is not None:
        for name, value in rel.derivatives.__dict__.items():
            getattr(taut.derivatives, name)[again] = value
    for j, i in enumerate(again):
        taut.wrinkled_radii[i] = rel.wrinkled_radii[j] if rel.wrinkled_radii is not None else []
        taut.failure_detail[i] = rel.failure_detail[j]
    taut.interfaces[again] = rel.interfaces
    return taut
