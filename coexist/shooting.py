"""Shooting from the pole to the clamp, for many pole stretches at once.

For a pole stretch ``λ0`` and voltage ``Φ̂`` the membrane equations are integrated from a series
start at the pole with a *trial* pressure ``p̂t`` until the hoop stretch returns to the clamp
value ``λ2 = λpre`` at some radius ``R*``. The equations are invariant under ``R → cR``,
``p → p/c`` (docs/physics.md), so this is the exact clamped solution of a membrane of radius ``R*``,
and the membrane of unit radius carries

``p̂ = p̂t R*``,  ``V̂ = V̂t / R*³``,  ``Q̂ = Q̂t / R*²``,  ``Ψ̂ = Ψ̂t / R*²``,  ``ẑ = ẑt / R*``.

No iteration on the pressure is needed: one integration gives one point of the curve. The last
step lands exactly on the clamp by taking ``λ2`` as the independent variable (Hénon's trick).
The trial pressure comes from a spherical-cap estimate, so that ``R* ≈ 1`` and the tolerances
mean the same thing for every state.
"""

from __future__ import annotations

import math
import sys
import time
from dataclasses import dataclass, field, replace

import numpy as np

from . import validation
from .errors import ModelRangeError, SceneError
from .model import QUADRATURE_FACTORS, MembraneModel, model_cache_key
from .numerics import cache
from .numerics import dop853 as _int
from .numerics.buffers import BufferedFunction
from .numerics.roots import bracketed_root
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
#: tension-field states (coexist.wrinkling): both tensions vanish; no natural width; too many switches
SLACK = 20
PULL_IN = 21
TOO_MANY_SWITCHES = 22
#: a curve's state left unsolved: it lies beyond a state without equilibrium that ends the curve's first run of valid
#: states (coexist.patterned: never part of a curve, which is that run)
BEYOND_RUN = 23
#: a patterned zone's pole stretch below that of its flat (unpressurised) state (coexist.patterned): no equilibrium
BELOW_FLAT = 24
#: the search of the voltage at a pressure (coexist.curves.voltage_at_pressure) used up its iterations, its last state
#: valid but not at the pressure: not a failure of the physics (more iterations may find it)
VOLTAGE_ITERATIONS = 25

#: a short tag and a sentence for every way a state can fail
REASONS = {
    OK: ("ok", "converged"),
    WRINKLED_AT_POLE: (
        "wrinkling",
        "the tension at the pole is not positive: the membrane wrinkles (membrane theory does not hold)",
    ),
    WRINKLED: ("wrinkling", "a tension turns negative between pole and clamp: the membrane wrinkles"),
    LOCKED: ("gent_locking", "the Gent chains lock (I1 - 3 reaches Jlim, or comes within 1e-9 of it)"),
    LOST_ELLIPTICITY: (
        "electromechanical_instability",
        "dT1/dλ1 vanishes: the membrane loses stability to thinning (electromechanical instability)",
    ),
    NO_CLAMP: (
        "no_equilibrium",
        "the membrane does not return to the clamp stretch within a radius "
        "of max_radius_factor (default 1000) times its estimated size: no equilibrium at this pole "
        "stretch within that search",
    ),
    STEP_LIMIT: ("solver_budget", "the integration used up its step budget (SolverSettings.max_steps)"),
    NOT_FINITE: ("no_equilibrium", "the integration produced non-finite values"),
    FOLDED_BACK: ("no_equilibrium", "the meridian turns back on itself (θ > π)"),
    NO_VOLTAGE: (
        "no_equilibrium",
        "no voltage Φ̂ ≥ 0 holds this pole stretch at the requested pressure (at zero voltage it is already below "
        "it, or it stays above it up to the voltage where the states fail, e.g. the pole wrinkles)",
    ),
    BELOW_RESOLUTION: (
        "out_of_range",
        "the pole stretch is within 5e-9 of the flat membrane: its deviation "
        "from the clamp stretch is below what double precision resolves",
    ),
    SLACK: (
        "slack",
        "the meridional tension of a wrinkled membrane turns non-positive: it goes slack "
        "(tension-field theory carries no load there)",
    ),
    PULL_IN: (
        "electromechanical_instability",
        "a wrinkled segment has no natural width, or dT1/dλ1 along it vanishes: the wrinkled membrane "
        "loses stability to thinning (pull-in)",
    ),
    TOO_MANY_SWITCHES: (
        "no_equilibrium",
        "the meridian switches between taut and wrinkled more often than coexist.wrinkling.MAX_SWITCHES",
    ),
    BEYOND_RUN: (
        "not_solved",
        "not solved: it lies beyond a pole stretch without a valid state that ends the curve's first run of states",
    ),
    BELOW_FLAT: (
        "no_equilibrium",
        "no pressure holds a pole stretch this small: unpressurised, the zone's regions already stretch its pole "
        "region further (e.g. a stiffer passive annulus pulling an electrode disc open), and inflation stretches it "
        "more (the clamp stretch is reached before the rim even where the zone is flat)",
    ),
    VOLTAGE_ITERATIONS: (
        "solver_budget",
        "the search of the voltage that holds the requested pressure used up its iterations before meeting it "
        "(voltage_at_pressure's iterations): not a failure of the physics",
    ),
}


class _NumpyOps:
    """The few operations :func:`_hermite_min` needs, for numpy arrays."""

    fmin, fmax = staticmethod(np.minimum), staticmethod(np.maximum)
    sqrt, fabs = staticmethod(np.sqrt), staticmethod(np.abs)

    @staticmethod
    def where(cond, a, b):
        return np.where(cond, a, b)

    @staticmethod
    def both(a, b):
        return a & b


class _CasadiOps:
    """The same operations for CasADi expressions (imported only when an attempt function is built)."""

    def __init__(self):
        import casadi as ca

        self.fmin, self.fmax, self.sqrt, self.fabs, self.where = ca.fmin, ca.fmax, ca.sqrt, ca.fabs, ca.if_else

    @staticmethod
    def both(a, b):
        return a * b


def _hermite_min(ops, xa, ya, da, xb, yb, db):
    """Smallest value on ``[xa, xb]`` of the cubic Hermite interpolant with values ``ya, yb`` and slopes
    ``da, db`` at the ends: the ends, and the interior stationary points that are minima. In ``s`` on
    ``[0, 1]``, ``p'(s) = A s² + B s + C`` with the coefficients below. Written once for numpy
    (:func:`hermite_minimum`) and for CasADi (the attempt function), through ``ops``."""
    h = xb - xa
    A = 6 * (ya - yb) + 3 * h * (da + db)
    B = -6 * (ya - yb) - 4 * h * da - 2 * h * db
    C = h * da
    disc = B * B - 4 * A * C
    sq = ops.sqrt(ops.fmax(disc, 0.0))
    flat = ops.fabs(A) <= 1e-300
    best = ops.fmin(ya, yb)
    for sgn in (-1.0, 1.0):
        # a vanishing A leaves the linear root -C/B (the guards keep both branches finite)
        s = ops.where(flat, -C / (B + (B == 0)), (-B + sgn * sq) / (2 * A + flat))
        ok = ops.both(ops.both(disc >= 0, s > 0), s < 1)
        s2, s3 = s * s, s * s * s
        p = ya * (2 * s3 - 3 * s2 + 1) + h * da * (s3 - 2 * s2 + s) + yb * (-2 * s3 + 3 * s2) + h * db * (s3 - s2)
        best = ops.where(ops.both(ok, p < best), p, best)
    return best


def hermite_minimum(xa, ya, da, xb, yb, db):
    """:func:`_hermite_min` on numpy arrays (vectorised): refines a tension's minimum between two
    integration nodes (error O(h⁴)).

    Parameters
    ----------
    xa, xb : array_like
        The two nodes (``R̂``), ``xa < xb``.
    ya, yb : array_like
        Values at the nodes (e.g. ``T̂1``).
    da, db : array_like
        Slopes ``dy/dx`` at the nodes (e.g. ``dT̂1/dR̂``).

    Returns
    -------
    ndarray
        Smallest value of the cubic Hermite interpolant on ``[xa, xb]``, of the broadcast shape of
        the inputs (never above ``min(ya, yb)``).
    """
    with np.errstate(all="ignore"):
        return _hermite_min(_NumpyOps, *(np.asarray(v, dtype=float) for v in (xa, ya, da, xb, yb, db)))


def first_valid_run(ok) -> slice:
    """The first contiguous run of True in ``ok`` (which must hold at least one True).

    Parameters
    ----------
    ok : array_like of bool, 1-D
        Validity of each state along a grid.

    Returns
    -------
    slice
        ``slice(first, stop)`` of the run (an empty slice if ``ok`` holds no True).

    Examples
    --------
    >>> first_valid_run([False, True, True, False, True])
    slice(1, 3, None)
    """
    ok = np.asarray(ok, dtype=bool)
    first = int(np.argmax(ok))
    rest = np.flatnonzero(~ok[first:])
    return slice(first, first + int(rest[0]) if rest.size else ok.size)


def reason_tag(code: int) -> str:
    """Short machine-readable tag of a status code (e.g. ``"wrinkling"``), as in :data:`REASONS`.

    Parameters
    ----------
    code : int
        ``OK`` or a failure code of :data:`REASONS`.

    Returns
    -------
    str
        The tag; it is the ``reason`` of the :class:`ModelRangeError` raised for that failure.
    """
    return REASONS[int(code)][0]


def reason_text(code: int) -> str:
    """One-sentence explanation of a status code, as in :data:`REASONS`.

    Parameters
    ----------
    code : int
        ``OK`` or a failure code of :data:`REASONS`.

    Returns
    -------
    str
        The sentence.
    """
    return REASONS[int(code)][1]


