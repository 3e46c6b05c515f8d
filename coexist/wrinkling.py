"""Shooting through hoop-wrinkled segments: tension-field theory in the vectorised integrator.

A model with ``wrinkling="tension-field"`` (:class:`~coexist.model.MembraneModel`) does not refuse a
state whose hoop tension would turn negative: there the membrane wrinkles across the hoop direction,
carries no hoop tension, and its material hoop stretch is the *natural width* ``w = λ2*(λ1; Φ̂)``, the
root of ``T̂2(λ1, w) = 0`` (docs/physics.md, section 10). :func:`coexist.shooting.solve_states` shoots
every state as a taut membrane first; the states it finds wrinkled are taken up here by the same DOP853
integrator (:mod:`coexist.numerics.dop853`), all columns at once, from the last node before the tension's zero
that the taut shot vouches for (its state, sensitivities, radius and step; the pole-to-onset segment is not
integrated twice; from the pole where the zero may lie in an earlier step whose minimum the taut shot located
only after its run):

* a *taut* segment integrates the membrane equations (:meth:`~coexist.model.MembraneModel.rhs`) until
  the hoop tension ``T̂2(λ1, λ2)`` falls to zero (located within the step to roundoff, including a dip
  to zero between two nodes); the segment then turns *wrinkled*, with ``ρ = λ2`` and ``w = λ2`` there;
* a *wrinkled* segment integrates :meth:`~coexist.model.MembraneModel.wrinkled_rhs` (``R̂T̂1`` constant,
  ``θ' = p̂λ1ρ/T̂1``, ``ρ`` the geometric hoop stretch), its width polished by Newton's method on
  ``T̂2(λ1, w) = 0`` from a row that integrates ``w' = (dw/dλ1) λ1'``, until the gap ``w − ρ`` closes
  (taut again, ``λ2 = ρ``);
* either ends where the geometric hoop stretch reaches the clamp's, ``ρ = λpre``, at ``R̂*``; the
  ``R̂ → cR̂, p̂ → p̂/c`` scaling then gives the unit membrane, as for taut states.

``λ1, ρ, θ`` and the quadratures are continuous at a switch; ``λ1'`` is not, so the sensitivities
(the variational equations, for exact derivatives to ``λ0`` and ``Φ̂``) jump by the saltation
``S⁺ = S⁻ + (f⁻ − f⁺) dτ/da``, ``dτ/da = −(∇g·S⁻ + ∂g/∂a)/(∇g·f⁻)`` for the switching function ``g``.

A crossing (switch or clamp) is located inside the step that crossed it from the switching function and its
slope at both ends of that step (kept by the integration): Newton's method from the root of their cubic Hermite
interpolant (error ``O(h⁴)``), each iterate one DOP853 step of the trial size from the last node, ended by a
Newton step below :data:`NEWTON_FINAL` taken along the trajectory without another step (its error is that
step's square): two or three steps per crossing (see :func:`_locate`).

Failures are named: ``slack`` (the meridional tension falls to zero: both tensions vanish), ``pull-in``
(no natural width, or ``K = dT̂1/dλ1`` along it falls to zero), Gent locking, folding back, and more than
:data:`MAX_SWITCHES` switches.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from . import shooting as sh
from .model import QUADRATURE_FACTORS, MembraneModel
from .numerics import dop853 as _int
from .numerics.buffers import BufferedFunction
from .numerics.roots import bracketed_root
from .settings import SolverSettings

#: most switches between taut and wrinkled along one meridian
MAX_SWITCHES = 8
#: relative Newton step below which the natural width has converged
WIDTH_TOL = 1e-13
#: a Newton step of the natural width below WIDTH_TOL that falls on an end of its bracket ends it where
#: ``λ2 ∂T̂2/∂λ2`` exceeds this there (a root where the hoop tension rises, not its underflow far out)
WIDTH_STIFFNESS = 1e-6
#: iterations of the natural width's safeguarded Newton method before it gives up (no root: NaN)
WIDTH_MAX_ITER = 200
#: a natural width not bracketed below this hoop stretch (or below twice the material's locking stretch, where that
#: is larger) has none: the search (doubling its lower end while the hoop tension stays negative) stops there with
#: NaN. A neo-Hookean width beyond 1e4 needs ``1 − Φ̂²λ1²`` below 1e-16 (the closed form
#: ``λ2* = [λ1²(1 − Φ̂²λ1²)]^(−1/4)``), i.e. below the rounding of ``Φ̂λ1``; a Gent width lies before locking
#: (``λ2² < Jlim + 3``, below twice the locking stretch ``√((Jlim + 3)/2)``: Jlim up to 1e13 was checked, review
#: helper-69). Without it an input without a root doubled its bracket for all :data:`WIDTH_MAX_ITER` iterations, and
#: held its whole batch that long (535 of 735 calls on a neo-Hookean tension-field ring curve at Φ̂ = 0.35: 7.7 of
#: its 8.9 s)
WIDTH_LIMIT = 1e6
#: Newton steps polishing the integrated width at every right-hand side evaluation (the row is
#: accurate to the integration tolerance, so one step leaves its square; the second is roundoff)
WIDTH_POLISH = 1
#: relative location of a switch or of the clamp within its step
LOCATE_RTOL = 1e-14
#: a Newton step of the location below this fraction of its point ends it: the new point is then within about the
#: step's square of the root (~1e-14 of it), without another evaluation (see :func:`_locate`)
NEWTON_FINAL = 1e-7
#: Newton iterations on the cubic Hermite interpolant of a switching function (the location's start)
HERMITE_ITERATIONS = 12

#: a wrinkled segment whose stiffness ``K = dT̂1/dλ1`` falls below this fraction of ``T̂11`` pulls in: ``λ1'``
#: diverges like ``(R̂c − R̂)^(−1/2)`` as ``K → 0``, so the last ``1e-6`` changes the state by ~1e-12
PULL_IN_TOLERANCE = 1e-9

#: a natural width's bracket narrower than this fraction of its upper end has closed (four units in the last place)
_WIDTH_ROUNDOFF = 4 * np.finfo(float).eps

TAUT, WRINKLED = 0, 1
#: status of a column of :func:`shoot_relaxed` that reached its ``stop_radius`` (internal: never a state's status)
STOPPED = 98
_CLAMP, _SWITCH, _DIP = 1, 2, 3


def natural_width(model: MembraneModel, l1, phi=0.0, guess=None):
    """The natural width ``λ2*(λ1; Φ̂)``: the hoop stretch at which the hoop tension vanishes.

    ``T̂2(λ1, λ2*; Φ̂) = ∂W*/∂λ2 = 0`` with ``∂T̂2/∂λ2 > 0`` (a minimum of ``W*`` in ``λ2``), solved by a
    safeguarded, vectorised Newton method on ``model.tensions`` (``T̂22 = ∂T̂2/∂λ2``). It starts at (or
    brackets with) ``λ2 = λ1^(−1/2)``, where the elastic hoop tension of any material with
    ``Ws(I1)`` vanishes, so ``T̂2 = −Φ̂²λ1²λ2 ≤ 0`` there: the root sought is the first upward crossing
    of ``T̂2`` beyond it. Neo-Hookean: ``λ2* = [λ1²(1 − Φ̂²λ1²)]^(−1/4)``, none for ``Φ̂λ1 ≥ 1``.

    Parameters
    ----------
    model : MembraneModel
        The membrane (its tensions).
    l1 : float or array_like
        Meridional stretches ``λ1 > 0``.
    phi : float or array_like
        Normalised voltages ``Φ̂``, broadcast against ``l1``.
    guess : float or array_like, optional
        Starting values (e.g. the previous width along a meridian); safeguarded, any positive value
        works.

    Returns
    -------
    float or ndarray
        ``λ2*`` of the broadcast shape (a float for float inputs); NaN where there is no root (at fixed
        voltage ``W*`` then has no minimum in ``λ2``: electromechanical pull-in), none below
        :data:`WIDTH_LIMIT` (or twice the locking stretch), or an input is not finite.
    """
    l1a, phia = np.broadcast_arrays(np.asarray(l1, dtype=float), np.asarray(phi, dtype=float))
    width, _ = _natural_width_tensions(
        model, np.atleast_1d(l1a).astype(float), np.atleast_1d(phia).astype(float), guess
    )
    return float(width[0]) if l1a.ndim == 0 else width


def _natural_width_tensions(model: MembraneModel, l1: np.ndarray, phi: np.ndarray, guess=None):
    """:func:`natural_width` of float arrays ``l1``, ``phi`` of one shape (at least one-dimensional), and the
    tensions at it.

    The method's last evaluation of ``model.tensions`` checks ``T̂22 > 0`` at the widths: its seven outputs are those
    at ``(λ1, λ2*, Φ̂)``, the same numbers as a caller's evaluation there (the same points in the same order, so the
    same path through the generated code), which it need not repeat (a tension-field ring's relaxed meridional
    tension evaluated every width's tensions twice more: :func:`coexist.patterned_relaxed.relaxed_meridional_tension`).

    Parameters
    ----------
    model : MembraneModel
        The membrane (its tensions).
    l1, phi : ndarray
        Meridional stretches and normalised voltages, float arrays of one shape.
    guess : float or array_like, optional
        Starting values, as for :func:`natural_width`.

    Returns
    -------
    width : ndarray
        ``λ2*`` of the shape of ``l1`` (NaN where none, as :func:`natural_width`).
    tensions : tuple of 7 ndarray or None
        ``model.tensions(l1, width, phi)``, each of that shape; None when the check turned a width it evaluated into
        NaN (no root there: the tensions at NaN are not those of its evaluation).
    """
    with np.errstate(all="ignore"):
        lo = l1**-0.5  # T̂2(λ1, lo) = −Φ̂²λ1²lo ≤ 0
    hi = np.full_like(lo, np.inf)
    x = lo.copy()
    if guess is not None:
        g = _of_shape(guess, l1.shape)
        x = np.where(np.isfinite(g) & (g > 0), g, x)
    # an input that is not finite (or λ1 ≤ 0) has no width (NaN): it had iterated all WIDTH_MAX_ITER times, and held
    # its batch (a tension-field ring's search for its interface stretch passes such inputs: 157 of 730 calls of one
    # curve)
    done = ~(np.isfinite(l1) & np.isfinite(phi) & (l1 > 0))
    x = np.where(done, np.nan, x)
    lo_zero = np.zeros(l1.shape, dtype=bool)  # T̂2 is exactly zero at the bracket's lower end
    # the bracket's lower end has been evaluated (a start there, or moved to a point): a locked upper end is not
    # bisected before the lower end is known to be free of locking
    lo_seen = np.zeros(l1.shape, dtype=bool)
    locking = getattr(getattr(model, "elasticity", None), "locking_stretch", None)
    limit = max(WIDTH_LIMIT, 2 * locking) if locking is not None else WIDTH_LIMIT
    # A column's width and `done` are all that leave the loop, and a finished column's width is never changed again
    # (`x = np.where(done, x, new)`): its bracket and flags are not masked by `~done` below (they are not read again).
    # The arrays are mostly of one to three columns, where each numpy operation costs about a microsecond whatever
    # it computes: a value needed twice is computed once, and the rare branches (a Newton step at the bracket's end)
    # only where some column takes them.
    with np.errstate(all="ignore"):
        for _ in range(WIDTH_MAX_ITER):
            if done.all():
                break
            out = model.tensions(l1, x, phi)
            T2, margin, T22 = (_of_shape(out[k], x.shape) for k in (1, 4, 6))
            # beyond Gent locking: too far (the tensions there can be finite, with T̂2 < 0, and would move
            # the bracket's lower end past the root)
            free = margin > 0
            bad = ~(np.isfinite(T2) & free)
            at_lo = x == lo
            # locked at λ2 = λ1^(−1/2) itself, where I1 (at this λ1) is least: locked at every hoop stretch, no width
            # (a Gent membrane stretched past locking along the meridian had bisected its bracket down to that end,
            # ~50 evaluations for the NaN: 1700 of the 20000 calls, a third of the evaluations, of a tension-field
            # ring's `coexist coexistence`)
            locked_everywhere = ~free & at_lo
            lo_seen |= at_lo
            # (only a point above the lower end bounds the root: a guess below λ1^(−1/2) past locking had set the upper
            # end below the lower one, and the bracket, "closed", returned their mean, no root; review, helper-70)
            hi = np.where((bad | (T2 > 0)) & (x > lo), np.minimum(hi, x), hi)
            moved = ~bad & (T2 <= 0) & (x >= lo)
            lo = np.where(moved, x, lo)
            lo_seen |= moved
            lo_zero = np.where(moved, T2 == 0, lo_zero)
            step = np.where(bad, np.nan, T2 / T22)
            newton = x - step
            ok = np.isfinite(newton) & (T22 > 0) & (newton > lo) & (newton < hi)
            bounded = np.isfinite(hi)
            new = newton
            if not ok.all():  # (every step is taken in most iterations)
                fallback = np.where(bounded, np.where(lo_seen, 0.5 * (lo + hi), lo), 2 * lo)
                new = np.where(ok, newton, fallback)
            small = np.abs(step) <= WIDTH_TOL * x
            conv = ok & small
            # at the root T̂2 of either sign at roundoff puts x itself at one end of the bracket, and the Newton step
            # of a few ulp (or zero) is not strictly inside it: it had been refused and the bracket bisected down to
            # roundoff from its far end, ~50 more iterations (the tension-field ring curves). Such a step ends it
            # too where T̂2 rises measurably there (x ∂T̂2/∂λ2 above WIDTH_STIFFNESS), not where T̂2 and its slope
            # merely underflow towards zero far out (no width: Φ̂λ1 = 1 for a neo-Hookean membrane)
            at_end = small & ~ok
            if at_end.any():
                at_end &= np.isfinite(step) & (T22 * x > WIDTH_STIFFNESS)
                new = np.where(at_end, np.clip(newton, lo, hi), new)  # the Newton point, kept in the bracket
                conv |= at_end
            # the bracket's lower end is an exact zero of T̂2 and its upper end is known: a root of the computed tension,
            # whatever its stiffness. Near Φ̂λ1 = 1 (neo-Hookean) T̂2 is flat, zero to rounding over ~1e-5 of λ2* ~ 300:
            # such a bracket had been bisected down to roundoff (85 evaluations, now ~30; the root is as good, its error
            # against the closed form the same). Without an upper end (T̂2 ≤ 0 up to WIDTH_LIMIT: Φ̂λ1 = 1 to
            # rounding) it is none, as before
            going = ~conv  # (neither kind of end below needs a bounded bracket's conv: one is bounded, the other not)
            zero = going & lo_zero & bounded
            new = np.where(zero, lo, new)
            conv |= zero
            # a bracket below roundoff (the root sits between two neighbouring floats)
            conv |= bounded & (hi - lo <= _WIDTH_ROUNDOFF * hi)
            # the hoop tension still negative beyond the limit: no width (NaN below, where T̂22 is not positive)
            none = going & ~bounded & (lo > limit) | locked_everywhere
            new = np.where(none, np.nan, new)
            x = np.where(done, x, new)
            done |= conv | none
        out = model.tensions(l1, x, phi)
        T22 = _of_shape(out[6], x.shape)
        found = done & (T22 > 0)
        width = np.where(found, x, np.nan)
    # the evaluation was at the widths unless the check turned a finite point into NaN (no root there)
    tensions = tuple(_of_shape(a, x.shape) for a in out) if (found | np.isnan(x)).all() else None
    return width, tensions


def _of_shape(a, shape) -> np.ndarray:
    """An output ``a`` of a generated function as a float array of ``shape`` (a constant one is broadcast), not
    copied where it already is one (``np.broadcast_to`` costs a few microseconds, the arrays are mostly tiny)."""
    if type(a) is np.ndarray and a.shape == shape and a.dtype == np.float64:
        return a
    return np.broadcast_to(np.asarray(a, dtype=float), shape)


#: meridional stretches at which the wrinkled stiffness is sampled for :func:`band_pull_in_onset`
ONSET_STRETCHES = np.geomspace(1.001, 20.0, 160)
#: ... whose ratio, a Gent membrane's sampled up to its uniaxial locking stretch instead (past 20 for Jlim ≳ 1300, where
#: the unstable stretch lies beyond 20: review, helper-79)
ONSET_RATIO = ONSET_STRETCHES[1] / ONSET_STRETCHES[0]
#: voltages (fractions of the window's top) at which :func:`band_pull_in_onset` brackets the onset
ONSET_VOLTAGES = 8
#: relative tolerance of :func:`band_pull_in_onset`'s voltage (it places probes, it is not reported)
ONSET_TOL = 1e-10
#: zoom rounds of the stencil that refines the smallest sampled stiffness (its spacing falls 4× a round)
ONSET_ZOOMS = 4


def _onset_stretches(model: MembraneModel) -> np.ndarray:
    """The stretches at which the wrinkled stiffness is sampled: :data:`ONSET_STRETCHES`, or for a Gent membrane the
    same ratio of neighbours up to its uniaxial locking stretch (``√2`` times its equibiaxial one: ``λ1² + 2/λ1 − 3 =
    Jlim`` against ``2λ² + λ⁻⁴ − 3``), beyond which no strip has a width at any voltage (each such stretch costs the
    width's whole iteration)."""
    locking = getattr(getattr(model, "elasticity", None), "locking_stretch", None)
    if locking is None or not np.isfinite(locking):
        return ONSET_STRETCHES
    top = math.sqrt(2.0) * locking
    n = int(math.ceil(math.log(top / ONSET_STRETCHES[0]) / math.log(ONSET_RATIO)))
    return ONSET_STRETCHES[0] * ONSET_RATIO ** np.arange(n)


def _wrinkled_stiffness(model: MembraneModel, l1, phi) -> np.ndarray:
    """``K/|T̂11|`` of hoop-wrinkled material at ``(λ1, Φ̂)`` (``K = T̂11 − T̂12²/T̂22`` at the natural width: its sign,
    scaled; at high voltage ``T̂11`` is negative at small stretches, and ``K/T̂11`` had turned a negative ``K`` positive:
    review, helper-79); ``inf`` where there is no natural width."""
    l1, phi = np.broadcast_arrays(np.asarray(l1, dtype=float), np.asarray(phi, dtype=float))
    w = natural_width(model, l1, phi)
    with np.errstate(all="ignore"):
        _, _, T11, T12, _, _, T22 = (np.asarray(a, dtype=float) * np.ones(l1.shape) for a in model.tensions(l1, w, phi))
        k = (T11 - T12 * T12 / T22) / np.abs(T11)
    return np.where(np.isfinite(k), k, np.inf)


def band_pull_in_onset(model: MembraneModel, phi_hi: float) -> float | None:
    """The lowest voltage ``Φ̂c ≤ phi_hi`` at which a hoop-wrinkled strip of the material loses its stiffness
    somewhere: the root of ``g(Φ̂) = min_λ1 K(λ1; Φ̂)/T̂11``, where ``K = T̂11 − T̂12²/T̂22`` at the natural width
    ``λ2*(λ1; Φ̂)`` is the slope ``dT̂1ʷ/dλ1`` of the wrinkled tension (docs/physics.md, section 10).

    Above ``Φ̂c`` the stretches around the first zero of ``K`` are unstable (pull-in), an interval born with zero
    width: a state whose wrinkled band spans it stops being valid just above ``Φ̂c``, and may be valid again a little
    higher, once its band's stretches have moved past the unstable ones (a Gent membrane on a huge chamber: invalid
    from 3.72295 to about 3.727 kV, ``λ1 ≈ 5.21`` unstable from ``Φ̂c``, 3.722945 kV; review, helper-77). The
    continuation probes just past ``Φ̂c`` (:meth:`coexist.continuation.Tracer._one_way`).

    ``K/|T̂11|`` is sampled on :data:`ONSET_STRETCHES` at :data:`ONSET_VOLTAGES` voltages up to ``phi_hi``; the first
    that is not positive somewhere brackets ``Φ̂c``, whose ``g`` (the minimum over stretches refined by a parabola
    through the three samples around it, the samples narrowing with the bracket) is then solved by regula falsi
    (Illinois) to :data:`ONSET_TOL`. Cached per model and ``phi_hi``.

    Parameters
    ----------
    model : MembraneModel
        One layer of a tension-field membrane (a patterned zone's layers carry ``Φ̂/n`` each).
    phi_hi : float
        The largest voltage of interest.

    Returns
    -------
    float or None
        ``Φ̂c``, or None when the stiffness stays positive up to ``phi_hi``.
    """
    key = ("band pull-in onset", float(phi_hi))
    built = model._built
    if key not in built:
        built[key] = _band_pull_in_onset(model, float(phi_hi))
    return built[key]


def _stiffness_dip(model: MembraneModel, l1: np.ndarray, phi: float) -> tuple[float, bool]:
    """The smallest ``K/|T̂11|`` of hoop-wrinkled material over the stretches ``l1`` (ascending) at ``phi``, and whether
    the stiffness is positive again at a larger stretch (the material stiffens back, as a Gent membrane does; a
    neo-Hookean strip's falls for good towards ``Φ̂λ1 = 1``: no interior onset, a band reaching it is an ordinary
    pull-in; review, helper-78).

    The minimum is taken over ``l1``, then on a stencil of 9 samples between the smallest one's neighbours, zoomed
    :data:`ONSET_ZOOMS` times (near the onset the dip is narrower than the grid: at 3.725 kV, 2e-3 above it, the grid's
    smallest is +0.019), and refined by the parabola through the three samples around the stencil's smallest.
    Stateless: the minimum moves with the voltage (λ1 3.96 at Φ̂ 0.3, 5.21 at the onset for Gent 97), and a stencil
    carried from the last voltage lost it (review, helper-78)."""
    k = _wrinkled_stiffness(model, l1, phi)
    i = int(np.argmin(k))
    # positive again strictly past the minimum's neighbourhood (a neo-Hookean strip's smallest sample can be its last
    # with a width, and the stencil then finds the singular fall towards Φ̂λ1 = 1 beside it: review, helper-79)
    beyond = k[i + 2 :]
    recovers = bool(np.any(np.isfinite(beyond) & (beyond > 0)))
    best = float(k[i])
    x = np.array([l1[max(i - 1, 0)], l1[i], l1[min(i + 1, l1.size - 1)]])
    kx = k[max(i - 1, 0) : i + 2]
    m = 0
    for _ in range(ONSET_ZOOMS):  # 9 samples between the minimum's neighbours, a quarter of their spacing apart
        x = np.linspace(x[0], x[-1], 9)
        kx = _wrinkled_stiffness(model, x, phi)
        m = int(np.argmin(kx))
        best = min(best, float(kx[m]))
        x = x[max(m - 1, 0) : m + 2]
    if 0 < m < kx.size - 1 and np.all(np.isfinite(kx[m - 1 : m + 2])):
        a, b, c = kx[m - 1], kx[m], kx[m + 1]
        curv = a - 2 * b + c
        if curv > 0:
            best = min(best, float(b - (a - c) ** 2 / (8 * curv)))
    return best, recovers


def softened_at(model: MembraneModel, phi: float) -> bool:
    """Whether hoop-wrinkled material loses its stiffness inside its range of stretches at voltage ``Φ̂``: the smallest
    ``K/|T̂11|`` is not positive, and it is positive again at a larger stretch (:func:`_stiffness_dip`;
    :func:`band_pull_in_onset`). Monotone in ``Φ̂``: the largest voltage found not softened and the smallest found
    softened are remembered per model, and a voltage outside them is answered without evaluating the material.

    Parameters
    ----------
    model : MembraneModel
        One layer of a tension-field membrane.
    phi : float
        The voltage ``Φ̂``.

    Returns
    -------
    bool
    """
    memo = model._built.setdefault("band softened", [0.0, np.inf])  # [largest not softened, smallest softened]
    if phi <= memo[0]:
        return False
    if phi >= memo[1]:
        return True
    best, recovers = _stiffness_dip(model, _onset_stretches(model), phi)
    soft = best <= 0 and recovers
    if soft:
        memo[1] = phi
    else:
        memo[0] = phi
    return soft


def _band_pull_in_onset(model: MembraneModel, phi_hi: float) -> float | None:
    if not (phi_hi > 0 and softened_at(model, phi_hi)):
        return None
    grid = _onset_stretches(model)
    l1 = grid[np.isfinite(_wrinkled_stiffness(model, grid, phi_hi))]  # beyond locking no width at any voltage
    phis = phi_hi * np.arange(1, ONSET_VOLTAGES + 1) / ONSET_VOLTAGES
    K = _wrinkled_stiffness(model, np.tile(l1, phis.size), np.repeat(phis, l1.size)).reshape(phis.size, l1.size)
    soft_rows = [i for i in range(phis.size) if np.any(K[i] <= 0)]
    j = soft_rows[0] if soft_rows else phis.size - 1  # the grid may miss a narrow dip: the top is soft (checked)

    def g(phi):
        return _stiffness_dip(model, l1, phi)[0]

    lo, hi = (phis[j - 1] if j else 0.0), phis[j]
    g_hi = g(hi)
    g_lo = g(lo) if lo > 0 else np.inf
    while lo > 0 and not g_lo > 0:  # the grid missed a narrow dip below: the onset lies lower still
        j -= 1
        hi, g_hi = lo, g_lo
        lo = phis[j - 1] if j else 0.0
        g_lo = g(lo) if lo > 0 else np.inf
    if not g_hi <= 0:  # the refined minimum disagrees with the samples: bisect on its sign alone
        g_lo, g_hi = np.inf, -np.inf
    side = 0
    for _ in range(200):
        if hi - lo <= ONSET_TOL * hi:
            break
        if np.isfinite(g_lo) and np.isfinite(g_hi):
            x = hi - g_hi * (hi - lo) / (g_hi - g_lo)
            x = min(max(x, lo + 0.01 * (hi - lo)), hi - 0.01 * (hi - lo))
        else:
            x = 0.5 * (lo + hi)
        gx = g(x)
        if gx <= 0:
            hi, g_hi = x, (gx if np.isfinite(g_hi) else -np.inf)
            if side == -1 and np.isfinite(g_lo):
                g_lo *= 0.5
            side = -1
        else:
            lo, g_lo = x, (gx if np.isfinite(g_lo) else np.inf)
            if side == 1 and np.isfinite(g_hi):
                g_hi *= 0.5
            side = 1
    return float(hi)


def natural_width_neo_hookean(l1, phi=0.0):
    """Closed form ``λ2* = [λ1²(1 − Φ̂²λ1²)]^(−1/4)`` of a neo-Hookean membrane (NaN for ``Φ̂λ1 ≥ 1``).

    From ``T̂2 = λ2(1 − Φ̂²λ1²) − λ1⁻²λ2⁻³ = 0``.

    Parameters
    ----------
    l1, phi : float or array_like
        Meridional stretch and normalised voltage.

    Returns
    -------
    float or ndarray
    """
    l1 = np.asarray(l1, dtype=float)
    with np.errstate(all="ignore"):
        s = l1**2 * (1 - np.asarray(phi, dtype=float) ** 2 * l1**2)
        out = np.where(s > 0, s**-0.25, np.nan)
    return float(out) if out.ndim == 0 else out


@dataclass
class RelaxedShots:
    """What :func:`shoot_relaxed` found for each state (one entry per column), in the trial scaling.

    ``out`` has the keys of the taut shooting's output (``R`` the clamp radius ``R̂*``, ``p`` the trial
    pressure, ``V, Q, Psi, z`` the quadratures with their factors, and with derivatives ``dR_dl0`` ...);
    ``wrinkled_radii`` lists per state the hoop-wrinkled intervals ``(R̂start, R̂end)`` of the unit
    membrane.
    """

    out: dict
    status: np.ndarray
    min_tension: np.ndarray
    max_field: np.ndarray
    steps: np.ndarray
    fail_radius: np.ndarray
    wrinkled_radii: list = field(default_factory=list)
    #: per state the smallest ``K/T̂11`` (``K = dT̂1ʷ/dλ1``) at the outer ends of its wrinkled bands, where
    #: ``λ1`` is smallest in the band; ``inf`` for a taut state. It falls to zero at the band's pull-in.
    band_stiffness: np.ndarray | None = None
    #: with ``stop_radius`` only (:func:`shoot_relaxed`; None otherwise): where every column stopped, in the
    #: trial scaling: ``R`` (the stop radius for status :data:`STOPPED`, the clamp radius for ``OK``), ``y`` (the
    #: rows there, the layout of :class:`_Layout`: state, width ``w``, ``p̂t``, ``Φ̂``), ``mode`` (:data:`TAUT` or
    #: :data:`WRINKLED` at the stop) and ``intervals`` (per column its wrinkled intervals in the trial scaling,
    #: a band still open at the stop ending there)
    end: dict | None = None


class _Layout:
    """Rows of the relaxed integration: the taut shooting's rows ``0 … S−1`` (state, sensitivities), the
    natural width ``W = S``, the trial pressure ``P = S + 1`` and the voltage ``P + 1``."""

    def __init__(self, derivatives: bool):
        self.derivatives = derivatives
        self.S = 17 if derivatives else 7
        self.W = self.S
        self.P = self.S + 1
        self.rows = self.S + 3


def _polish(model, l1, w, phi, steps=WIDTH_POLISH):
    """Newton steps on ``T̂2(λ1, w) = 0`` from ``w``; returns ``w`` and the tensions there."""
    t = model.tensions(l1, w, phi)
    for _ in range(steps):
        w = w - t[1] / t[6]
        t = model.tensions(l1, w, phi)
    return w, t


class _Equations:
    """The right-hand sides of both kinds of segment, and their switching functions."""

    def __init__(self, model: MembraneModel, lay: _Layout):
        self.model, self.lay = model, lay
        # the run's settings and tolerances (set by shoot_relaxed)
        self.settings: SolverSettings = SolverSettings()
        self.rtol = np.zeros(0)
        self.atol = np.zeros((lay.rows, 0))
        # per column: K/T̂11 at the outer ends of its wrinkled bands (smallest; see RelaxedShots)
        self.band_stiffness = np.zeros(0)
        # per column the radius to stop at (shoot_relaxed's stop_radius); None: settings.max_radius_factor
        self.t_end: np.ndarray | None = None

    def end_of(self, cols) -> np.ndarray:
        """Where the columns ``cols`` stop integrating: their ``stop_radius``, else ``settings.max_radius_factor``."""
        if self.t_end is None:
            return np.full(np.size(cols), self.settings.max_radius_factor)
        return self.t_end[cols]

    def reached_end(self) -> int:
        """The status of a column that reached :meth:`end_of`: :data:`STOPPED` at a stop radius, else no clamp."""
        return sh.NO_CLAMP if self.t_end is None else STOPPED

    def taut(self, R, y):
        lay, out = self.lay, np.empty_like(y)
        out[lay.W :] = 0.0
        if lay.derivatives:
            self.model.rhs_sensitivities_into(R, y[0], y[1], y[2], y[lay.P], y[lay.P + 1], y[7:10], y[12:15], out)
        else:
            self.model.rhs_into(R, y[0], y[1], y[2], y[lay.P], y[lay.P + 1], out)
        return out

    def wrinkled(self, R, y):
        lay, out = self.lay, np.empty_like(y)
        out[lay.P :] = 0.0
        phi = y[lay.P + 1]
        w, _ = _polish(self.model, y[0], y[lay.W], phi)
        if lay.derivatives:
            vals = self.model.wrinkled_rhs_sensitivities(R, y[0], y[1], y[2], y[lay.P], phi, w, y[7:10], y[12:15])
        else:
            vals = self.model.wrinkled_rhs(R, y[0], y[1], y[2], y[lay.P], phi, w)
        for i, v in enumerate(vals):
            out[i if i < lay.S else lay.W] = v
        return out

    def rhs(self, mode):
        return self.taut if mode == TAUT else self.wrinkled

    def _switching_function(self, mode):
        """CasADi ``(λ1, λ2 or ρ, θ, w, Φ̂, λ1', λ2' or ρ', w') -> (g, dg/dR̂, T̂1, |Ê|, stiffness, locking
        margin, w)`` of one node (one call serves all columns: numpy's per-operation cost would dominate)."""
        store = sh._integrators(self.model)._casadi
        key = ("relaxed switching", mode)
        if key not in store:
            import casadi as ca

            aux = self.model.casadi_functions["aux"]
            l1, l2, th, w0, phi, f0, f1, fw = (ca.SX.sym(n) for n in ("l1", "l2", "th", "w", "phi", "f0", "f1", "fw"))
            if mode == TAUT:
                T1, T2, T11, T12, margin, E, T22 = aux(l1, l2, phi)
                out = [T2, T12 * f0 + T22 * f1, T1, ca.fabs(E), T11, margin, l2]
            else:
                w = w0
                for _ in range(WIDTH_POLISH):
                    a = aux(l1, w, phi)
                    w = w - a[1] / a[6]
                T1, T2, T11, T12, margin, E, T22 = aux(l1, w, phi)
                # K relative to |T̂11|: near K = 0 the meridian's slope λ1' = −T̂1/(R̂K) diverges like an inverse
                # square root and an integrator creeps towards it; below PULL_IN_TOLERANCE it is pull-in. The sign is
                # K's (K ≤ T̂11): a safeguard only, for with the ideal dielectric T̂11 < 0 forces T̂1 < 0, a slack node,
                # and K/T̂11 falls to −∞ before T̂11 changes sign (review, helper-80); K/|T̂11| = K/T̂11 wherever a
                # node is valid
                out = [
                    w - l2,
                    fw - f1,
                    T1,
                    ca.fabs(E),
                    (T11 - T12 * T12 / T22) / ca.fabs(T11) - PULL_IN_TOLERANCE,
                    margin,
                    w,
                ]
            x = ca.vertcat(l1, l2, th, w0, phi, f0, f1, fw)
            store[key] = ca.Function("switching", [x], [ca.vertcat(*out)])
        return store[key]

    def attempts_kind(self, mode) -> str:
        """The name of the attempt function of ``mode`` (its cache key's ``kind``)."""
        return ("relaxed_taut", "relaxed_wrinkled")[mode] + ("_sens" if self.lay.derivatives else "")

    def stepper(self, mode, n: int):
        """DOP853 steps of ``n`` columns in ``mode``: numpy for a large batch, else one CasADi call per step
        (compiled once per machine), as the taut shooting's small batches."""
        kind = ("relaxed_taut", "relaxed_wrinkled")[mode] + ("_sens" if self.lay.derivatives else "")
        return sh._integrators(self.model).stepper_of(
            kind, n, self.lay.rows, self.rhs(mode), lambda: self._casadi_rhs(mode), medium=True
        )

    def _casadi_rhs(self, mode):
        import casadi as ca

        lay, f = self.lay, self.model.casadi_functions
        t, y = ca.SX.sym("t"), ca.SX.sym("y", lay.rows)
        phi, p = y[lay.P + 1], y[lay.P]
        sens = (y[7], y[8], y[9], y[12], y[13], y[14]) if lay.derivatives else ()
        if mode == TAUT:
            d = f["rhs_sens" if lay.derivatives else "rhs"](t, y[0], y[1], y[2], p, phi, *sens)
            out = [*d, 0, 0, 0]
        else:
            w = y[lay.W]
            for _ in range(WIDTH_POLISH):
                aux = f["aux"](y[0], w, phi)
                w = w - aux[1] / aux[6]
            d = f["wrinkled_rhs_sens" if lay.derivatives else "wrinkled_rhs"](t, y[0], y[1], y[2], p, phi, w, *sens)
            out = [*d, 0, 0]
        return ca.Function("rhs", [t, y], [ca.vertcat(*out)])

    def switching(self, mode, y, f):
        """The switching function ``g`` (taut: ``T̂2``; wrinkled: ``w − ρ``) and its slope ``dg/dR̂``, with
        the tensions, the width used and the validity codes of the node."""
        lay = self.lay
        n = y.shape[1]
        fn = self._switching_function(mode)
        x = np.vstack([y[0], y[1], y[2], y[lay.W], y[lay.P + 1], f[0], f[1], f[lay.W]])
        # bound once per model, mode and batch size (a shooting makes a new _Equations, the model keeps these)
        store = sh._integrators(self.model)._casadi
        call = store.get(("relaxed switching call", mode, n))
        if call is None:
            call = store[("relaxed switching call", mode, n)] = BufferedFunction(
                fn.map(n, "serial") if n > 1 else fn, [8], 7, n
            )
        g, dg, T1, E, stiff, margin, w = call(x)
        code = np.zeros(np.shape(y[0]), dtype=int)
        code[np.abs(y[2]) > math.pi] = sh.FOLDED_BACK
        code[~(stiff > 0)] = sh.LOST_ELLIPTICITY if mode == TAUT else sh.PULL_IN
        code[~(margin > 0)] = sh.LOCKED
        code[~(T1 > 0)] = sh.SLACK
        if mode == WRINKLED:
            code[~np.isfinite(w)] = sh.PULL_IN
        return g, dg, T1, np.abs(E), code, stiff


def _hermite_dip(Ra, ga, da, Rb, gb, db):
    """Whether the cubic Hermite interpolant of ``g`` on ``[Ra, Rb]`` dips below zero between positive
    ends (a switch between two nodes)."""
    interior = (da < 0) & (db > 0) & (ga > 0) & (gb > 0)
    dip = np.zeros(np.shape(ga), dtype=bool)
    if interior.any():
        est = sh.hermite_minimum(Ra[interior], ga[interior], da[interior], Rb[interior], gb[interior], db[interior])
        dip[interior] = est < 0
    return dip


def shoot_relaxed(
    model: MembraneModel,
    settings: SolverSettings,
    l0,
    phi,
    derivatives: bool = False,
    start: dict | None = None,
    stop_radius=None,
) -> RelaxedShots:
    """Shoot the states ``(λ0, Φ̂)`` of a tension-field membrane from the pole to the clamp.

    Each column starts taut at the pole's series radius, or at the node its taut shooting stopped at
    (``start``): the pole-to-onset segment, taut, is then not integrated twice.

    Parameters
    ----------
    model : MembraneModel
        A model with ``wrinkling="tension-field"``.
    settings : SolverSettings
        Tolerances, as for the taut shooting.
    l0, phi : ndarray
        Pole stretches (above ``λpre``, with a positive pole tension) and voltages, one per state.
    derivatives : bool
        Carry the variational equations (exact derivatives to ``λ0`` and ``Φ̂``).
    start : dict, optional
        Per state a taut node to start from (what :func:`coexist.shooting._shoot` leaves in its
        ``restart``): ``R``, ``y`` (the rows of :func:`coexist.shooting.start_rows`), a step size ``h``,
        the smallest tension ``min_T`` and largest field ``max_E`` up to it; a column whose ``R`` is NaN
        starts at the pole. Optional keys (for a start that is not the taut shot's, e.g. a region of a
        patterned zone, :mod:`coexist.patterned_relaxed`): ``mode`` (per state :data:`TAUT` or :data:`WRINKLED`:
        the segment the column starts in; a wrinkled start takes its natural width from
        :func:`natural_width` and opens its wrinkled interval at ``R``) and ``atol`` (the absolute tolerances
        of the rows of :func:`coexist.shooting.start_rows`, instead of those of ``l0, phi``).
    stop_radius : array_like, optional
        Per state a radius (trial scaling) at which to stop instead of going on to the clamp: a column that
        reaches it without meeting the clamp stretch gets status :data:`STOPPED` and its rows there in
        :attr:`RelaxedShots.end` (one that meets the clamp first lands there, status ``OK``, as without
        it). Default: none (the clamp, within ``settings.max_radius_factor``); every result is then
        unchanged.

    Returns
    -------
    RelaxedShots
    """
    lay = _Layout(derivatives)
    eqs = _Equations(model, lay)
    l0 = np.asarray(l0, dtype=float)
    phi = np.broadcast_to(np.asarray(phi, dtype=float), l0.shape).copy()
    m = l0.size
    R0 = settings.series_radius
    _, y_start, atol_start, rtol = sh.start_rows(model, settings, l0, phi, derivatives)
    S = lay.S
    y = np.vstack([y_start[:S], y_start[1:2], y_start[S:]])
    atol = np.vstack([atol_start[:S], np.full((1, m), np.inf), atol_start[S:]])
    atol = np.where(np.isfinite(atol), atol, 1e300)
    eqs.settings, eqs.rtol, eqs.atol = settings, rtol, atol
    eqs.band_stiffness = np.full(m, np.inf)
    R = np.full(m, R0)
    h = np.full(m, R0)
    mode = np.zeros(m, dtype=int)
    status = np.full(m, -1)  # running
    steps = np.zeros(m, dtype=int)
    switches = np.zeros(m, dtype=int)
    T0, *_ = model.pole(l0, phi)
    min_T = np.broadcast_to(np.asarray(T0, dtype=float), (m,)).copy()
    max_E = np.abs(np.broadcast_to(np.asarray(model.tensions(l0, l0, phi)[5], dtype=float), (m,))).copy()
    if start is not None:
        go = np.isfinite(start["R"]) & (start["h"] > 0) & np.all(np.isfinite(start["y"]), axis=0)
        go &= np.isfinite(start["min_T"]) & np.isfinite(start["max_E"])
        go = np.flatnonzero(go)
        ys = start["y"][:, go]
        y[:, go] = np.vstack([ys[:S], ys[1:2], ys[S:]])
        R[go], h[go] = start["R"][go], start["h"][go]
        min_T[go], max_E[go] = start["min_T"][go], start["max_E"][go]
        if "atol" in start:
            given = start["atol"][:, go]
            given = np.vstack([given[:S], atol[S : S + 1, go], given[S:]])
            atol[:, go] = np.where(np.isfinite(given), given, 1e300)
        if "mode" in start:
            mode[go] = np.asarray(start["mode"], dtype=int)[go]
    fail_R = np.full(m, np.nan)
    wrinkled_from = np.full(m, np.nan)
    if start is not None and "mode" in start:
        wr = np.flatnonzero(mode == WRINKLED)
        if wr.size:  # a wrinkled start: its natural width (T̂2(λ1, w) = 0, w ≥ ρ), its interval opens here
            y[lay.W, wr] = natural_width(model, y[0, wr], y[lay.P + 1, wr], guess=y[1, wr])
            wrinkled_from[wr] = R[wr]
    if stop_radius is not None:
        eqs.t_end = np.broadcast_to(np.asarray(stop_radius, dtype=float), (m,)).copy()
    intervals: list[list] = [[] for _ in range(m)]
    out = {k: np.full(m, np.nan) for k in ("p", "V", "Q", "Psi", "z", "R")}
    if derivatives:
        out.update({k: np.full(m, np.nan) for k in ("dR_dl0", "dV_dl0", "dQ_dl0", "dR_dphi", "dV_dphi", "dQ_dphi")})
    # per column the switching function and its slope dg/dR̂ at the last accepted node, and at the end of the
    # step that crossed the clamp or a switch, with λ2 and λ2' there, and λ2' at the node (_handle_stops
    # locates the crossing from them without taking that step again)
    node = np.full((7, m), np.nan)
    while (status == -1).any():
        for md in (TAUT, WRINKLED):
            cols = np.flatnonzero((status == -1) & (mode == md))
            if cols.size:
                _segment(eqs, md, cols, R, y, h, status, steps, min_T, max_E, fail_R, node, rtol, atol, settings)
                _handle_stops(eqs, md, cols, R, y, h, mode, status, switches, wrinkled_from, intervals, out, node)
    end = None
    if stop_radius is not None:
        raw: list[list] = [list(v) for v in intervals]
        R_end = R.copy()
        end = {"R": R_end, "y": y.copy(), "mode": mode.copy(), "intervals": raw}
        for i in np.flatnonzero(status == STOPPED):
            if mode[i] == WRINKLED:
                raw[i].append((wrinkled_from[i], R[i]))
        stopped_wrinkled = np.flatnonzero((status == STOPPED) & (mode == WRINKLED))
        if stopped_wrinkled.size:  # a band that reaches the stop ends there
            f_stop = eqs.rhs(WRINKLED)(R[stopped_wrinkled], y[:, stopped_wrinkled])
            _band_end(eqs, stopped_wrinkled, y[:, stopped_wrinkled], f_stop)
        for i in np.flatnonzero(status == sh.OK):
            R_end[i] = out["R"][i]
            raw[i] = [(a, b if math.isfinite(b) else out["R"][i]) for a, b in intervals[i]]
    done = status == sh.OK
    for i in np.flatnonzero(done):
        Rs = out["R"][i]
        intervals[i] = [(a / Rs, (b if math.isfinite(b) else Rs) / Rs) for a, b in intervals[i]]
        if intervals[i]:
            min_T[i] = 0.0  # the hoop tension vanishes in the wrinkled region
    fail_radius = np.where(done, np.inf, fail_R / np.where(np.isfinite(out["R"]), out["R"], 1.0))
    band = np.where(done, eqs.band_stiffness, np.nan)
    if end is not None:
        band = np.where(done | (status == STOPPED), eqs.band_stiffness, np.nan)
    return RelaxedShots(out, status, min_T, max_E, steps, fail_radius, intervals, band, end)


def _segment(eqs, md, cols, R, y, h, status, steps, min_T, max_E, fail_R, node, rtol, atol, settings):
    """Integrate the columns ``cols`` (all in mode ``md``) until each crosses the clamp or a switch, or fails;
    on return ``R, y`` of a crossing column hold the last node before the crossing, ``h`` the step that
    crossed (status ``-2 - kind``) and ``node`` the switching function and its slope at that node and at the
    step's end, with ``λ2, λ2'`` there, and ``λ2'`` at the node."""
    _lay, model = eqs.lay, eqs.model
    lam_clamp = model.prestretch
    n = cols.size
    k_cross = np.zeros(n, dtype=int)
    h_cross = np.full(n, np.nan)
    end_cross = np.full((4, n), np.nan)
    R_last = R[cols].copy()
    y_start = y[:, cols]
    f0 = eqs.rhs(md)(R_last, y_start)
    g0, dg0, *_ = eqs.switching(md, y_start, f0)
    # right after a switch the new segment's function is zero (to roundoff): a fall below it at the first
    # node is a switch back
    g_last = np.maximum(g0, 1e-300)
    dg_last = dg0.copy()
    l2p_last = f0[1].copy()

    def event(t_new, y_new, idx, f_new):
        g, dg, T1, E, code, _ = eqs.switching(md, y_new, f_new)
        clamp = y_new[1] <= lam_clamp
        switch = (g <= 0) & (g_last[idx] > 0)
        dip = ~switch & _hermite_dip(R_last[idx], g_last[idx], dg_last[idx], t_new, g, dg)
        if md == TAUT:
            min_T[cols[idx]] = np.minimum(min_T[cols[idx]], np.where(clamp | switch, np.inf, np.minimum(T1, g)))
        else:
            min_T[cols[idx]] = np.minimum(min_T[cols[idx]], np.where(clamp | switch, np.inf, T1))
        max_E[cols[idx]] = np.maximum(max_E[cols[idx]], np.where(clamp | switch, 0.0, E))
        res = np.full(idx.size, _int.CONTINUE)
        cross = clamp | switch | dip
        k_cross[idx[clamp]] = _CLAMP
        k_cross[idx[~clamp & switch]] = _SWITCH
        k_cross[idx[~clamp & ~switch & dip]] = _DIP
        h_cross[idx[cross]] = t_new[cross] - R_last[idx[cross]]
        end_cross[:, idx[cross]] = np.vstack([g[cross], dg[cross], y_new[1, cross], f_new[1, cross]])
        res[cross] = _int.CROSSED
        bad = ~cross & (code != 0)
        res[bad] = _int.FAILED + code[bad]
        fail_R[cols[idx[bad]]] = t_new[bad]
        keep = ~cross
        R_last[idx[keep]] = t_new[keep]
        g_last[idx[keep]] = g[keep]
        dg_last[idx[keep]] = dg[keep]
        l2p_last[idx[keep]] = f_new[1, keep]
        return res

    entry = sh._integrators(model).attempts_of(eqs.attempts_kind(md), lambda: _attempt_function(eqs, md))
    if entry.get("fast") or n <= sh.CASADI_BATCH_LIMIT:  # compiled: any size (sh.run_attempts chunks it)
        _segment_attempts(entry, eqs, md, cols, R, y, h, f0, g_last, dg_last, status, steps, min_T, max_E, fail_R, node)
        return
    res = _int.integrate(
        eqs.stepper(md, n),
        R[cols],
        y_start,
        eqs.end_of(cols),
        rtol[cols],
        atol[:, cols],
        settings.max_steps,
        event=event,
        h0=h[cols],
    )
    steps[cols] += res.steps
    R[cols] = res.t
    y[:, cols] = res.y
    st = res.status
    crossed = st == _int.CROSSED
    status[cols[crossed]] = -2 - k_cross[crossed]
    h[cols[crossed]] = h_cross[crossed]
    status[cols[st == _int.REACHED_END]] = eqs.reached_end()
    status[cols[st == _int.STEP_LIMIT]] = sh.STEP_LIMIT
    failed = st >= _int.FAILED
    status[cols[failed]] = st[failed] - _int.FAILED
    node[0, cols], node[1, cols], node[2:6, cols], node[6, cols] = g_last, dg_last, end_cross, l2p_last


#: layout of the packed per-trajectory state of the relaxed attempt function (then y, f, atol)
_HEAD = (
    "t",
    "h",
    "t_end",
    "rtol",
    "status",
    "steps",
    "max_steps",
    "g_last",
    "dg_last",
    "R_last",
    "minT",
    "maxE",
    "failR",
    "kind",
    "h_cross",
    "g_cross",
    "dg_cross",
    "l2_cross",
    "f1_cross",
)
_H = {k: i for i, k in enumerate(_HEAD)}


def _attempt_function(eqs, mode, K: int = sh.ATTEMPTS_PER_CALL):
    """``K`` DOP853 attempts of one trajectory in ``mode`` as one CasADi function of its packed state: what
    :func:`_segment`'s numpy loop does per step (the step and its error control, then at the new node the
    switching function, the clamp, a dip between nodes, the failures), so that a small batch costs one call
    per ``K`` attempts instead of several numpy and CasADi calls per step. A stopped trajectory (status ≠ 0:
    ``CROSSED`` with its ``kind`` and ``h_cross``, a failure code, ``REACHED_END``, ``STEP_LIMIT``) passes
    through unchanged."""
    import casadi as ca

    lay, model = eqs.lay, eqs.model
    rhs = eqs._casadi_rhs(mode)
    R = lay.rows
    step = _int.casadi_step_function(rhs, R, "dop853_relaxed")
    sw = eqs._switching_function(mode)
    o = len(_HEAD)
    x = ca.SX.sym("x", o + 3 * R)
    g = {k: x[i] for k, i in _H.items()}
    y, f, atol = x[o : o + R], x[o + R : o + 2 * R], x[o + 2 * R : o + 3 * R]
    t, h = g["t"], g["h"]
    active = g["status"] == 0
    hs, last, y_new, f_new, accepted, factor, t_new = sh.attempt_step(step, g, y, atol, R)
    q = sw(ca.vertcat(y_new[0], y_new[1], y_new[2], y_new[lay.W], y_new[lay.P + 1], f_new[0], f_new[1], f_new[lay.W]))
    gg, dg, T1, E, stiff, margin, w = (q[i] for i in range(7))
    clamp = y_new[1] <= model.prestretch
    switch = (gg <= 0) * (g["g_last"] > 0)
    interior = (g["dg_last"] < 0) * (dg > 0) * (g["g_last"] > 0) * (gg > 0)
    est = sh._hermite_min(sh._CasadiOps(), g["R_last"], g["g_last"], g["dg_last"], t_new, gg, dg)
    dip = interior * (est < 0) * (1 - switch)
    cross = accepted * ((clamp + switch + dip) > 0)
    kind = ca.if_else(clamp, _CLAMP, ca.if_else(switch, _SWITCH, _DIP))
    code = ca.if_else(ca.fabs(y_new[2]) > math.pi, sh.FOLDED_BACK, 0)
    code = ca.if_else(1 - (stiff > 0), sh.LOST_ELLIPTICITY if mode == TAUT else sh.PULL_IN, code)
    code = ca.if_else(1 - (margin > 0), sh.LOCKED, code)
    code = ca.if_else(1 - (T1 > 0), sh.SLACK, code)
    if mode == WRINKLED:
        code = ca.if_else(w != w, sh.PULL_IN, code)
    move = accepted * (1 - cross)
    bad = move * (code != 0)
    status = ca.if_else(cross, _int.CROSSED, g["status"])
    status = ca.if_else(bad, code, status)
    status = ca.if_else(move * last * (code == 0), _int.REACHED_END, status)
    steps = g["steps"] + active
    status = ca.if_else((status == 0) * (steps >= g["max_steps"]), _int.STEP_LIMIT, status)
    node_min = ca.fmin(T1, gg) if mode == TAUT else T1
    new = {
        "t": ca.if_else(move, t_new, t),
        "h": ca.if_else(active, hs * factor, h),
        "t_end": g["t_end"],
        "rtol": g["rtol"],
        "status": status,
        "steps": steps,
        "max_steps": g["max_steps"],
        "g_last": ca.if_else(move, gg, g["g_last"]),
        "dg_last": ca.if_else(move, dg, g["dg_last"]),
        "R_last": ca.if_else(move, t_new, g["R_last"]),
        "minT": ca.if_else(move, ca.fmin(g["minT"], node_min), g["minT"]),
        "maxE": ca.if_else(move, ca.fmax(g["maxE"], E), g["maxE"]),
        "failR": ca.if_else(bad, t_new, g["failR"]),
        "kind": ca.if_else(cross, kind, g["kind"]),
        "h_cross": ca.if_else(cross, hs, g["h_cross"]),
        "g_cross": ca.if_else(cross, gg, g["g_cross"]),
        "dg_cross": ca.if_else(cross, dg, g["dg_cross"]),
        "l2_cross": ca.if_else(cross, y_new[1], g["l2_cross"]),
        "f1_cross": ca.if_else(cross, f_new[1], g["f1_cross"]),
    }
    head = ca.vertcat(*[new[k] for k in _HEAD])
    x_new = ca.vertcat(head, ca.if_else(move, y_new, y), ca.if_else(move, f_new, f), atol)
    name = f"attempts_{eqs.attempts_kind(mode)}"
    one = ca.Function(name + "_one", [x], [ca.cse(x_new)])
    acc = one.mapaccum(name + "_acc", K)
    xm = ca.MX.sym("x", o + 3 * R)
    return ca.Function(name, [xm], [acc(xm)[:, K - 1]])


def _segment_attempts(entry, eqs, md, cols, R, y, h, f0, g_last, dg_last, status, steps, min_T, max_E, fail_R, node):
    """:func:`_segment` for a small batch: the attempt function, :data:`coexist.shooting.ATTEMPTS_PER_CALL`
    attempts per call, until every column stops; the same outcome as the numpy loop."""
    lay, settings = eqs.lay, eqs.settings
    n, rows = cols.size, lay.rows
    o = len(_HEAD)
    X = np.zeros((o + 3 * rows, n))
    X[_H["t"]], X[_H["h"]], X[_H["t_end"]] = R[cols], h[cols], eqs.end_of(cols)
    X[_H["rtol"]], X[_H["max_steps"]] = eqs.rtol[cols], settings.max_steps
    X[_H["g_last"]], X[_H["dg_last"]], X[_H["R_last"]] = g_last, dg_last, R[cols]
    X[_H["minT"]], X[_H["maxE"]], X[_H["failR"]], X[_H["h_cross"]] = min_T[cols], max_E[cols], np.nan, np.nan
    X[[_H["g_cross"], _H["dg_cross"], _H["l2_cross"], _H["f1_cross"]]] = np.nan
    X[o : o + rows], X[o + rows : o + 2 * rows], X[o + 2 * rows :] = y[:, cols], f0, eqs.atol[:, cols]
    sh.run_attempts(entry, X, _H["status"], _H["steps"], _H["max_steps"])
    st = X[_H["status"]].astype(int)
    steps[cols] += X[_H["steps"]].astype(int)
    R[cols] = X[_H["t"]]
    y[:, cols] = X[o : o + rows]
    min_T[cols] = X[_H["minT"]]
    max_E[cols] = X[_H["maxE"]]
    crossed = st == _int.CROSSED
    status[cols[crossed]] = -2 - X[_H["kind"], crossed].astype(int)
    h[cols[crossed]] = X[_H["h_cross"], crossed]
    node[0, cols], node[1, cols] = X[_H["g_last"]], X[_H["dg_last"]]
    node[2:6, cols] = X[[_H["g_cross"], _H["dg_cross"], _H["l2_cross"], _H["f1_cross"]]]
    node[6, cols] = X[o + rows + 1]  # λ2' at the node
    status[cols[st == _int.REACHED_END]] = eqs.reached_end()
    status[cols[st == _int.STEP_LIMIT]] = sh.STEP_LIMIT
    failed = st >= _int.FAILED
    status[cols[failed]] = st[failed]
    fail_R[cols[failed]] = X[_H["failR"], failed]


def _handle_stops(eqs, md, cols, R, y, h, mode, status, switches, wrinkled_from, intervals, out, node):
    """Locate the clamp or the switch inside the step that crossed it (from the switching function and its
    slope at both ends of that step, ``node``, see :func:`_segment`), then land on the clamp (with the
    derivatives) or switch the segment (with the saltation of the sensitivities)."""
    model = eqs.model
    lam_clamp = model.prestretch
    sel = np.flatnonzero(status[cols] <= -2)
    if not sel.size:
        return
    idx = cols[sel]
    kind = -2 - status[idx]
    fun = eqs.rhs(md)
    stepper = eqs.stepper(md, idx.size)
    Ra, ya = R[idx], y[:, idx]
    # the CasADi stepper evaluates its first stage itself; numpy's takes it
    fa = fun(Ra, ya) if isinstance(stepper, _int.NumpyStepper) else np.zeros_like(ya)
    hc = h[idx]
    g_a, dg_a, g_e, dg_e, l2_e, f1_e, f1_a = node[:, idx]
    # the last point evaluated in each column's step: where the location ends
    last_s, last_y, last_f = np.full(idx.size, np.nan), ya.copy(), fa.copy()

    def at(s, j):
        ys, fs, _, _ = stepper.step(Ra[j], ya[:, j], fa[:, j], s)
        last_s[j], last_y[:, j], last_f[:, j] = s, ys, fs
        return ys, fs

    def g_switch(s, j):
        ys, fs = at(s, j)
        g, dg, *_ = eqs.switching(md, ys, fs)
        return g, dg

    def g_clamp(s, j):
        ys, fs = at(s, j)
        return ys[1] - lam_clamp, fs[1]

    # a dip: the switching function's minimum inside the step, located first (its slope's root)
    s_hi = hc.copy()
    located = np.full(idx.size, np.nan)  # crossings located for both functions (a switch and the clamp in one step)
    dip = np.flatnonzero(kind == _DIP)
    if dip.size:

        def slope(s, j):
            ys, fs = at(s, dip[j])
            return eqs.switching(md, ys, fs)[1]

        r = bracketed_root(slope, np.zeros(dip.size), hc[dip], xtol=1e-12 * hc[dip], max_iter=60)
        ys, fs = at(r.x, dip)
        g_min = eqs.switching(md, ys, fs)[0]
        real = g_min <= 0
        s_hi[dip[real]] = r.x[real]
        kind[dip[real]] = _SWITCH
        kind[dip[~real]] = 0  # no crossing after all: resume after the step
        g_e[dip[real]] = g_min[real]
        dg_e[dip[real]] = 0.0  # at the minimum
    # where both the clamp and a switch fall in the step, the first one counts
    both = np.flatnonzero((kind == _CLAMP) & (g_e <= 0) & (g_a > 0))
    if both.size:
        g_lo, g_hi = np.maximum(g_a[both], 1e-300), np.minimum(g_e[both], -1e-300)
        s_sw = _locate(lambda s, j: g_switch(s, both[j]), hc[both].copy(), g_lo, g_hi, dg_a[both], dg_e[both])
        c_lo, c_hi = ya[1, both] - lam_clamp, np.minimum(l2_e[both] - lam_clamp, -1e-300)
        s_cl = _locate(lambda s, j: g_clamp(s, both[j]), hc[both].copy(), c_lo, c_hi, f1_a[both], f1_e[both])
        first_switch = s_sw < s_cl
        kind[both[first_switch]] = _SWITCH
        located[both] = np.where(first_switch, s_sw, s_cl)
    # resume the false alarms at the end of their step
    none = np.flatnonzero(kind == 0)
    if none.size:
        R[idx[none]] = Ra[none] + hc[none]
        y[:, idx[none]] = at(hc[none], none)[0]
        status[idx[none]] = -1
    for k in (_CLAMP, _SWITCH):
        j = np.flatnonzero(kind == k)
        if not j.size:
            continue
        x = located[j]
        todo = np.flatnonzero(np.isnan(x))
        if todo.size:
            jt = j[todo]
            # the integrator saw the crossing: its ends keep their signs (a re-evaluation may differ by roundoff)
            if k == _SWITCH:
                f_lo, f_hi, d_lo, d_hi = np.maximum(g_a[jt], 1e-300), np.minimum(g_e[jt], -1e-300), dg_a[jt], dg_e[jt]
                crossing = g_switch
            else:
                f_lo, f_hi = ya[1, jt] - lam_clamp, np.minimum(l2_e[jt] - lam_clamp, -1e-300)
                d_lo, d_hi = f1_a[jt], f1_e[jt]
                crossing = g_clamp
            x[todo] = _locate(lambda s, jj, jt=jt, c=crossing: c(s, jt[jj]), s_hi[jt].copy(), f_lo, f_hi, d_lo, d_hi)
        if todo.size < j.size:  # located for both crossings: the point of the first one
            jl = j[np.isnan(located[j]) == False]  # noqa: E712
            at(located[jl], jl)
        # the located point: the last one evaluated (exactly there, or one final Newton step away, see _locate)
        Rs = Ra[j] + last_s[j]
        ys, fs = last_y[:, j], last_f[:, j]
        if k == _CLAMP:  # _land corrects onto the clamp from the nearby point itself
            _land(eqs, md, idx[j], Rs, ys, fs, out, status, intervals, wrinkled_from)
        else:  # the switch: the last Newton step taken along the trajectory (error ~ its square)
            d = x - last_s[j]
            moved = d != 0
            if moved.any():
                ys = ys + fs * d
                Rs = Ra[j] + x
                fs = np.where(moved, fun(Rs, ys), fs)
            _switch(eqs, md, idx[j], Rs, ys, fs, R, y, h, hc[j], mode, status, switches, wrinkled_from, intervals)


def _hermite_root(H, g_lo, g_hi, d_lo, d_hi, iterations=HERMITE_ITERATIONS):
    """Root in ``(0, H)`` of the cubic Hermite interpolant of ``g`` on ``[0, H]`` from its values
    ``g_lo > 0 > g_hi`` and slopes ``d_lo, d_hi`` at the ends: the starting point of :func:`_locate`.

    With ``t = s/H``, ``a = H d_lo``, ``b = H d_hi``: ``p(t) = g_lo + a t + c2 t² + c3 t³``,
    ``c2 = 3(g_hi − g_lo) − 2a − b``, ``c3 = 2(g_lo − g_hi) + a + b`` (error ``O(H⁴)``); its root by Newton's
    method kept inside the shrinking bracket (bisection where a step leaves it), from the secant, until the
    steps fall below 1e-10 (the interpolant's own error is larger). Non-finite slopes are taken as zero.
    """
    lo, hi = np.zeros_like(H), np.ones_like(H)
    with np.errstate(all="ignore"):
        t = np.clip(g_lo / (g_lo - g_hi), 0.0, 1.0)
        a, b = H * d_lo, H * d_hi
        finite = np.isfinite(a) & np.isfinite(b)
        a, b = np.where(finite, a, 0.0), np.where(finite, b, 0.0)
        c2 = 3 * (g_hi - g_lo) - 2 * a - b
        c3 = 2 * (g_lo - g_hi) + a + b
        for _ in range(iterations):
            p = g_lo + t * (a + t * (c2 + t * c3))
            dp = a + t * (2 * c2 + 3 * c3 * t)
            pos = p > 0
            lo = np.where(pos, t, lo)
            hi = np.where(pos, hi, t)
            new = t - p / dp
            new = np.where(p == 0, t, np.where((new >= lo) & (new <= hi), new, 0.5 * (lo + hi)))  # NaN: bisection
            done = np.max(np.abs(new - t)) <= 1e-10
            t = new
            if done:
                break
    return t * H


def _locate(fun, hi, g_lo, g_hi, d_lo=None, d_hi=None, rtol=LOCATE_RTOL, max_iter=40):
    """Roots ``s`` in ``(0, hi)`` of ``g(s)`` given ``fun(s, idx) -> (g, dg/ds)``, ``g(0) = g_lo > 0 > g_hi =
    g(hi)``: Newton's method kept inside the shrinking bracket (bisection where a step leaves it).

    It starts at the root of the cubic Hermite interpolant (:func:`_hermite_root`) where the slopes
    ``d_lo, d_hi`` at the ends are given (error ``O(hi⁴)``: two evaluations), else at the secant. It has
    converged when a Newton step is below ``rtol s``, or when a Newton step ``δ`` inside the bracket is
    below :data:`NEWTON_FINAL` ``s``: the point it gives is then within ``~|g''/(2g')| δ²`` of the root (quadratic
    convergence; ``dg/ds`` is the slope of the exact flow, that of the step differs by the step's own
    error, ``~rtol``), below ``rtol s`` without an evaluation more: ``g`` of a DOP853 step has a roundoff
    floor near ``1e-13 s``, below which a stricter test could only bisect."""
    lo = np.zeros_like(hi)
    with np.errstate(all="ignore"):
        if d_lo is not None and d_hi is not None:
            x = _hermite_root(hi, g_lo, g_hi, d_lo, d_hi)
        else:
            x = hi * g_lo / (g_lo - g_hi)
        x = np.clip(x, 1e-6 * hi, (1 - 1e-6) * hi)
        x = np.where(np.isfinite(x), x, 0.5 * hi)
    done = np.zeros(hi.size, dtype=bool)
    for _ in range(max_iter):
        o = np.flatnonzero(~done)
        if not o.size:
            break
        g, dg = fun(x[o], o)
        pos = g > 0
        lo[o[pos]] = x[o[pos]]
        hi[o[~pos]] = x[o[~pos]]
        with np.errstate(all="ignore"):
            step = g / dg
        new = x[o] - step
        ok = np.isfinite(new) & (new > lo[o]) & (new < hi[o])
        small = np.abs(step) <= rtol * np.abs(x[o])
        final = ok & ~small & (np.abs(step) <= NEWTON_FINAL * np.abs(x[o]))
        conv = (ok & small) | final | (g == 0)
        conv |= hi[o] - lo[o] <= 4 * np.finfo(float).eps * hi[o]
        x[o] = np.where(final, new, np.where(conv, x[o], np.where(ok, new, 0.5 * (lo[o] + hi[o]))))
        done[o[conv]] = True
    return x


def _land(eqs, md, idx, Rs, ys, fs, out, status, intervals, wrinkled_from):
    """Land on the clamp ``ρ = λpre`` (a Newton correction from the located point) and record the outputs."""
    lay, model = eqs.lay, eqs.model
    lam_clamp = model.prestretch
    d = (ys[1] - lam_clamp) / fs[1]
    Rc = Rs - d
    yc = ys - fs * d
    fc = eqs.rhs(md)(Rc, yc)
    fV, fQ, fPsi, _ = QUADRATURE_FACTORS
    out["R"][idx] = Rc
    out["p"][idx] = yc[lay.P]
    out["V"][idx] = fV * yc[3]
    out["Q"][idx] = fQ * yc[4]
    out["Psi"][idx] = fPsi * yc[5]
    out["z"][idx] = yc[6]
    if lay.derivatives:
        for a, first in (("l0", 7), ("phi", 12)):
            dR = -yc[first + 1] / fc[1]
            out[f"dR_d{a}"][idx] = dR
            out[f"dV_d{a}"][idx] = fV * (yc[first + 3] + fc[3] * dR)
            out[f"dQ_d{a}"][idx] = fQ * (yc[first + 4] + fc[4] * dR)
    status[idx] = sh.OK
    open_ = md == WRINKLED
    if open_:
        _band_end(eqs, idx, yc, fc)
    for _i, c in enumerate(idx):
        if open_:
            intervals[c].append((wrinkled_from[c], math.inf))
    return Rc


def _band_end(eqs, idx, y, f):
    """Record ``K/T̂11`` where the wrinkled bands of the columns ``idx`` end (at ``y``, ``f``)."""
    stiff = eqs.switching(WRINKLED, y, f)[5] + PULL_IN_TOLERANCE
    eqs.band_stiffness[idx] = np.minimum(eqs.band_stiffness[idx], stiff)


def _switch(eqs, md, idx, Rs, ys, fs, R, y, h, hc, mode, status, switches, wrinkled_from, intervals):
    """Switch the columns ``idx`` at ``(Rs, ys)`` to the other kind of segment; the sensitivities jump by
    the saltation (module docstring)."""
    lay, model = eqs.lay, eqs.model
    phi = ys[lay.P + 1]
    new = WRINKLED if md == TAUT else TAUT
    yn = ys.copy()
    if md == TAUT:  # at T̂2 = 0 the width is the hoop stretch itself
        yn[lay.W] = ys[1]
        _, T2, _, T12, _, _, T22 = model.tensions(ys[0], ys[1], phi)
        g_phi = model.wrinkle_aux(ys[0], ys[1], phi)[0]
        grad = (T12, T22)
    else:  # the gap closes: λ2 = ρ
        w, _ = _polish(model, ys[0], ys[lay.W], phi)
        _, _, dw_dl1, dw_dphi = model.wrinkle_aux(ys[0], w, phi)
        grad = (dw_dl1, -1.0)
        g_phi = dw_dphi
    if lay.derivatives:
        fn = eqs.rhs(new)(Rs, yn)
        denom = grad[0] * fs[0] + grad[1] * fs[1]
        for first, g_a in ((7, 0.0), (12, g_phi)):
            dtau = -(grad[0] * yn[first] + grad[1] * yn[first + 1] + g_a) / denom
            for r in range(5):
                yn[first + r] = yn[first + r] + (fs[r] - fn[r]) * dtau
    if md == WRINKLED:
        _band_end(eqs, idx, ys, fs)
    R[idx] = Rs
    y[:, idx] = yn
    h[idx] = np.maximum(hc, 1e-6 * Rs)  # a switch located at the very start of its step: never a zero step
    mode[idx] = new
    switches[idx] += 1
    status[idx] = np.where(switches[idx] > MAX_SWITCHES, sh.TOO_MANY_SWITCHES, -1)
    # a new segment whose own switching function falls at once cannot start: the meridian can neither go on
    # as it was nor change. Where the wrinkled side's stiffness K has (nearly) vanished this is its pull-in
    # (the observed case: the gap closes where T̂1ʷ has its minimum), else a degenerate switch
    f_new = eqs.rhs(new)(Rs, yn)
    _, dg_new, *_ = eqs.switching(new, yn, f_new)
    stuck = ~(dg_new > 0)
    if stuck.any():
        wr_y, wr_f = (ys, fs) if md == WRINKLED else (yn, f_new)
        stiff = eqs.switching(WRINKLED, wr_y, wr_f)[5] + PULL_IN_TOLERANCE
        code = np.where(stiff < 1e-3, sh.PULL_IN, sh.TOO_MANY_SWITCHES)
        status[idx[stuck]] = code[stuck]
    for i, c in enumerate(idx):
        if md == TAUT:
            wrinkled_from[c] = Rs[i]
        else:
            intervals[c].append((wrinkled_from[c], Rs[i]))


@dataclass(frozen=True)
class SegmentEquations:
    """The right-hand sides of :func:`shoot_relaxed`'s two kinds of segment, without sensitivities (from
    :func:`segment_equations`).

    Rows (one column per state): ``λ1``, ``λ2`` (taut; wrinkled: ``ρ``, the *geometric* hoop stretch), ``θ``,
    ``V̂/π``, ``Q̂/2π``, ``Ψ̂/2π``, ``ẑ``, then the natural width ``w`` (row :attr:`width_row`), the trial pressure
    ``p̂t`` and ``Φ̂``.
    """

    #: ``f(R̂, y) -> dy/dR̂`` of a taut segment (the membrane equations; ``w`` constant)
    taut: Callable[[np.ndarray, np.ndarray], np.ndarray]
    #: ``f(R̂, y) -> dy/dR̂`` of a hoop-wrinkled segment (``R̂T̂1`` constant, ``θ' = p̂t λ1 ρ/T̂1``; the width polished
    #: by Newton's method on ``T̂2(λ1, w) = 0`` at every evaluation, from the row ``w' = (dw/dλ1) λ1'``)
    wrinkled: Callable[[np.ndarray, np.ndarray], np.ndarray]
    #: ``switching(mode, y, f) -> (g, dg/dR̂)``: the switching function of a segment of ``mode`` (:data:`TAUT`:
    #: ``g = T̂2(λ1, λ2)``; :data:`WRINKLED`: ``g = w − ρ``, ``w`` polished) and its slope, at the nodes ``y`` with
    #: their right-hand sides ``f``; a segment switches where its ``g`` falls to zero
    switching: Callable[[int, np.ndarray, np.ndarray], tuple]
    #: index of the width row ``w``: set it to ``ρ`` where a segment turns wrinkled (``T̂2 = 0`` there)
    width_row: int
    #: number of rows
    rows: int


def segment_equations(model: MembraneModel) -> SegmentEquations:
    """The taut and hoop-wrinkled right-hand sides :func:`shoot_relaxed` integrates (numpy, all columns at once),
    without sensitivities: for integrating a relaxed meridian again between its known switches (the profile of
    a wrinkled state, :mod:`coexist.shapes`).

    Taut: the membrane equations (:meth:`~coexist.model.MembraneModel.rhs`). Hoop-wrinkled (docs/physics.md,
    section 10): ``λ1' = −T̂1/(R̂K)``, ``ρ' = (λ1 cos θ − ρ)/R̂``, ``θ' = p̂t λ1 ρ/T̂1``, ``K = T̂11 − T̂12²/T̂22``, the
    tensions at ``(λ1, w)``, ``w`` the natural width (``T̂2(λ1, w) = 0``), the quadratures ``V̂, ẑ`` with the
    geometric stretches and ``Q̂, Ψ̂`` with the material ones (:meth:`~coexist.model.MembraneModel.wrinkled_rhs`).

    Parameters
    ----------
    model : MembraneModel
        The membrane.

    Returns
    -------
    SegmentEquations
        Both right-hand sides, their switching functions and the rows' layout.
    """
    lay = _Layout(False)
    eqs = _Equations(model, lay)

    def switching(mode, y, f):
        g, dg, *_ = eqs.switching(mode, y, f)
        return g, dg

    return SegmentEquations(taut=eqs.taut, wrinkled=eqs.wrinkled, switching=switching, width_row=lay.W, rows=lay.rows)