@dataclass
class StateDerivatives:
    """Exact first derivatives of the clamped states, from the variational equations.

    ``dp_dl0 = ∂p̂/∂λ0|Φ̂``, ``dv_dl0``, ``dq_dl0`` and ``dp_dphi = ∂p̂/∂Φ̂|λ0``, ``dv_dphi``,
    ``dq_dphi``; those of ``Ψ̂`` follow from ``dΨ̂ = p̂ dV̂ − Q̂ dΦ̂``: ``∂Ψ̂/∂λ0 = p̂ ∂V̂/∂λ0`` and
    ``∂Ψ̂/∂Φ̂ = p̂ ∂V̂/∂Φ̂ − Q̂``.
    """

    dp_dl0: np.ndarray
    dv_dl0: np.ndarray
    dq_dl0: np.ndarray
    dp_dphi: np.ndarray
    dv_dphi: np.ndarray
    dq_dphi: np.ndarray

    @staticmethod
    def of(states: MembraneStates) -> StateDerivatives:
        """The derivatives of ``states``, which must have been shot with ``derivatives=True``.

        Parameters
        ----------
        states : MembraneStates
            States from :func:`solve_states`.

        Returns
        -------
        StateDerivatives
            ``states.derivatives``.

        Raises
        ------
        ValueError
            If the states were shot without derivatives.
        """
        if states.derivatives is None:
            raise ValueError("these states were shot without derivatives (solve_states(..., derivatives=True))")
        return states.derivatives

    def take(self, index) -> StateDerivatives:
        """The derivatives of a subset of the states.

        Parameters
        ----------
        index : int, slice or array_like
            Any numpy index into the state axis (a slice, integer or boolean array).

        Returns
        -------
        StateDerivatives
            Every field indexed with ``index``.
        """
        return StateDerivatives(**{k: v[index] for k, v in self.__dict__.items()})


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
        integration (its true clamp radius is unknown when it fails); ``inf`` when ``OK`` (it never fails).
    steps : ndarray of int
        Integration steps taken per state (a diagnostic of cost).
    shapes : list or None
        With ``shape=True``: per state an array ``(R̂, r̂, ẑ)`` of the meridian.
    derivatives : StateDerivatives or None
        With ``derivatives=True``: exact first derivatives to ``λ0`` and ``Φ̂``.
    wrinkled_radii : list or None
        For a tension-field model (``wrinkling="tension-field"``): per state the hoop-wrinkled intervals
        ``(R̂start, R̂end)`` of the unit membrane (empty when taut); None for a model that refuses
        wrinkling. A wrinkled state's ``min_tension`` is 0 (its hoop tension vanishes there).
    wrinkled_stiffness : ndarray or None
        For a tension-field model: per state ``K/T̂11`` at the outer ends of its wrinkled bands (the
        smallest; ``K = dT̂1ʷ/dλ1``, ``inf`` when taut, NaN when failed). It falls to zero where a band
        pulls in (docs/physics.md, section 10); None for a model that refuses wrinkling.
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
    derivatives: StateDerivatives | None = field(default=None, repr=False)
    wrinkled_radii: list | None = field(default=None, repr=False)
    wrinkled_stiffness: np.ndarray | None = field(default=None, repr=False)

    @property
    def wrinkled_fraction(self) -> np.ndarray:
        """Reference area fraction of the hoop-wrinkled region, ``Σ (R̂end² − R̂start²)`` per state (0 for a
        taut state; NaN for a failed one, and for every state of a model that refuses wrinkling)."""
        n = self.status.size
        if self.wrinkled_radii is None:
            return np.full(n, np.nan)
        frac = np.array([sum(b * b - a * a for a, b in w) for w in self.wrinkled_radii], dtype=float)
        return np.where(self.ok, frac, np.nan)

    @property
    def ok(self) -> np.ndarray:
        """Boolean array: True where ``status`` is ``OK`` (only those entries hold a state)."""
        return self.status == OK

    def require_ok(self) -> MembraneStates:
        """Raise :class:`ModelRangeError` naming the first failed input, else return self.

        Returns
        -------
        MembraneStates
            ``self``, when every state is ``OK``.

        Raises
        ------
        ModelRangeError
            At the first failed state, with its pole stretch, voltage and reason
            (:func:`reason_text`; ``reason`` is :func:`reason_tag`).
        """
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
    ``λ0 → 1``; vectorised), kept inside the bracket where ``sin α − α/λ0`` changes sign (bisection when a
    step would leave it). Only an estimate is needed (it scales the trial pressure); written out here
    rather than through the general :func:`~coexist.numerics.roots.newton` because every shooting calls it
    (that cost 0.3 ms of a 2 ms small batch)."""
    target = 1.0 / np.asarray(l0, dtype=float)
    if target.ndim == 1 and target.size <= _SCALAR_CAP_ANGLES:
        return np.array([_cap_angle_one(float(x)) for x in target])
    a = np.minimum(np.sqrt(6.0 * (1.0 - target)), 3.0)
    lo = np.full_like(a, 1e-300)
    hi = np.full_like(a, math.pi * (1 - 1e-12))
    for _ in range(40):
        g = np.sin(a) - target * a  # positive below the root
        lo = np.where(g > 0, a, lo)
        hi = np.where(g > 0, hi, a)
        with np.errstate(divide="ignore", invalid="ignore"):
            new = a - g / (np.cos(a) - target)
        new = np.where(np.isfinite(new) & (new >= lo) & (new <= hi), new, 0.5 * (lo + hi))
        done = np.abs(new - a) <= 1e-14 * np.abs(new)
        a = new
        if done.all():
            break
    return a


#: batches up to this size take the cap angle element by element in floats (numpy's per-call cost dominates there)
_SCALAR_CAP_ANGLES = 16


def _cap_angle_one(target: float) -> float:
    """:func:`_cap_angle` of one pole stretch ``1/target``, in floats: the same safeguarded Newton iteration, which
    stops when this state has converged (the vectorised one iterates until all have: a trial pressure, and so a
    state, may differ at the rounding level between a batch of up to :data:`_SCALAR_CAP_ANGLES` and a larger one;
    the cap angle only scales the trial, so the states agree to the shooting's tolerance)."""
    a = min(math.sqrt(6.0 * (1.0 - target)), 3.0)
    lo, hi = 1e-300, math.pi * (1 - 1e-12)
    for _ in range(40):
        g = math.sin(a) - target * a  # positive below the root
        if g > 0:
            lo = a
        else:
            hi = a
        slope = math.cos(a) - target
        new = a - g / slope if slope != 0 else math.nan
        if not (math.isfinite(new) and lo <= new <= hi):
            new = 0.5 * (lo + hi)
        done = abs(new - a) <= 1e-14 * abs(new)
        a = new
        if done:
            break
    return a


def trial_pressure(model: MembraneModel, l0, phi, pole_tension=None):
    """Spherical-cap estimate of ``p̂`` at pole stretch ``λ0``: ``p̂ ≈ 2 T̂1(λ0, λ0) α / λ0²``.

    Only used to scale the trial integration so that it reaches the clamp near ``R̂ = 1``.

    ``α`` is the half-angle of a spherical cap whose arc is ``λ0/λpre`` times its chord:
    ``sin α / α = λpre/λ0``.

    Parameters
    ----------
    model : MembraneModel
        The membrane (its pole tension ``T̂1(λ0, λ0)`` and prestretch ``λpre``).
    l0 : ndarray
        Pole stretches ``λ0 > λpre``.
    phi : float or ndarray
        Normalised voltages ``Φ̂``, broadcast against ``l0``.
    pole_tension : ndarray, optional
        ``T̂1(λ0, λ0)`` if the caller has it already (else computed here).

    Returns
    -------
    ndarray
        The trial pressures ``p̂t``.
    """
    T0 = model.pole(l0, phi)[0] if pole_tension is None else pole_tension
    stretch = l0 / model.prestretch
    alpha = _cap_angle(np.maximum(stretch, 1 + 1e-12))
    return 2 * T0 * alpha / l0**2


def _check_inputs(model, l0, phi):
    """What :func:`checked_state_inputs` checks beyond ``validation.real_array`` (finite ``λ0``, finite ``Φ̂ ≥ 0``):
    ``λ0 > λpre``, and no voltage on a model without electrostatics."""
    below = l0 <= model.prestretch
    if below.any():
        raise SceneError(
            f"pole stretch must be finite and exceed the prestretch {model.prestretch:g}, got {l0[below][0]:g}",
            "pole_stretch",
        )
    if not model.has_voltage and phi.any():
        raise SceneError("this model has no electrostatics: Φ̂ must be 0", "phi_hat")


#: a tension's minimum between two integration nodes is located exactly (the step re-taken to where its
#: slope vanishes) when its interpolated estimate is below this: where the onset of wrinkling is decided
REFINE_MINIMUM_BELOW = 0.02

#: batches of at most this many live trajectories are integrated by the CasADi attempt function in CasADi's
#: virtual machine, larger ones by numpy (measured crossover on this machine: ~25)
CASADI_BATCH_LIMIT = 24
#: columns per call of an attempt function compiled to machine code: it takes a batch of any size, in chunks of
#: this many (so the functions mapped over the columns, kept per model and batch size, stay few and small); at
#: 200-5000 trajectories it costs 25-28 µs each, against 75-150 µs by numpy (measured on this machine). Its
#: step function (:meth:`_Integrators.stepper`) serves batches up to this size, numpy the larger ones
COMPILED_BATCH_LIMIT = 256
#: uses of a model's attempt function in one process after which it is compiled (once per machine)
COMPILE_AFTER = 12
#: while a model's library is compiled in the background, the cache is looked at again every this many uses ...
RECHECK_EVERY = 16
#: ... or at the first use this many seconds after the last look: uses come fast in small batches and slowly in large
#: ones (a patterned zone's derivative passes in numpy, ~1 s each, until the library is loaded: a single patterned
#: zone's first `coexist coexistence` took 105 s, 100 of them after its library was built, against 11 s compiling in
#: the foreground; the looks every 16 uses had all come in its first half second)
RECHECK_SECONDS = 0.25


def _recheck_due(entry: dict, uses: int) -> bool:
    """Whether a library compiling in the background is looked for in the cache at this use (:data:`RECHECK_EVERY`,
    :data:`RECHECK_SECONDS`); notes the time of the look in ``entry``."""
    now = time.monotonic()
    if uses % RECHECK_EVERY == 0 or now - entry.get("looked", 0.0) >= RECHECK_SECONDS:
        entry["looked"] = now
        return True
    return False


#: times a process starts a library's background compilation again after finding the lock another's
RESTARTS = 3


def _may_start_again(entry: dict) -> bool:
    """Whether a library still missing from the cache may start its own background compilation now: the lock is
    free (the compilation that held it was another library's) and it has not been started :data:`RESTARTS` times
    in this process (counted in ``entry["starts"]``)."""
    from .numerics.compiled import compiling

    if compiling() or entry.get("starts", 0) >= RESTARTS:
        return False
    entry["starts"] = entry.get("starts", 0) + 1
    return True


def _compiling_elsewhere() -> bool:
    """Whether the last :func:`~coexist.numerics.compiled.compiled` left the library to a compilation in the
    background (this process's or another's): it is loaded from the cache later."""
    from .numerics.compiled import STATUS

    return STATUS["last"] in ("compiling in the background", "another compilation is running")


class _Integrators:
    """The right-hand sides a model is shot with, numpy and CasADi, built once per model on first use.

    ``radius``: the membrane equations in ``R̂`` (rows λ1, λ2, θ, V̂/π, Q̂/2π, Ψ̂/2π, ẑ, p̂t, Φ̂);
    ``radius_sens``: the same with the variational equations (rows 7–16: ∂(λ1, λ2, θ, V̂/π, Q̂/2π) to
    λ0, then to Φ̂; p̂t and Φ̂ in rows 17 and 18); ``hoop``: the last step, with ``λ2`` as the
    independent variable (rows R̂, λ1, θ, V̂/π, Q̂/2π, Ψ̂/2π, ẑ, p̂t, Φ̂).
    """

    def __init__(self, model: MembraneModel, compile_after: int = COMPILE_AFTER):
        self.model = model
        self.compile_after = compile_after
        self._casadi: dict = {}
        self._keys: dict = {}

    # numpy right-hand sides (large batches)
    def radius(self, R, y):
        out = np.empty_like(y)
        out[7:] = 0.0
        return self.model.rhs_into(R, y[0], y[1], y[2], y[7], y[8], out)

    def radius_sens(self, R, y):
        out = np.empty_like(y)
        out[17:] = 0.0
        return self.model.rhs_sensitivities_into(R, y[0], y[1], y[2], y[17], y[18], y[7:10], y[12:15], out)

    def hoop(self, l2, z):
        d = np.empty((7, l2.size))
        d[:] = self.model.rhs(z[0], z[1], l2, z[2], z[7], z[8])
        inv = 1.0 / d[1]
        out = np.zeros_like(z)
        out[0] = inv
        out[1] = d[0] * inv
        out[2:7] = d[2:] * inv
        return out

    def key(self, kind: str) -> str | None:
        """:func:`_attempts_key` of this model and ``kind``, computed once (it hashes the model's description:
        some 50 µs, on every small shooting call before it was kept)."""
        if kind not in self._keys:
            self._keys[kind] = _attempts_key(self.model, kind)
        return self._keys[kind]

    def attempts(self, kind: str):
        """The attempt function (:func:`attempt_function`) for ``kind``: CasADi's virtual machine at first,
        compiled machine code (:mod:`coexist.numerics.compiled`) from the :data:`COMPILE_AFTER`-th use in a process
        on (a model used that often is worth the one-time compilation; it is cached on disk)."""
        rows = {"radius": 9, "radius_sens": 19}[kind]
        return self.attempts_of(kind, lambda: attempt_function(self.model, kind, rows))

    def attempts_of(self, kind: str, make):
        """The attempt function ``make()`` (a CasADi function named ``attempts_{kind}``), built once per model
        and ``kind``, cached on disk and compiled like :meth:`attempts`; returns its entry (``fun``, ``maps``,
        ``fast``)."""
        entry = self._casadi.get(("attempts", kind))
        if entry is not None and entry["compiled"]:  # built and compiled (or tried): nothing left to do but count
            entry["uses"] += 1
            return entry
        from .numerics.compiled import compiled, load_cached

        entry = self._casadi.setdefault(("attempts", kind), {"fun": None, "uses": 0, "compiled": False, "maps": {}})
        name, key = f"coexist_attempts_{kind}", self.key(kind)
        if entry["fun"] is None:
            fast = None if key is None else load_cached(name, key, f"attempts_{kind}")
            if fast is not None:  # compiled by an earlier process: no symbolic graph to build at all
                entry["fun"], entry["fast"], entry["compiled"] = fast, True, True
            else:  # the CasADi graph: deserialised if an earlier process built it, else built (and kept)
                entry["fun"] = make() if key is None else cache.casadi_function(name, key, make)
        entry["uses"] += 1
        if not entry["compiled"] and entry["uses"] >= self.compile_after:
            if entry.get("pending"):  # compiling in the background: loaded once it is in the cache
                fast = None
                if key is not None and _recheck_due(entry, entry["uses"]):
                    fast = load_cached(name, key, f"attempts_{kind}")
                    if fast is None and _may_start_again(entry):  # the lock was another library's
                        fast = compiled(entry["fun"], name, key=key)
                entry["compiled"] = fast is not None
            else:
                fast = compiled(entry["fun"], name, key=key)
                entry["pending"] = fast is None and key is not None and _compiling_elsewhere()
                entry["compiled"] = not entry["pending"]  # tried (whether it worked or not), or waited for
            if fast is not None:
                entry["fun"], entry["maps"], entry["fast"] = fast, {}, True
        return entry

    def small_batch_limit(self, kind: str, m: int) -> int:
        """Largest batch the attempt function takes: any, once compiled (:func:`run_attempts` feeds it
        :data:`COMPILED_BATCH_LIMIT` columns at a time); :data:`CASADI_BATCH_LIMIT` in CasADi's virtual
        machine, where numpy is faster for larger batches."""
        entry = self._casadi.get(("attempts", kind))
        if entry is None:
            entry = self.attempts(kind)  # built now: it may already be compiled on this machine
            entry["uses"] -= 1
        return sys.maxsize if entry.get("fast") else CASADI_BATCH_LIMIT

    def stepper(self, kind: str, n: int):
        """A stepper for ``n`` trajectories of the right-hand side ``kind``."""
        rows = {"radius": 9, "radius_sens": 19, "hoop": 9}[kind]
        return self.stepper_of(kind, n, rows, getattr(self, kind), lambda: self._casadi_rhs(kind), medium=True)

    def stepper_of(self, kind: str, n: int, rows: int, fun, casadi_rhs, medium: bool = False):
        """A stepper for ``n`` trajectories of ``rows`` rows: numpy's ``fun(t, y)`` for a large batch, else the
        whole DOP853 step of the CasADi function ``casadi_rhs()`` (built once per model and ``kind``, cached
        on disk, compiled after :data:`COMPILE_AFTER` uses in a process). ``medium``: once compiled, the
        step function also serves batches up to :data:`COMPILED_BATCH_LIMIT` (where it beats numpy)."""
        limit = COMPILED_BATCH_LIMIT if medium else CASADI_BATCH_LIMIT
        if n > limit:
            return _int.NumpyStepper(fun)
        st = self._casadi.get(kind)
        if st is not None and self._casadi[("stepper compiled", kind)]:  # compiled: its uses no longer matter
            return st
        from .numerics.compiled import compiled, load_cached

        name, key = f"coexist_dop853_{kind}", self.key(kind)
        if st is None:
            # compiled by an earlier process, else CasADi's graph (deserialised, or built and kept)
            step = None if key is None else load_cached(name, key, f"dop853_{kind}")
            self._casadi[("stepper uses", kind)] = self.compile_after if step is not None else 0
            self._casadi[("stepper compiled", kind)] = step is not None

            def make():
                return _int.casadi_step_function(casadi_rhs(), rows, f"dop853_{kind}")

            if step is None:
                step = make() if key is None else cache.casadi_function(name, key, make)
            st = self._casadi[kind] = _int.CasadiStepper(step, fun, rows)
        uses = self._casadi[("stepper uses", kind)] = self._casadi[("stepper uses", kind)] + 1
        fast = None
        if uses == self.compile_after:  # used often in this process: worth compiling once per machine
            fast = compiled(st._step, name, key=key)
            self._casadi[("stepper pending", kind)] = fast is None and key is not None and _compiling_elsewhere()
        elif (
            uses > self.compile_after
            and self._casadi.get(("stepper pending", kind))
            and not self._casadi[("stepper compiled", kind)]
            and key is not None
            and _recheck_due(self._casadi.setdefault(("stepper looked", kind), {}), uses)
        ):  # compiling in the background: loaded once it is in the cache
            fast = load_cached(name, key, f"dop853_{kind}")
            tries = self._casadi.setdefault(("stepper starts", kind), {})
            if fast is None and _may_start_again(tries):  # the lock was another library's
                fast = compiled(st._step, name, key=key)
        if fast is not None:
            st = self._casadi[kind] = _int.CasadiStepper(fast, fun, rows)
            self._casadi[("stepper compiled", kind)] = True
            self._casadi[("stepper pending", kind)] = False
        if n > CASADI_BATCH_LIMIT and not self._casadi[("stepper compiled", kind)]:
            return _int.NumpyStepper(fun)  # the virtual machine loses to numpy here
        return st

    def _casadi_rhs(self, kind):
        import casadi as ca

        f = self.model.casadi_functions
        t = ca.SX.sym("t")
        if kind == "radius":
            y = ca.SX.sym("y", 9)
            d = f["rhs"](t, y[0], y[1], y[2], y[7], y[8])
            return ca.Function("rhs", [t, y], [ca.vertcat(*d, 0, 0)])
        if kind == "radius_sens":
            y = ca.SX.sym("y", 19)
            d = f["rhs_sens"](t, y[0], y[1], y[2], y[17], y[18], y[7], y[8], y[9], y[12], y[13], y[14])
            return ca.Function("rhs", [t, y], [ca.vertcat(*d, 0, 0)])
        z = ca.SX.sym("z", 9)
        d = f["rhs"](z[0], z[1], t, z[2], z[7], z[8])
        inv = 1 / d[1]
        return ca.Function(
            "rhs",
            [t, z],
            [ca.vertcat(inv, d[0] * inv, d[2] * inv, d[3] * inv, d[4] * inv, d[5] * inv, d[6] * inv, 0, 0)],
        )


#: attempts (trial steps) per call of the CasADi attempt function
ATTEMPTS_PER_CALL = 8
#: layout of the packed per-trajectory state of the attempt function (then y, f, atol, candidate y)
_HEAD = (
    "t",
    "h",
    "t_end",
    "rtol",
    "status",
    "steps",
    "max_steps",
    "formal",
    "Ra",
    "T1a",
    "T2a",
    "d1a",
    "d2a",
    "minT",
    "maxE",
    "failR",
    "cand_est",
    "cand_Ra",
    "cand_h",
    "cand_da",
    "cand_db",
    "cand_k",
)
_H = {k: i for i, k in enumerate(_HEAD)}


def attempt_step(step, g: dict, y, atol, R: int):
    """One DOP853 attempt of an attempt function, in CasADi: the step of size ``min(h, t_end − t)`` by ``step``
    (:func:`coexist.numerics.dop853.casadi_step_function`), its blended error norm, acceptance (finite and
    error ≤ 1, only while ``status`` is 0) and the factor of the next step size, as
    :func:`coexist.numerics.dop853.integrate` does them.

    Parameters
    ----------
    step : casadi.Function
        The whole DOP853 step ``(t, h, y) -> (y_new, f_new, e5, e3)`` stacked.
    g : dict
        The packed state's scalars (``t``, ``h``, ``t_end``, ``rtol``, ``status``) as CasADi expressions.
    y, atol : casadi.SX
        The state and its absolute tolerances (``R`` rows).
    R : int
        Rows of the state.

    Returns
    -------
    tuple
        ``(hs, last, y_new, f_new, accepted, factor, t_new)``: the step taken, whether it ends the range, the
        new state and its derivative, acceptance, the step-size factor and the new independent variable.
    """
    import casadi as ca

    t, h = g["t"], g["h"]
    span = g["t_end"] - t
    last = h >= span
    hs = ca.if_else(last, span, h)
    out = step(t, hs, y)
    y_new, f_new, e5, e3 = out[:R], out[R : 2 * R], out[2 * R : 3 * R], out[3 * R : 4 * R]
    scale = atol + ca.fmax(ca.fabs(y), ca.fabs(y_new)) * g["rtol"]
    s5 = ca.sumsqr(e5 / scale)
    s3 = ca.sumsqr(e3 / scale)
    den = s5 + 0.01 * s3
    err = ca.fabs(hs) * s5 / ca.sqrt(ca.if_else(den > 0, den, 1) * R)
    total = ca.sum1(y_new) + ca.sum1(f_new)
    finite = (total == total) * (ca.fabs(total) < 1e300)
    accepted = (g["status"] == 0) * finite * (err <= 1)
    grow = 0.9 * ca.if_else(err > 0, err, 1) ** (-1.0 / 8)
    factor = ca.if_else(err == 0, 10, ca.fmin(ca.fmax(grow, 0.2), 10))
    factor = ca.if_else(accepted, factor, ca.fmin(1, factor))
    factor = ca.if_else(finite, factor, 0.25)
    t_new = ca.if_else(last, g["t_end"], t + hs)
    return hs, last, y_new, f_new, accepted, factor, t_new


def attempt_function(model: MembraneModel, kind: str, rows: int, K: int = ATTEMPTS_PER_CALL):
    """``K`` DOP853 attempts of one trajectory as one CasADi function of its packed state.

    One attempt is what :func:`coexist.numerics.dop853.integrate` does per step, with the checks of
    :func:`_shoot`: the step (stages and error estimate), its acceptance and the new step size; at the
    new node the tensions and their slopes dT/dR, the crossing of the clamp stretch (the step is then
    discarded and the trajectory stops), the failures (a node tension not positive, Gent locking, loss
    of ellipticity, a meridian folding back), the smallest tension and largest field so far, and, where
    the cubic Hermite estimate of a tension's minimum between the last two nodes comes below
    :data:`REFINE_MINIMUM_BELOW`, the step that holds it (the caller locates that minimum exactly).
    A step that fails leaves the trajectory at the node it started from, with that step's size in ``h``
    (the failure's radius in ``failR``). A finished trajectory (status ≠ 0) passes through unchanged.

    Parameters
    ----------
    model : MembraneModel
        The membrane whose equations are integrated.
    kind : {"radius", "radius_sens"}
        The right-hand side: the membrane equations in ``R̂``, or the same with the variational
        equations (see ``_Integrators``).
    rows : int
        Rows of the integrated state: 9 for ``radius``, 19 for ``radius_sens``.
    K : int
        Attempts per call (:data:`ATTEMPTS_PER_CALL`).

    Returns
    -------
    casadi.Function
        Maps one packed state, a column of ``len(_HEAD) + 4 rows`` (the scalars of ``_HEAD``: time,
        step, status, smallest tension, ...; then ``y``, its derivative ``f``, ``atol`` and the ``y`` of
        the step holding a tension's minimum), to the packed state after ``K`` attempts.
    """
    import casadi as ca

    fns = _integrators(model)
    rhs = fns._casadi_rhs(kind)
    step = _int.casadi_step_function(rhs, rows, f"dop853_{kind}")
    aux = model.casadi_functions["aux"]
    ops = _CasadiOps()
    R = rows
    n = len(_HEAD) + 4 * R
    x = ca.SX.sym("x", n)
    g = {k: x[i] for k, i in _H.items()}
    o = len(_HEAD)
    y, f, atol, cy = x[o : o + R], x[o + R : o + 2 * R], x[o + 2 * R : o + 3 * R], x[o + 3 * R : o + 4 * R]
    t, h = g["t"], g["h"]
    # the first attempt of a trajectory computes the derivative at its start (the caller leaves it unset)
    f = ca.if_else(g["steps"] == 0, rhs(t, y), f)
    active = g["status"] == 0
    hs, last, y_new, f_new, accepted, factor, t_new = attempt_step(step, g, y, atol, R)
    P = R - 2
    T1, T2, T11, T12, margin, E, T22 = aux(y_new[0], y_new[1], y_new[P + 1])
    d1 = T11 * f_new[0] + T12 * f_new[1]
    d2 = T12 * f_new[0] + T22 * f_new[1]
    crossed = y_new[1] <= model.prestretch
    node_min = ca.fmin(T1, T2)
    inf = ca.inf
    ests = []
    for k, (Ta, da, T, d) in enumerate(((g["T1a"], g["d1a"], T1, d1), (g["T2a"], g["d2a"], T2, d2)), start=1):
        interior = (da < 0) * (d > 0)
        e = _hermite_min(ops, g["Ra"], Ta, da, t_new, T, d)
        ests.append((k, ca.if_else(interior * (e < ca.fmin(Ta, T)), e, inf), da, d))
    e_min = ca.fmin(ests[0][1], ests[1][1])
    near = e_min < REFINE_MINIMUM_BELOW
    # the smallest tension so far: nodes and the estimates not near zero (those are located exactly later)
    step_min = ca.fmin(node_min, ca.if_else(near, inf, e_min))
    certain = ca.if_else(g["formal"] > 0, T1 <= 0, node_min <= 0)
    code = ca.if_else(certain, WRINKLED, 0)
    code = ca.if_else((code == 0) * (margin <= 0), LOCKED, code)
    code = ca.if_else((code == 0) * (T11 <= 0), LOST_ELLIPTICITY, code)
    code = ca.if_else((code == 0) * (ca.fabs(y_new[2]) > math.pi), FOLDED_BACK, code)
    code = ca.if_else(crossed, 0, code)
    move = accepted * (1 - crossed)
    status = g["status"]
    status = ca.if_else(accepted * crossed, _int.CROSSED, status)
    status = ca.if_else(move * (code != 0), code, status)
    status = ca.if_else(move * last * (code == 0), _int.REACHED_END, status)
    steps = g["steps"] + active
    status = ca.if_else((status == 0) * (steps >= g["max_steps"]), _int.STEP_LIMIT, status)
    # a step that fails stops the trajectory at the node it started from (with the step's size in h): the
    # last node the shooting vouches for, where coexist.wrinkling restarts a wrinkled state
    keep = move * (code == 0)
    better = keep * near * (e_min < g["cand_est"])
    k_best = ca.if_else(ests[0][1] <= ests[1][1], 1, 2)
    da_best = ca.if_else(k_best == 1, ests[0][2], ests[1][2])
    db_best = ca.if_else(k_best == 1, ests[0][3], ests[1][3])
    new = {
        "t": ca.if_else(keep, t_new, t),
        "h": ca.if_else(move * (code != 0), hs, ca.if_else(active, hs * factor, h)),
        "t_end": g["t_end"],
        "rtol": g["rtol"],
        "status": status,
        "steps": steps,
        "max_steps": g["max_steps"],
        "formal": g["formal"],
        "Ra": ca.if_else(keep, t_new, g["Ra"]),
        "T1a": ca.if_else(keep, T1, g["T1a"]),
        "T2a": ca.if_else(keep, T2, g["T2a"]),
        "d1a": ca.if_else(keep, d1, g["d1a"]),
        "d2a": ca.if_else(keep, d2, g["d2a"]),
        "minT": ca.if_else(keep, ca.fmin(g["minT"], step_min), g["minT"]),
        "maxE": ca.if_else(keep, ca.fmax(g["maxE"], ca.fabs(E)), g["maxE"]),
        "failR": ca.if_else(move * (code != 0), t_new, g["failR"]),
        "cand_est": ca.if_else(better, e_min, g["cand_est"]),
        "cand_Ra": ca.if_else(better, t, g["cand_Ra"]),
        "cand_h": ca.if_else(better, t_new - t, g["cand_h"]),
        "cand_da": ca.if_else(better, da_best, g["cand_da"]),
        "cand_db": ca.if_else(better, db_best, g["cand_db"]),
        "cand_k": ca.if_else(better, k_best, g["cand_k"]),
    }
    head = ca.vertcat(*[new[k] for k in _HEAD])
    x_new = ca.vertcat(head, ca.if_else(keep, y_new, y), ca.if_else(keep, f_new, f), atol, ca.if_else(better, y, cy))
    one = ca.Function(f"attempt_{kind}", [x], [ca.cse(x_new)])
    if K == 1:
        return one
    # K attempts in a loop (mapaccum keeps the graph one attempt long); only the last state comes out
    acc = one.mapaccum(f"attempts_{kind}_acc", K)
    xm = ca.MX.sym("x", n)
    return ca.Function(f"attempts_{kind}", [xm], [acc(xm)[:, K - 1]])


def _attempts_key(model: MembraneModel, kind: str) -> str | None:
    """The cache key of a model's attempt function (serialised or compiled): what the model is (effects,
    parameters), which function, the settings baked into it, the library's own source files that
    generate it and the CasADi version — so that a cached function is reused exactly when it would be
    generated the same again. None for a model whose effects are not the library's (never cached)."""
    if model_cache_key(model) is None:
        return None
    digest = cache.source_digest(
        (
            "model.py",
            "effects.py",
            "shooting.py",
            "wrinkling.py",
            "numerics/dop853.py",
            "numerics/dop853_tableau.py",
            "numerics/codegen.py",
            "numerics/compiled.py",
        )
    )
    return cache.key(model.describe(), model.electrostatics.name, kind, ATTEMPTS_PER_CALL, REFINE_MINIMUM_BELOW, digest)


def _integrators(model: MembraneModel) -> _Integrators:
    built = model._built
    if "integrators" not in built:
        built["integrators"] = _Integrators(model)
    return built["integrators"]


def fresh_integrators(model: MembraneModel, compile_after: int = COMPILE_AFTER) -> None:
    """Give ``model`` new integrators that compile (or load compiled) code from their ``compile_after``-th use.

    The small batches run in CasADi's virtual machine until then and as compiled machine code after; both
    evaluate the same graph but round differently in the last bits. ``compile_after=1`` puts every
    computation on the compiled path from the first call (where a C compiler is at hand), so that a result
    does not depend on what its process computed before (:func:`coexist.sweep.same_code_path`).

    Parameters
    ----------
    model : MembraneModel
        The model whose integrators are replaced.
    compile_after : int
        Uses before compiling (default :data:`COMPILE_AFTER`).
    """
    model._built["integrators"] = _Integrators(model, int(compile_after))


def checked_state_inputs(model: MembraneModel, pole_stretch, phi_hat, settings: SolverSettings | None):
    """The inputs of a batch of states, checked and flattened (shared by :func:`solve_states` and
    :func:`coexist.patterned.solve_patterned_states`).

    Parameters
    ----------
    model : MembraneModel
        The membrane.
    pole_stretch, phi_hat : array_like
        Pole stretches and voltages, broadcast against each other.
    settings : SolverSettings or None
        Default ``SolverSettings()``.

    Returns
    -------
    tuple
        ``(settings, l0, phi)`` with ``l0`` and ``phi`` flat float arrays of one size.

    Raises
    ------
    SceneError
        If a pole stretch is not finite or not above ``λpre``, a voltage is negative or not finite, or a
        voltage is not zero for a model without electrostatics.
    """
    settings = validation.settings_or_default(settings)
    validation.membrane_model(model)
    l0, phi = validation.broadcastable(
        "pole_stretch, phi_hat",
        validation.real_array(pole_stretch, "pole_stretch"),
        validation.real_array(phi_hat, "phi_hat", lo=0.0),
    )
    l0 = np.array(l0, dtype=float).ravel()
    phi = np.array(phi, dtype=float).ravel()
    _check_inputs(model, l0, phi)
    return settings, l0, phi


def solve_states(
    model: MembraneModel,
    pole_stretch,
    phi_hat=0.0,
    settings: SolverSettings | None = None,
    shape: bool = False,
    derivatives: bool = False,
    formal: bool = False,
    starts=None,
) -> MembraneStates:
    """Equilibrium states of a clamped zone at the given pole stretches and voltages.

    Parameters
    ----------
    model : MembraneModel
        The membrane (effects and prestretch).
    pole_stretch : array_like
        Pole stretches ``λ0 > λpre``.
    phi_hat : float or array_like
        Normalised voltages ``Φ̂ ≥ 0``, broadcast against ``pole_stretch``.
    settings : SolverSettings, optional
        Tolerances and limits of the integration; default ``SolverSettings()``.
    shape : bool
        Also return the meridian ``(R̂, r̂, ẑ)`` of every state (costs extra output steps).
    derivatives : bool
        Also return the exact first derivatives of ``p̂, V̂, Q̂`` (and ``Ψ̂``) with respect to the pole
        stretch and the voltage, from the variational equations integrated with the state
        (:class:`StateDerivatives`; about twice the cost of the states alone).
    formal : bool
        Continue through a non-positive hoop tension instead of stopping with ``wrinkling``: the taut
        equations stay regular while the meridional tension is positive, and ``min_tension`` then goes
        smoothly through zero. Such a state is *not* a membrane equilibrium (it would wrinkle); this is
        only for locating the onset of wrinkling as the root of a smooth function.
    starts : coexist.patterned.ScaleStarts, optional
        A patterned zone only (ignored otherwise): a continuation's store of converged states, whose nearest
        kept neighbour starts each state's interface-scale iteration (a start, never a result: the states are
        the same to the solver's tolerance); the converged states are kept in it.

    Returns
    -------
    MembraneStates
        Failed states are flagged by ``status``; nothing in a flagged entry is to be trusted.

    Raises
    ------
    SceneError
        If a pole stretch is not finite or not above ``λpre``, a voltage is negative or not finite,
        or a voltage is not zero for a model without electrostatics.
    """
    if getattr(model, "pattern", None) is not None:  # a patterned zone (coexist.patterned.PatternedModel)
        if model.tension_field:  # its WRINKLED states shot again relaxed
            from .patterned_relaxed import shoot_zone_relaxed

            return shoot_zone_relaxed(model, pole_stretch, phi_hat, settings, shape, derivatives, formal, starts)
        from .patterned import shoot_zone

        return shoot_zone(model, pole_stretch, phi_hat, settings, shape, derivatives, formal, starts)
    settings, l0, phi = checked_state_inputs(model, pole_stretch, phi_hat, settings)
    states = _solve_uniform(model, l0, phi, settings, shape, derivatives, formal)
    # the trial pressure is proportional to the pole tension T̂0 while the pressure stays finite as T̂0 → 0 (the tension
    # off the pole carries it): the clamp's trial radius grows like 1/T̂0. A state that found no clamp within
    # max_radius_factor there is shot again with the search radius grown so (Gent 97 at p̂ = 1.2, λ0 3.265: T̂0 =
    # 1.9e-3 needed R ≈ 1.8e3 and was refused as "no equilibrium", which ended the Φ̂–Q̂ spiral early with that reason:
    # review, helper-72); only those, so that every other state is the same whatever it is batched with, and one
    # that finds no clamp again keeps its first failure (a wider search of a trajectory that never returns costs
    # many steps: review, helper-75)
    none = (states.status == NO_CLAMP).nonzero()[0]  # the pole tension only for those (the hot path has none)
    if none.size:
        with np.errstate(all="ignore"):
            T0 = np.asarray(model.pole(l0[none], phi[none])[0], dtype=float) * np.ones(none.size)
        again = none[(T0 > 0) & (T0 < SEARCH_TENSION)]
        T0 = T0[(T0 > 0) & (T0 < SEARCH_TENSION)]
    else:
        again = none
    if again.size:
        growth = float(np.clip(SEARCH_TENSION / T0.min(), 1.0, SEARCH_GROWTH_MAX))
        wider = replace(settings, max_radius_factor=settings.max_radius_factor * growth)
        found = _solve_uniform(model, l0[again], phi[again], wider, shape, derivatives, formal)
        _put(states, found, again, found.status == OK)
    return states


def _put(states: MembraneStates, new: MembraneStates, rows, take) -> None:
    """``states[rows[take]] = new[take]`` for every per-state field (derivatives, shapes and bands included)."""
    idx, sub = rows[take], np.flatnonzero(take)
    for name, value in states.__dict__.items():
        if isinstance(value, np.ndarray):
            value[idx] = getattr(new, name)[sub]
        elif name in ("shapes", "wrinkled_radii") and value is not None:
            for i, j in zip(idx, sub):
                value[i] = getattr(new, name)[j]
        elif name == "derivatives" and value is not None:
            for k in value.__dict__:
                getattr(value, k)[idx] = getattr(new.derivatives, k)[sub]


def _per_state(value, n: int) -> np.ndarray:
    """An output of a generated function as a float array of the ``n`` states (a view where it is one already)."""
    value = np.asarray(value, dtype=float)
    return value if value.shape == (n,) else np.broadcast_to(value, (n,))


def _solve_uniform(model, l0, phi, settings, shape, derivatives, formal) -> MembraneStates:
    """:func:`solve_states` of a uniform zone on checked inputs, with ``settings.max_radius_factor`` as given."""
    n = l0.size
    lam_clamp = model.prestretch
    status = np.zeros(n, dtype=int)
    fail_radius = np.full(n, np.inf)

    with np.errstate(all="ignore"):
        pole = model.pole(l0, phi)
        T0, alpha = _per_state(pole[0], n), _per_state(pole[1], n)
        aux0 = model.tensions(l0, l0, phi)
        margin0 = _per_state(aux0[4], n)
        max_field = np.abs(_per_state(aux0[5], n))
    status[l0 - model.prestretch < FLAT_LIMIT * model.prestretch] = BELOW_RESOLUTION
    status[(status == OK) & (margin0 <= LOCKING_LIMIT)] = LOCKED
    status[(status == OK) & ~np.isfinite(T0)] = NOT_FINITE  # an overflowing pole tension is not a wrinkle
    status[(status == OK) & (T0 <= 0)] = WRINKLED_AT_POLE
    status[(status == OK) & (alpha <= 0)] = LOST_ELLIPTICITY
    fail_radius[status != OK] = 0.0

    # (x.nonzero()[0] here and below: np.flatnonzero of a 1-D x without its Python layers, on every small batch)
    live = (status == OK).nonzero()[0]
    keys = ("p", "V", "Q", "Psi", "z", "R") + (
        ("dR_dl0", "dV_dl0", "dQ_dl0", "dR_dphi", "dV_dphi", "dQ_dphi") if derivatives else ()
    )
    trial = np.full((len(keys), n), np.nan)  # the trial membrane's, one row per key
    out = dict(zip(keys, trial))
    min_tension = np.where(status == OK, T0, np.nan)
    steps = np.zeros(n, dtype=int)
    shapes = [None] * n if shape else None
    # a tension-field model takes a wrinkled state up where its taut shooting stopped (coexist.wrinkling)
    restart: dict | None = {} if model.tension_field and not formal else None
    if live.size:
        with np.errstate(all="ignore"):
            _shoot(
                model,
                settings,
                (l0, phi, T0, live, lam_clamp),
                _Diagnostics(status, fail_radius, out, min_tension, max_field, steps, shapes),
                derivatives,
                formal,
                restart=restart,
            )
    wrinkled_radii: list | None = None
    wrinkled_stiffness: np.ndarray | None = None
    if model.tension_field and not formal:
        wrinkled_radii = [[] for _ in range(n)]
        wrinkled_stiffness = np.full(n, np.inf)
        again = np.flatnonzero(status == WRINKLED)
        if again.size:
            from .wrinkling import shoot_relaxed

            with np.errstate(all="ignore"):
                start = None if not restart else {k: v[..., again] for k, v in restart.items()}
                shots = shoot_relaxed(model, settings, l0[again], phi[again], derivatives, start=start)
            for k in out:
                out[k][again] = shots.out[k]
            status[again] = shots.status
            min_tension[again] = shots.min_tension
            max_field[again] = shots.max_field
            steps[again] += shots.steps
            fail_radius[again] = shots.fail_radius
            for j, i in enumerate(again):
                wrinkled_radii[i] = shots.wrinkled_radii[j]
            if shots.band_stiffness is not None:
                wrinkled_stiffness[again] = shots.band_stiffness
    bad = status != OK
    trial[:, bad] = np.nan
    R = out["R"]
    p_trial = out["p"]
    p_hat, v_hat, q_hat = p_trial * R, out["V"] / R**3, out["Q"] / R**2
    deriv = clamped_derivatives(out, p_trial, R, v_hat, q_hat) if derivatives else None
    return MembraneStates(
        pole_stretch=l0,
        phi_hat=phi,
        p_hat=p_hat,
        v_hat=v_hat,
        q_hat=q_hat,
        psi_hat=out["Psi"] / R**2,
        apex_height=out["z"] / R,
        max_field=np.where(bad, np.nan, max_field),
        min_tension=np.where(bad, np.nan, min_tension),
        clamp_radius=R,
        status=status,
        fail_radius=fail_radius,
        steps=steps,
        shapes=shapes,
        derivatives=deriv,
        wrinkled_radii=wrinkled_radii,
        wrinkled_stiffness=None if wrinkled_stiffness is None else np.where(bad, np.nan, wrinkled_stiffness),
    )


def clamped_derivatives(trial: dict, p_trial, R, v_hat, q_hat, bad=None) -> StateDerivatives:
    """The derivatives of the unit membrane's ``p̂, V̂, Q̂`` to ``λ0`` and ``Φ̂`` from those of the trial shooting.

    With ``p̂ = p̂t R*``, ``V̂ = V̂t/R*³``, ``Q̂ = Q̂t/R*²`` and ``a`` either parameter:
    ``dp̂/da = p̂t dR*/da``, ``dV̂/da = (dV̂t/da)/R*³ − 3 V̂ (dR*/da)/R*``, ``dQ̂/da = (dQ̂t/da)/R*² − 2 Q̂ (dR*/da)/R*``.

    Parameters
    ----------
    trial : dict
        ``dR_d{a}``, ``dV_d{a}``, ``dQ_d{a}`` (``a`` = ``l0``, ``phi``): the trial membrane's, per state.
    p_trial, R, v_hat, q_hat : ndarray
        The trial pressure, the clamp radius ``R*`` and the unit membrane's ``V̂, Q̂``.
    bad : ndarray of bool, optional
        States without derivatives (NaN).

    Returns
    -------
    StateDerivatives
    """
    parts = {}
    for a in ("l0", "phi"):
        dR = trial[f"dR_d{a}"] if bad is None else np.where(bad, np.nan, trial[f"dR_d{a}"])
        parts[f"dp_d{a}"] = p_trial * dR
        parts[f"dv_d{a}"] = trial[f"dV_d{a}"] / R**3 - 3 * v_hat * dR / R
        parts[f"dq_d{a}"] = trial[f"dQ_d{a}"] / R**2 - 2 * q_hat * dR / R
    return StateDerivatives(**parts)


#: a state that finds no clamp while its pole tension ``T̂0`` is below this is shot again with the search radius
#: ``max_radius_factor`` grown like ``1/T̂0`` (:func:`solve_states`)
SEARCH_TENSION = 1e-2
#: ... up to this factor (``T̂0 = 1e-5``)
SEARCH_GROWTH_MAX = 1e3


def start_rows(model: MembraneModel, settings: SolverSettings, l0, phi, derivatives: bool, pole_tension=None):
    """The integrator's start at the series radius, and its tolerances, for pole stretches ``l0``.

    Rows ``λ1, λ2, θ, V̂/π, Q̂/2π, Ψ̂/2π, ẑ`` (then, with ``derivatives``, their sensitivities
    ``∂(λ1, λ2, θ, V̂/π, Q̂/2π)`` to ``λ0`` and to ``Φ̂``), then ``p̂t`` and ``Φ̂``.

    Parameters
    ----------
    model : MembraneModel
        The membrane.
    settings : SolverSettings
        Tolerances (``rtol``, ``atol``, the series radius, sensitivity error control).
    l0, phi : ndarray
        Pole stretches and voltages, one per state.
    derivatives : bool
        With the sensitivity rows.
    pole_tension : ndarray, optional
        ``T̂1(λ0, λ0)`` per state if the caller has it (passed to :func:`trial_pressure`).

    Returns
    -------
    p_trial : ndarray
        The trial pressures (:func:`trial_pressure`).
    y0 : ndarray
        The rows at ``R̂0 = settings.series_radius``, one column per state.
    atol : ndarray
        Absolute tolerance per row and column, from the size of each row at ``R̂ = 1``.
    rtol : ndarray
        Relative tolerance per column (``settings.rtol``, raised to what roundoff allows).
    """
    p = trial_pressure(model, l0, phi, pole_tension)
    R0 = settings.series_radius
    m = l0.size
    lam_clamp = model.prestretch
    # series start at the pole (docs/physics.md) and, for the absolute tolerances, the same series
    # evaluated at R̂ = 1: each trajectory's tolerance then follows the size of its own quantities (a
    # barely inflated membrane has θ ~ δ, V̂ ~ δ, Ψ̂ ~ δ² for an apex deflection δ, and a fixed
    # absolute tolerance would swallow them)
    # (one evaluation for both radii: the generated series costs per call, not per column)
    inputs = np.empty((4, 2, m))  # λ0, p̂t, Φ̂, R̂: every state at R̂0, then at R̂ = 1
    inputs[0], inputs[1], inputs[2] = l0, p, phi
    inputs[3, 0], inputs[3, 1] = R0, 1.0
    series = model.series_start(*inputs.reshape(4, 2 * m))
    both = np.empty((len(series), 2 * m))
    for row, value in zip(both, series):
        row[:] = value  # (broadcast, as the rows of a generated function are)
    start, unit = both[:, :m], both[:, m:]
    rows = 19 if derivatives else 9
    y0 = np.empty((rows, m))
    size = np.empty((rows, m))
    y0[:7] = start[:7]
    size[:2] = 1.0
    size[2:7] = np.abs(unit[2:7])
    if derivatives:
        y0[7:17] = start[7:17]
        if settings.sensitivity_error_control:
            size[7:9] = 1.0
            size[9:12] = np.abs(unit[9:12])
            size[12:17] = np.maximum(np.abs(unit[12:17]), 1e-30)
        else:
            # integrated on the steps the states choose: the derivative of the discrete solution
            size[7:17] = np.inf
    y0[-2], y0[-1] = p, phi
    size[-2:] = 1.0
    atol = settings.atol * np.maximum(size, 1e-30)
    # roundoff bounds what can be asked of a barely inflated membrane: its tensions are differences
    # of O(1) numbers that are O(λ0 − λpre), so their relative precision is ~ε/(λ0 − λpre)
    rtol = np.maximum(settings.rtol, ROUNDOFF_TOLERANCE / (l0 / lam_clamp - 1))
    return p, y0, atol, rtol


@dataclass
class _Diagnostics:
    """The arrays :func:`_shoot` fills in place, one entry per requested state."""

    status: np.ndarray
    fail_radius: np.ndarray
    out: dict
    min_tension: np.ndarray
    max_field: np.ndarray
    steps: np.ndarray
    shapes: list | None


def _shoot(model, settings, problem, diagnostics: _Diagnostics, derivatives, formal=False, restart=None):
    """Integrate the live trajectories of ``problem = (λ0, Φ̂, T̂0, live, λclamp)``; fills ``diagnostics``
    in place. ``restart``, if a dict, receives for every state (NaN where none) the node a ``WRINKLED``
    trajectory can be taken up from by :func:`coexist.wrinkling.shoot_relaxed`: ``R``, ``y`` (the rows of
    :func:`start_rows`), ``h`` (a step size), ``min_T``, ``max_E`` (up to that node), the last accepted node
    before the tension's zero that this shooting vouches for; NaN (from the pole) where the zero may lie
    before a step whose minimum was located only after the run."""
    l0, phi, T0, live, lam_clamp = problem
    d = diagnostics
    status, fail_radius, out, min_tension, max_field, steps, shapes = (
        d.status,
        d.fail_radius,
        d.out,
        d.min_tension,
        d.max_field,
        d.steps,
        d.shapes,
    )
    l0, phi, T0 = (a[live] for a in (l0, phi, T0))
    m = live.size
    R0 = settings.series_radius
    p, y0, atol, rtol = start_rows(model, settings, l0, phi, derivatives, T0)
    P = y0.shape[0] - 2  # row of the trial pressure; the voltage is the next
    local_min_T = T0.copy()
    local_max_E = max_field[live].copy()
    local_fail_R = np.full(m, np.nan)
    local_code = np.zeros(m, dtype=int)
    trace: list | None = [] if shapes is not None else None
    if restart is not None:  # the smallest tension and largest field before each node (numpy path)
        pre_T, pre_E = local_min_T.copy(), local_max_E.copy()
    # the last accepted node of each trajectory (radius, T1, T2, their slopes dT/dR, the state and its
    # derivative): a tension's minimum between two nodes is first estimated by the cubic Hermite
    # interpolant of its values and exact slopes (error O(h⁴)); where that estimate comes near zero (where
    # the onset of wrinkling is decided), the step is taken again to the point where dT/dR = 0, so the
    # minimum carries the integrator's own accuracy. At the pole the slopes vanish (even in R).
    node = np.zeros((5, m))
    node[0], node[1], node[2] = R0, T0, T0
    node_y = y0.copy()
    fns = _integrators(model)
    kind = "radius_sens" if derivatives else "radius"

    def slopes(y, f, T11, T12, T22):
        # dT1/dR = ∂T1/∂λ1 λ1' + ∂T1/∂λ2 λ2',  dT2/dR = ∂T2/∂λ1 λ1' + ∂T2/∂λ2 λ2' (∂T2/∂λ1 = ∂T1/∂λ2)
        return T11 * f[0] + T12 * f[1], T12 * f[0] + T22 * f[1]

    def tension_and_slope(y, f, k):
        T1_, T2_, T11_, T12_, _, _, T22_ = model.tensions(y[0], y[1], y[P + 1])
        d1_, d2_ = slopes(y, f, T11_, T12_, T22_)
        return (T1_, d1_) if k == 1 else (T2_, d2_)

    def exact_min(cols, k, Ra, ya, h, da, db):
        """Minimum of tension k inside the steps (Ra, Ra + h): the root of dT/dR = 0
        (:func:`~coexist.numerics.roots.bracketed_root`), each iterate one step of the integrator from the
        last node; the smallest tension met on the way is the minimum."""
        stepper = fns.stepper(kind, cols.size)
        fa_ = stepper.rhs(Ra, ya)
        best = np.full(cols.size, np.inf)

        def slope_at(s_, idx):
            y_s, f_s, _, _ = stepper.step(Ra[idx], ya[:, idx], fa_[:, idx], s_)
            T_s, g_s = tension_and_slope(y_s, f_s, k)
            best[idx] = np.minimum(best[idx], T_s)
            return g_s

        bracketed_root(slope_at, np.zeros(cols.size), h, da, db, xtol=1e-9 * np.maximum(h, 1e-300), max_iter=10)
        return best

    def refine_min(R, T1, T2, d1, d2, cols, y_new=None):
        a = node[:, cols]
        est = []
        for k, (T, d) in enumerate(((T1, d1), (T2, d2)), start=1):
            ends = np.minimum(a[k], T)
            # an interior minimum needs the slope to turn from falling to rising within the step (the
            # cubic could dip otherwise only by less than the interpolation error): most steps have none
            interior = (a[2 + k] < 0) & (d > 0)
            if not interior.any():
                est.append(ends)
                continue
            e = ends.copy()
            e[interior] = hermite_minimum(
                a[0][interior], a[k][interior], a[2 + k][interior], R[interior], T[interior], d[interior]
            )
            interior &= e < ends
            near = interior & (e < REFINE_MINIMUM_BELOW) & np.isfinite(e)
            if y_new is not None and near.any():
                sub = np.flatnonzero(near)
                e = e.copy()
                e[sub] = exact_min(
                    cols[sub], k, a[0][sub], node_y[:, cols[sub]], R[sub] - a[0][sub], a[2 + k][sub], d[sub]
                )
            est.append(e)
        return np.minimum(est[0], est[1])

    def check(R, y, cols, f):
        if restart is not None:
            pre_T[cols], pre_E[cols] = local_min_T[cols], local_max_E[cols]
        # generated functions return arrays shaped like their inputs (constants included)
        T1, T2, T11, T12, margin, E, T22 = model.tensions(y[0], y[1], y[P + 1])
        crossed = y[1] <= lam_clamp
        d1, d2 = slopes(y, f, T11, T12, T22)
        # a step that crosses the clamp is discarded: its state lies outside the membrane
        t_min = np.where(crossed, np.inf, refine_min(R, T1, T2, d1, d2, cols, y))
        keep = cols[~crossed]
        node[:, keep] = np.vstack([R, T1, T2, d1, d2])[:, ~crossed]
        node_y[:, keep] = y[:, ~crossed]
        local_min_T[cols] = np.minimum(local_min_T[cols], t_min)
        if formal:  # only the meridional tension must stay positive
            t_min = np.where(crossed, np.inf, T1)
        local_max_E[cols] = np.maximum(local_max_E[cols], np.where(crossed, 0.0, np.abs(E)))
        if trace is not None:
            trace.append((cols.copy(), R.copy(), y[1] * R, y[6].copy()))
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
    small = shapes is None and m <= fns.small_batch_limit(kind, m)
    if shapes is None and not small:
        # a large batch counts as a use too (compiled from the COMPILE_AFTER-th, looked for while it compiles): a
        # process of large batches alone had shot them in numpy to its end (a fresh machine's first p̂–V̂ curves: 5.7
        # ms for 200 states against 3.0 ms compiled)
        fns.attempts(kind)
        small = m <= fns.small_batch_limit(kind, m)
    h_att = np.full(m, np.nan)  # the attempt function's step sizes (filled only for a restart)
    from_pole = np.zeros(m, dtype=bool)
    if small:
        res, cand = _integrate_attempts(
            fns,
            kind,
            y0,
            R0,
            R_end,
            rtol,
            atol,
            settings.max_steps,
            formal,
            T0,
            local_max_E,
            local_min_T,
            local_fail_R,
            local_code,
            h_out=h_att if restart is not None else None,
        )
    else:
        res = _int.integrate(
            fns.stepper(kind, m), np.full(m, R0), y0, R_end, rtol, atol, settings.max_steps, event=check
        )
    steps[live] += res.steps
    code = np.where(res.status == _int.CROSSED, OK, local_code)
    if small and cand is not None:
        # the minima whose estimate came near zero, located exactly (what check() does within the loop)
        idx, k, Ra, ya, hh, da, db = cand
        exact = np.full(idx.size, np.inf)
        for kk in (1, 2):
            sel = k == kk
            if sel.any():
                exact[sel] = exact_min(idx[sel], kk, Ra[sel], ya[:, sel], hh[sel], da[sel], db[sel])
        local_min_T[idx] = np.minimum(local_min_T[idx], exact)
        from_pole[idx[exact <= 0]] = True  # a zero in a step before the last node
        if not formal:
            wr = (exact <= 0) & (code[idx] == OK)
            code[idx[wr]] = WRINKLED
            local_fail_R[idx[wr]] = Ra[wr]
    code[res.status == _int.REACHED_END] = NO_CLAMP
    code[res.status == _int.STEP_LIMIT] = STEP_LIMIT
    code[(res.status >= _int.FAILED) & (local_code == 0)] = NOT_FINITE

    # final step onto the clamp with λ2 as the independent variable
    go = (code == OK).nonzero()[0]
    if restart is not None:
        before_clamp = local_min_T.copy()
        h_land = np.full(m, np.nan)
    if go.size:
        yh = res.y[:, go]
        Rh = res.t[go]
        # R, λ1, θ, V, Q, Ψ, z, p, φ: λ2 becomes the independent variable, R a row
        hoop_rows = [0, 2, 3, 4, 5, 6, P, P + 1]
        z0 = np.empty((9, go.size))
        z0[0], z0[1:] = Rh, yh[hoop_rows]
        atol_h = np.empty((9, go.size))
        atol_h[0], atol_h[1:] = settings.atol, atol[hoop_rows][:, go]
        # usually one step of the size of the remaining stretch lands on the clamp within tolerance;
        # the few that do not are integrated adaptively
        hoop = fns.stepper("hoop", go.size)
        zf, err = _int.single_step(hoop, yh[1], z0, lam_clamp - yh[1], rtol[go][None, :], atol_h)
        landed = err <= 1.0
        steps[live[go]] += 1
        redo = (~landed).nonzero()[0]
        if redo.size:
            hop = _int.integrate(
                fns.stepper("hoop", redo.size),
                yh[1][redo],
                z0[:, redo],
                np.full(redo.size, lam_clamp),
                rtol[go][redo],
                atol_h[:, redo],
                settings.max_steps,
                h0=0.5 * np.abs(yh[1][redo] - lam_clamp),
            )
            steps[live[go][redo]] += hop.steps
            zf[:, redo] = hop.y
            landed[redo] = hop.status == _int.REACHED_END
        bad_turn = ~landed | ~np.isfinite(zf).all(axis=0) | (zf[0] <= Rh)
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
        T1, T2, T11, T12, _, _, T22 = model.tensions(zg[1], lam_clamp, zg[8])
        # the clamp is the last node: a minimum just before it is refined with it
        f_clamp = model.rhs(zg[0], zg[1], lam_clamp, zg[2], zg[7], zg[8])
        d1, d2 = slopes(None, f_clamp, T11, T12, T22)
        last = refine_min(zg[0], T1, T2, d1, d2, good)
        local_min_T[good] = np.minimum(local_min_T[good], np.minimum(np.minimum(T1, T2), last))
        wr = (local_min_T[good] <= 0) if not formal else (T1 <= 0)
        code[good[wr]] = WRINKLED
        local_fail_R[good[wr]] = zg[0][wr]
        if restart is not None:
            h_land[good] = zg[0] - Rh[~bad_turn]
        if derivatives and good.size:
            _end_derivatives(
                fns, res.y[:, good], Rh[~bad_turn], zg, rtol[good], atol[:, good], settings, out, idx, steps, live[good]
            )
    status[live] = code
    fail_radius[live] = np.where(
        code == OK, np.inf, local_fail_R / np.where(np.isfinite(out["R"][live]), out["R"][live], 1.0)
    )
    min_tension[live] = local_min_T
    max_field[live] = local_max_E
    if shapes is not None:
        _collect_shapes(trace, live, out, shapes, lam_clamp)
    if restart is not None:
        n, rows = status.size, y0.shape[0]
        for k, v in (("R", np.full(n, np.nan)), ("y", np.full((rows, n), np.nan)), ("h", np.full(n, np.nan))):
            restart[k] = v
        restart["min_T"], restart["max_E"] = np.full(n, np.nan), np.full(n, np.nan)
        wr = (code == WRINKLED) & ~from_pole
        # a node where the step after it failed: that node (the attempt function stops there; numpy moves on)
        at_node = np.flatnonzero(wr & (res.status >= _int.FAILED))
        if small:
            parts = [(at_node, res.t, res.y, h_att, local_min_T, local_max_E)]
        else:
            h_prev = res.t - res.t_previous
            parts = [(at_node, res.t_previous, res.y_previous, h_prev, pre_T, pre_E)]
        # the zero lies in the last step, onto the clamp: its start
        onto_clamp = np.flatnonzero(wr & (res.status == _int.CROSSED))
        parts.append((onto_clamp, res.t, res.y, h_land, before_clamp, local_max_E))
        for j, Rn, yn, hn, Tn, En in parts:
            i = live[j]
            restart["R"][i], restart["y"][:, i], restart["h"][i] = Rn[j], yn[:, j], hn[j]
            restart["min_T"][i], restart["max_E"][i] = Tn[j], En[j]


def run_attempts(
    entry: dict, X: np.ndarray, status_row: int, steps_row: int | None = None, limit_row: int | None = None
) -> None:
    """Call the attempt function of ``entry`` (:meth:`_Integrators.attempts_of`) on the packed states ``X`` (one
    column per trajectory), mapped over the columns still running (``X[status_row] == 0``, at most
    :data:`COMPILED_BATCH_LIMIT` per call), until none is; ``X`` is updated in place.

    Given the rows of the attempt count and its limit (``steps_row``, ``limit_row``: the ``steps`` and
    ``max_steps`` of the packed state), a column that a call leaves exactly as it found it but for its count
    (:func:`_stalled`: a trajectory that can no longer change, e.g. one whose every attempt is the same rejected
    step) is not run on to its limit call by call: it ends as it would, with ``STEP_LIMIT`` at the limit.

    Parameters
    ----------
    entry : dict
        The attempt function's entry (``fun`` and its ``maps`` by batch size).
    X : ndarray
        Packed states.
    status_row : int
        Row of the status in ``X``.
    steps_row, limit_row : int, optional
        Rows of the attempt count and of its limit in ``X`` (both, or no stalled column is ended early).
    """
    active = np.arange(X.shape[1])
    rows = X.shape[0]
    watch = (steps_row, limit_row) if steps_row is not None and limit_row is not None else None
    while active.size:
        for first in range(0, active.size, COMPILED_BATCH_LIMIT):
            cols = active[first : first + COMPILED_BATCH_LIMIT]
            n = cols.size
            call = entry["maps"].get(n)
            if call is None:
                fun = entry["fun"].map(n, "serial") if n > 1 else entry["fun"]
                call = entry["maps"][n] = BufferedFunction(fun, [rows], rows, n)
            before = X[:, cols]
            after = X[:, cols] = call(before)
            if watch is not None:
                _stalled(X, cols, before, after, status_row, *watch)
        active = active[X[status_row, active] == 0]


def _stalled(X, cols, before, after, status_row: int, steps_row: int, limit_row: int) -> None:
    """End the columns ``cols`` of :func:`run_attempts` that one call left unchanged but for their attempt count,
    as running on would end them (``X`` updated in place; ``before``/``after``: their packed states around the call).

    An attempt function is a fixed map of the packed state that reads the attempt count only to know whether an
    attempt is a trajectory's first and whether the count has reached its limit (where it stops the trajectory with
    ``STEP_LIMIT``, and leaves a stopped one as it is). A column still running after a call of ``K`` attempts that
    started past its first attempt and ends bitwise where it began (count aside) repeats those ``K`` attempts
    exactly, call after call, until the count reaches the limit: its states cycle with a period dividing ``K``, and
    the attempt that reaches the limit is ``(limit − count) mod K`` attempts into a cycle. So the count is set to
    that many attempts below the limit (the next call takes them and stops the column with ``STEP_LIMIT``, in the
    state running on would have reached), or the column is stopped at once where that is none: bitwise the
    outcome of the calls it is spared (a trajectory whose every attempt is the same rejected step, as a pole region
    asked to end below its series radius: 4000 attempts, some 500 calls, per trial)."""
    running = (after[status_row] == 0) & (before[steps_row] >= 1)
    if not running.any():  # the first call, or every column stopped: nothing to compare
        return
    same = after.view(np.int64) == before.view(np.int64)
    same[steps_row] = True
    still = running & same.all(axis=0)
    if not still.any():
        return
    c = cols[still]
    done = after[steps_row, still]
    per = done - before[steps_row, still]  # attempts per call (the trajectory ran through the whole call)
    left = np.mod(after[limit_row, still] - done, per)
    X[steps_row, c] = after[limit_row, still] - left
    X[status_row, c[left == 0]] = _int.STEP_LIMIT


def _integrate_attempts(
    fns, kind, y0, R0, R_end, rtol, atol, max_steps, formal, T0, max_E, min_T, fail_R, code, h_out=None
):
    """Integrate a small batch with the attempt function, :data:`ATTEMPTS_PER_CALL` attempts per call, until
    every trajectory stops. Fills ``min_T``, ``max_E``, ``fail_R`` and ``code`` in place and returns an
    :class:`~coexist.numerics.dop853.IntegrationResult` and the steps whose tension minimum must be located
    exactly (``(columns, tension, R_a, y_a, h, slope_a, slope_b)``, or None). A failed trajectory's ``t, y``
    (and ``min_T``, ``max_E``) are those of its last node before the failing step; ``h_out``, if given, is
    filled with the step sizes (a failed trajectory's: the failing step's)."""
    R, m = y0.shape
    entry = fns.attempts(kind)
    o = len(_HEAD)
    X = np.zeros((o + 4 * R, m))  # the derivative rows f stay zero: the first attempt computes them
    H = _H
    # no separate starting-step estimate: from the series radius the step grows tenfold per accepted attempt
    # (a rejected first attempt costs microseconds here, a numpy estimate half a millisecond)
    X[H["t"]], X[H["h"]], X[H["t_end"]], X[H["rtol"]] = R0, R0, R_end, rtol
    X[H["max_steps"]], X[H["formal"]] = max_steps, 1.0 if formal else 0.0
    X[H["Ra"]], X[H["T1a"]], X[H["T2a"]] = R0, T0, T0
    X[H["minT"]], X[H["maxE"]], X[H["failR"]], X[H["cand_est"]] = min_T, max_E, np.nan, np.inf
    X[o : o + R], X[o + 2 * R : o + 3 * R] = y0, np.where(np.isfinite(atol), atol, 1e300)
    run_attempts(entry, X, H["status"], H["steps"], H["max_steps"])
    status = X[H["status"]].astype(int)
    if h_out is not None:
        h_out[:] = X[H["h"]]
    min_T[:] = X[H["minT"]]
    max_E[:] = X[H["maxE"]]
    failed = status >= _int.FAILED
    code[failed] = status[failed]
    fail_R[failed] = X[H["failR"]][failed]
    t, y = X[H["t"]].copy(), X[o : o + R].copy()
    res = _int.IntegrationResult(
        t=t,
        y=y,
        status=np.where(failed, _int.FAILED, status),
        steps=X[H["steps"]].astype(int),
        t_previous=t,  # (read only: the numpy integration's node before the last, which here is the last)
        y_previous=y,
    )
    has = np.isfinite(X[H["cand_est"]]).nonzero()[0]
    if has.size == 0:
        return res, None
    cand = (
        has,
        X[H["cand_k"], has].astype(int),
        X[H["cand_Ra"], has],
        X[o + 3 * R : o + 4 * R][:, has],
        X[H["cand_h"], has],
        X[H["cand_da"], has],
        X[H["cand_db"], has],
    )
    return res, cand


def _end_derivatives(fns, y_h, R_h, z_end, rtol, atol, settings, out, idx, steps, step_idx):
    """Carry the sensitivities from the last step before the clamp onto the clamp, and turn them into
    total derivatives of the clamped solution.

    The clamp radius ``R*`` moves with the parameter ``a`` (``λ0`` or ``Φ̂``): from ``λ2(R*; a) = λpre``,
    ``dR*/da = −S_λ2 / λ2'`` and a quadrature ``w`` changes by ``dw/da = S_w + w' dR*/da`` (all at ``R*``).
    """
    stepper = fns.stepper("radius_sens", R_h.size)
    y_end, err = _int.single_step(stepper, R_h, y_h, z_end[0] - R_h, rtol[None, :], atol)
    redo = (~(err <= 1.0)).nonzero()[0]
    steps[step_idx] += 1
    if redo.size:
        hop = _int.integrate(
            fns.stepper("radius_sens", redo.size),
            R_h[redo],
            y_h[:, redo],
            z_end[0][redo],
            rtol[redo],
            atol[:, redo],
            settings.max_steps,
            h0=0.5 * (z_end[0][redo] - R_h[redo]),
        )
        y_end[:, redo] = hop.y
        steps[step_idx[redo]] += hop.steps
    R = z_end[0]
    f = fns.model.rhs(R, z_end[1], y_end[1], z_end[2], z_end[7], z_end[8])
    fV, fQ = QUADRATURE_FACTORS[:2]
    for a, first in (("l0", 7), ("phi", 12)):
        dR = -y_end[first + 1] / f[1]
        out[f"dR_d{a}"][idx] = dR
        out[f"dV_d{a}"][idx] = fV * (y_end[first + 3] + f[3] * dR)
        out[f"dQ_d{a}"][idx] = fQ * (y_end[first + 4] + f[4] * dR)


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
