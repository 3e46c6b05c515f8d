"""The two curve families of one zone: ``p̂(V̂)`` at fixed ``Φ̂`` and ``Φ̂(Q̂)`` at fixed ``p̂``.

Both are traced by the pole stretch ``λ0``, which does not turn where pressure, voltage or volume
do, so the curves pass through their limit points. A limit point is found where the slope of its quantity
along the grid changes sign, sampled by the secant of every interval and, at both ends of the curve and around
its sharp bends, by the exact slope at the node (so also in the first and last intervals, and two within one
interval: :func:`_grid_extrema`). Limit points are then located precisely, not read
off the grid: on a ``p̂–V̂`` curve by solving for the extremum (Chebyshev interpolation of the quantity
on a shrinking bracket around it, converged to the solver tolerance); on a ``Φ̂–Q̂``
curve as roots of the exact derivatives along it, ``dΦ̂/dλ0 = −(∂p̂/∂λ0)/(∂p̂/∂Φ̂)`` and
``dQ̂/dλ0 = ∂Q̂/∂λ0 + (∂Q̂/∂Φ̂) dΦ̂/dλ0`` (the variational equations of the shooting).

A ``Φ̂–Q̂`` curve needs the voltage that carries ``p̂`` at every pole stretch
(:func:`voltage_at_pressure`: a safeguarded Newton iteration with the exact ``∂p̂/∂Φ̂``); along the curve
most voltages start from the Hermite interpolant of a coarser set of solved ones and need two shots
without derivatives, and the zero-voltage states (which decide whether a pole stretch can carry ``p̂`` at
all) are shot only where they decide where the curve starts and ends.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from . import validation
from .errors import NoStateInRange, SceneError, SolverError
from .model import MembraneModel
from .numerics.roots import bracketed_root, chebyshev_extremum
from .numerics.sets import unique_sorted
from .settings import SolverSettings, error_reference, measured_error
from .shooting import (
    NO_VOLTAGE,
    OK,
    VOLTAGE_ITERATIONS,
    WRINKLED_AT_POLE,
    MembraneStates,
    StateDerivatives,
    first_valid_run,
    reason_tag,
    reason_text,
    solve_states,
)

_EPS = np.finfo(float).eps

#: the state quantities of a curve (attributes of :class:`~coexist.shooting.MembraneStates`), in table order
STATE_FIELDS = (
    "pole_stretch",
    "phi_hat",
    "p_hat",
    "v_hat",
    "q_hat",
    "psi_hat",
    "apex_height",
    "max_field",
    "min_tension",
)


#: the numbers of a limit point that carry an error (:attr:`LimitPoint.errors`)
LIMIT_POINT_FIELDS = ("pole_stretch", "p_hat", "v_hat", "phi_hat", "q_hat", "psi_hat")


@dataclass
class LimitPoint:
    """A turning point along a curve: ``kind`` is e.g. ``pressure_max`` or ``voltage_max``.

    ``errors`` maps each number (:data:`LIMIT_POINT_FIELDS`) to its error, measured by locating the limit point
    again at ``rtol/100`` (:func:`~coexist.settings.error_reference`; :func:`_limit_point_errors`): the extremal
    value (``p̂`` of a pressure maximum) is good to about the states' tolerance, while the location ``λ0`` and the
    other quantities there, which vary to first order with it, are only as good as the extremum is sharp (a flat
    one is ill-conditioned). None when it could not be measured: no valid state at the other tolerance, or no
    extremum of its kind found there.
    """

    kind: str
    pole_stretch: float
    p_hat: float
    v_hat: float
    phi_hat: float
    q_hat: float
    psi_hat: float
    errors: dict | None = None

    def to_dict(self) -> dict:
        """JSON-ready dict of the fields.

        Returns
        -------
        dict
            ``kind``, ``pole_stretch``, ``p_hat``, ``v_hat``, ``phi_hat``, ``q_hat``, ``psi_hat`` and ``errors``
            (the error of each number, or None where not measured).
        """
        out = dict(self.__dict__)
        out["errors"] = None if self.errors is None else dict(self.errors)
        return out


@dataclass
class Curve:
    """One curve of equilibrium states of a clamped zone, traced by the pole stretch.

    Attributes
    ----------
    family : str
        ``"pressure_volume"`` (fixed ``phi_hat``) or ``"voltage_charge"`` (fixed ``p_hat``).
    fixed : float
        The value held fixed (``Φ̂`` or ``p̂``).
    states : MembraneStates
        The valid states, in order of increasing pole stretch (all with status OK).
    limit_points : list of LimitPoint
        The refined extrema (pressure and volume, or voltage and charge), by pole stretch.
    starts_because, stopped_because : str or None
        Why the curve starts later or ends earlier than the requested pole-stretch range: the first state of the grid
        that fails beyond its first run of valid states, one that fails between two valid states of the grid (met
        while locating a limit point: "(at λ0, before the next state of the grid)"), or a jump of the states to
        another branch.
    rtol : float
        Relative tolerance of the integration the curve was shot with.
    """

    family: str
    fixed: float
    states: MembraneStates
    limit_points: list = field(default_factory=list)
    starts_because: str | None = None
    stopped_because: str | None = None
    rtol: float = 0.0

    def __getattr__(self, name):
        if name in STATE_FIELDS:
            return getattr(self.states, name)
        raise AttributeError(name)

    def to_dict(self) -> dict:
        """JSON-ready dict. A ``pressure_volume`` curve carries its fixed ``phi_hat`` and the arrays
        ``p_hat``, ``v_hat``, ``q_hat``, ``psi_hat``; a ``voltage_charge`` curve its fixed ``p_hat``
        and the array ``phi_hat`` instead of ``p_hat`` (whose largest deviation from the fixed value
        is ``p_hat_residual_max``).

        Returns
        -------
        dict
            Also ``family``, ``pole_stretch``, ``apex_height``, ``max_field_hat``, ``min_tension_hat``,
            ``limit_points`` (their :meth:`LimitPoint.to_dict`), ``relative_tolerance`` and, when set,
            ``starts_because`` / ``stopped_because``; for a tension-field model ``wrinkled_fraction`` and
            ``wrinkled_radii`` per state; arrays as lists of floats.
        """
        s = self.states
        out = {
            "family": self.family,
            "pole_stretch": s.pole_stretch.tolist(),
            "v_hat": s.v_hat.tolist(),
            "q_hat": s.q_hat.tolist(),
            "psi_hat": s.psi_hat.tolist(),
            "apex_height": s.apex_height.tolist(),
            "max_field_hat": s.max_field.tolist(),
            "min_tension_hat": s.min_tension.tolist(),
            "limit_points": [lp.to_dict() for lp in self.limit_points],
            "relative_tolerance": self.rtol,
        }
        if self.family == "pressure_volume":
            out["phi_hat"] = self.fixed
            out["p_hat"] = s.p_hat.tolist()
        else:
            out["p_hat"] = self.fixed
            out["phi_hat"] = s.phi_hat.tolist()
            out["p_hat_residual_max"] = float(np.max(np.abs(s.p_hat - self.fixed))) if s.p_hat.size else 0.0
        if s.wrinkled_radii is not None:  # a tension-field model: where each state is wrinkled
            out["wrinkled_fraction"] = s.wrinkled_fraction.tolist()
            out["wrinkled_radii"] = [[list(map(float, w)) for w in ws] for ws in s.wrinkled_radii]
        if self.starts_because:
            out["starts_because"] = self.starts_because
        if self.stopped_because:
            out["stopped_because"] = self.stopped_because
        return out

    def to_xarray(self):
        """The curve as an :class:`xarray.Dataset` (:func:`coexist.labelled.curve_dataset`): dimension ``state``
        with coordinate ``pole_stretch``, the normalised quantities with their normalisation in ``long_name``.

        Returns
        -------
        xarray.Dataset
        """
        from .labelled import curve_dataset

        return curve_dataset(self)


def _take(states: MembraneStates, index) -> MembraneStates:
    kw = {}
    for name, value in states.__dict__.items():
        if isinstance(value, np.ndarray):
            kw[name] = value[index]
        elif name in ("shapes", "wrinkled_radii") and value is not None:
            kw[name] = [value[i] for i in np.arange(len(value))[index]]
        elif name == "derivatives" and value is not None:
            kw[name] = value.take(index)
        else:
            kw[name] = value
    return MembraneStates(**kw)


#: at most this many stretches of one failure are named in a curve's "no valid state anywhere" (the rest counted)
FAILURES_NAMED = 3


def _failures_along(status, pole_stretch, why) -> str:
    """The failures along a grid without a valid state, a stretch of equal status at a time: "at 2.394: <why>; from
    2.508 to 4 (14 states), at 2.508: <why>" (the first :data:`FAILURES_NAMED` stretches; a user had been told only
    the first state's, which may be the odd one out)."""
    cuts = np.flatnonzero(np.diff(status) != 0) + 1
    starts, ends = np.r_[0, cuts], np.r_[cuts, status.size] - 1
    parts = []
    for a, b in zip(starts[:FAILURES_NAMED], ends[:FAILURES_NAMED]):
        group = "" if a == b else f"from {pole_stretch[a]:.4g} to {pole_stretch[b]:.4g} ({b - a + 1} states), "
        parts.append(f"{group}at {pole_stretch[a]:.4g}: {why(a)}")
    if starts.size > FAILURES_NAMED:
        parts.append(f"and {starts.size - FAILURES_NAMED} more stretches of failures")
    return "; ".join(parts)


def _valid_run(states: MembraneStates, pole_stretch, explain=None):
    """The first contiguous run of valid states, and why the range was cut before and after it (``explain(i)``, if
    given, says why state ``i`` has no voltage, for the status ``NO_VOLTAGE``)."""

    def why(i):
        code = states.status[i]
        if explain is not None and code == NO_VOLTAGE:
            return explain(i)
        return reason_text(code)

    ok = states.ok
    if not ok.any():
        raise NoStateInRange(
            f"no valid state anywhere in pole stretch {pole_stretch[0]:.4g}..{pole_stretch[-1]:.4g}"
            f" ({_failures_along(states.status, pole_stretch, why)})",
            reason_tag(states.status[0]),
        )
    run = first_valid_run(ok)
    first, last = run.start, run.stop - 1
    starts = None
    if first > 0:
        code = states.status[first - 1]
        starts = f"{reason_tag(code)}: below pole stretch {pole_stretch[first]:.6g} {why(first - 1)}"
    stopped = None
    if last + 1 < ok.size:
        code = states.status[last + 1]
        stopped = f"{reason_tag(code)}: beyond pole stretch {pole_stretch[last]:.6g} {why(last + 1)}"
    return run, starts, stopped


def _limit_point(kind: str, s: MembraneStates) -> LimitPoint:
    return LimitPoint(
        kind=kind,
        pole_stretch=float(s.pole_stretch[0]),
        p_hat=float(s.p_hat[0]),
        v_hat=float(s.v_hat[0]),
        phi_hat=float(s.phi_hat[0]),
        q_hat=float(s.q_hat[0]),
        psi_hat=float(s.psi_hat[0]),
    )


#: a node's exact slope (the variational equations) is asked for at both ends of the valid run, where the
#: secant slopes of the grid on either side of a node differ in sign or by more than this factor (an extremum,
#: or a bend sharp enough to hide a pair of them within one interval, is near), and next to every such node
SHARP_BEND = 4.0
#: an exact node slope smaller than this fraction of the secant slopes beside it is taken to be zero: its sign is
#: not used, the secants decide (the slopes' own noise is about 1e-11 absolute; a larger fraction, 1e-6, hid an
#: extremum in the last interval when the run ended within 1e-7 of another: review, helper-61)
SLOPE_NOISE = 1e-9


@dataclass(frozen=True)
class _Bracket:
    """An extremum (``is_max``, named ``kind``) of the quantity ``attr`` between the grid nodes ``lo < hi``."""

    attr: str
    kind: str
    is_max: bool
    lo: int
    hi: int


def _slope_rows(states: MembraneStates, quantities) -> np.ndarray:
    """The grid nodes whose exact slopes :func:`_grid_extrema` needs: both ends, every node where the secant
    slopes of a quantity on either side differ in sign or by more than :data:`SHARP_BEND`, and their
    neighbours."""
    n = states.pole_stretch.size
    flagged = np.zeros(n, dtype=bool)
    flagged[[0, n - 1]] = True
    for attr in quantities:
        d = np.diff(getattr(states, attr)) / np.diff(states.pole_stretch)
        a, b = np.abs(d[:-1]), np.abs(d[1:])
        with np.errstate(all="ignore"):
            sharp = (d[:-1] * d[1:] <= 0) | (np.maximum(a, b) > SHARP_BEND * np.minimum(a, b))
        centre = np.flatnonzero(sharp) + 1
        for k in (-1, 0, 1):
            flagged[np.clip(centre + k, 0, n - 1)] = True
    return np.flatnonzero(flagged)


def _grid_extrema(
    states: MembraneStates, quantities, slopes=None, resolution: float = 0.0, probe=None
) -> list[_Bracket]:
    """Every extremum of the named quantities that the grid shows, with its bracket of grid nodes.

    Along the grid the slope of a quantity is sampled in order by the secant ``(f[i+1] − f[i])/(λ0[i+1] −
    λ0[i])`` of every interval (it equals the slope somewhere inside) and, where ``slopes`` gives it, the
    exact slope at a node (:data:`SLOPE_NOISE`). Between two consecutive samples whose signs differ lies an
    extremum (a maximum where the slope turns negative); its bracket spans both samples: two intervals
    ``[λ0[i−1], λ0[i+1]]`` between two secants (the discrete extremum at node ``i``), one interval next to a
    node slope. So a node slope finds an extremum in the first or last interval of the grid, and two in one
    interval (both node slopes of the sign opposite to its secant) or on either side of one node.

    Parameters
    ----------
    states : MembraneStates
        A valid run of states along increasing pole stretches.
    quantities : dict
        Attribute (``p_hat``) → its pair of kinds (``("pressure_max", "pressure_min")``).
    slopes : dict, optional
        Attribute → exact ``d(attr)/dλ0`` along the curve at every node (NaN where not known).
    resolution : float
        The values' relative error (the solver's ``rtol``): extrema whose swing is below it are dropped
        (:func:`_resolved`).
    probe : callable, optional
        ``probe(λ0) -> {attribute: exact slope}`` at points between the nodes (:func:`_resolved`).

    Returns
    -------
    list of _Bracket
        In the order of the quantities, then of the pole stretch.
    """
    grid = states.pole_stretch
    brackets = []
    for attr, (max_kind, min_kind) in quantities.items():
        values = getattr(states, attr)
        d = np.diff(values) / np.diff(grid)
        exact = None if slopes is None else slopes.get(attr)
        samples = []  # (first node, last node, sign)
        for i in range(grid.size):
            if exact is not None and np.isfinite(exact[i]):
                beside = np.abs(d[max(i - 1, 0) : i + 1])
                if abs(exact[i]) > SLOPE_NOISE * float(beside.max(initial=0.0)):
                    samples.append((i, i, np.sign(exact[i])))
            if i < d.size and np.isfinite(d[i]) and d[i] != 0:
                samples.append((i, i + 1, np.sign(d[i])))
        found = []
        for (lo, _, s0), (_, hi, s1) in zip(samples, samples[1:]):
            if s0 != s1:
                is_max = bool(s0 > 0)
                found.append(_Bracket(attr, max_kind if is_max else min_kind, is_max, lo, hi))
        brackets += _resolved(
            found, values, resolution, grid, exact, None if probe is None else (lambda x, a=attr: probe(x)[a])
        )
    return brackets


def _resolved(brackets: list, values: np.ndarray, resolution: float, grid=None, exact=None, probe=None) -> list:
    """The extrema of one quantity (in order along the grid) that stand out of the values' noise.

    Each extremum's value is estimated: in a bracket of one interval with the exact slopes ``exact`` at both
    ends, as the extremum of the interval's cubic Hermite interpolant; otherwise as the extreme grid value in
    its bracket. The adjacent maximum and minimum whose values differ least are dropped together while they
    differ by at most ``resolution`` times the larger (their swing is below the states' own error: noise on a
    flat stretch, near the centre of a spiral), unless both are confirmed by the exact slopes at their
    brackets' ends (those are far less noisy than differences of values: at rtol 1e-6 a pair of Φ̂–Q̂
    extrema whose swing was 3e-7 relative, real to 1e-8, was dropped by the swing alone: review, helper-63).
    What is left are the extrema that persist (a maximum kept is the highest of those merged into it). A
    maximum and minimum in one interval are confirmed by ``probe``, the exact slope between them, if given. An
    extremum left over at either end is kept: the slope's sign changes across the flat stretch, so there is
    one (a rule that also dropped one within noise of the curve's end value lost a genuine pressure maximum 1.5
    intervals from the start of a fine grid at rtol 1e-6)."""
    if resolution <= 0 or not brackets:
        return brackets
    items = list(brackets)
    peak = []
    for b in items:
        value = np.nan
        if b.hi - b.lo == 1 and grid is not None and exact is not None and np.isfinite(exact[b.lo] + exact[b.hi]):
            poly = _interval_cubic(grid, values, exact, b.lo)
            offset = _cubic_extremum(poly, grid[b.hi] - grid[b.lo], b.is_max)
            value = float(poly(offset)) if np.isfinite(offset) else np.nan
        if not np.isfinite(value):
            value = float(values[b.lo : b.hi + 1].max() if b.is_max else values[b.lo : b.hi + 1].min())
        peak.append(value)

    def floor(a, b):
        return resolution * max(abs(a), abs(b))

    def confirmed(b):  # the exact slopes at both ends of its bracket rise into it and fall out of it (a maximum)
        if exact is None or not np.isfinite(exact[b.lo] + exact[b.hi]):
            return False
        sign = 1.0 if b.is_max else -1.0
        return bool(sign * exact[b.lo] > 0 > sign * exact[b.hi])

    sure = [confirmed(b) for b in items]
    if probe is not None and grid is not None and exact is not None:
        # a maximum and a minimum in one interval (both end slopes of one sign): the exact slope between the
        # cubic's two stationary points confirms them if it has the other sign (one batched call)
        pairs, points = [], []
        for k in range(len(items) - 1):
            a, b = items[k], items[k + 1]
            if a.lo == b.lo and a.hi == b.hi == a.lo + 1 and not (sure[k] and sure[k + 1]):
                if not np.isfinite(exact[a.lo] + exact[a.hi]):
                    continue
                poly = _interval_cubic(grid, values, exact, a.lo)
                h = grid[a.hi] - grid[a.lo]
                first, second = _cubic_extremum(poly, h, a.is_max), _cubic_extremum(poly, h, b.is_max)
                middle = 0.5 * (first + second) if np.isfinite(first + second) else 0.5 * h
                pairs.append(k)
                points.append(grid[a.lo] + middle)
        if pairs:
            slope = np.asarray(probe(np.array(points)), dtype=float)
            for k, t in zip(pairs, slope):
                if np.isfinite(t) and (t < 0 if items[k].is_max else t > 0):
                    sure[k] = sure[k + 1] = True
    while len(items) > 1:
        swings = [
            abs(peak[k] - peak[k + 1]) - floor(peak[k], peak[k + 1]) if not (sure[k] and sure[k + 1]) else np.inf
            for k in range(len(items) - 1)
        ]
        k = int(np.argmin(swings))
        if swings[k] > 0:
            break
        del items[k : k + 2], peak[k : k + 2], sure[k : k + 2]
    return items


class _FailsInside(SolverError):
    """A state between two valid grid states fails (met while locating a limit point): the curve's first run of
    valid states ends before it (:func:`_trace`). Where nobody ends the curve there, the solver error it is."""

    def __init__(self, message: str, pole_stretch: float, status: int):
        super().__init__(message)
        self.pole_stretch, self.status = pole_stretch, status


def _before(states: MembraneStates, gap: _FailsInside) -> tuple[MembraneStates, str]:
    """The states of a run up to the grid state before the failing one of ``gap``, and why the run ends there: the run
    of valid states ends before it, as it would on a grid that held it (a tension-field ring at Φ̂ = 0.47 on 15
    points: the states between λ0 = 1.01 and 1.2236 pull in, and the curve had failed as a whole; on 200 points it
    ends at 1.01)."""
    grid = states.pole_stretch
    i = int(np.searchsorted(grid, gap.pole_stretch)) - 1
    if not 0 <= i < grid.size - 1:
        raise gap
    stopped = (
        f"{reason_tag(gap.status)}: beyond pole stretch {grid[i]:.6g} (at {gap.pole_stretch:.6g}, before the next "
        f"state of the grid) {reason_text(gap.status)}"
    )
    return _take(states, slice(0, i + 1)), stopped


def _refine_brackets(states: MembraneStates, brackets, evaluate_states, settings) -> list[LimitPoint]:
    """Locate the extremum in every bracket (:func:`_grid_extrema`) by Chebyshev interpolation on a shrinking
    bracket (:func:`~coexist.numerics.roots.chebyshev_extremum`; the extremum of its kind with the largest
    or smallest value in the bracket), all brackets of one quantity in one call per round. A state there that fails,
    the one at the extremum found too, raises :class:`_FailsInside` (the first such pole stretch and its status)."""
    grid = states.pole_stretch
    found: list = [None] * len(brackets)
    for attr in dict.fromkeys(b.attr for b in brackets):
        sel = [j for j, b in enumerate(brackets) if b.attr == attr]
        failed: list = []  # (pole stretch, status) of every state that failed

        def g_of(x, attr=attr, failed=failed):
            st = evaluate_states(x)
            failed.extend(zip(np.asarray(x, dtype=float)[~st.ok].tolist(), st.status[~st.ok].tolist()))
            return np.where(st.ok, getattr(st, attr), np.nan)

        lo = np.array([grid[brackets[j].lo] for j in sel])
        hi = np.array([grid[brackets[j].hi] for j in sel])
        try:
            x_star, _ = chebyshev_extremum(
                g_of,
                lo,
                hi,
                np.array([brackets[j].is_max for j in sel]),
                ftol=0.5 * settings.rtol,
                xtol=settings.limit_point_xtol,
                nodes=settings.limit_point_nodes,
            )
        except ValueError as exc:
            message = f"no valid state near a limit point of {attr}: {exc}"
            if not failed:
                raise SolverError(message) from None
            x_bad, code = min(failed)
            raise _FailsInside(message, x_bad, int(code)) from None
        at = evaluate_states(x_star)
        if not np.all(at.ok):  # the state at the extremum itself fails: no limit point of NaN leaves here
            bad = np.flatnonzero(~at.ok)
            k = int(bad[np.argmin(np.asarray(x_star)[bad])])  # the first along the curve, as for the others
            message = f"no valid state at a limit point of {attr} (pole stretch {float(x_star[k]):.6g})"
            raise _FailsInside(message, float(x_star[k]), int(at.status[k]))
        for k, j in enumerate(sel):
            found[j] = _limit_point(brackets[j].kind, _take(at, slice(k, k + 1)))
    return found


def _node_slopes(states: MembraneStates, quantities, slopes_at) -> dict | None:
    """The exact slopes :func:`_grid_extrema` uses, at the nodes :func:`_slope_rows` names (``slopes_at(rows)``
    gives them: attribute → array over ``rows``); None without ``slopes_at``."""
    if slopes_at is None or states.pole_stretch.size < 2:
        return None
    rows = _slope_rows(states, quantities)
    known = slopes_at(rows)
    out = {}
    for attr in quantities:
        full = np.full(states.pole_stretch.size, np.nan)
        full[rows] = known[attr]
        out[attr] = full
    return out


#: an interval across which a quantity changes by more than this many times what the exact slopes at both its
#: ends allow (``h max |X'|``), and by more than :data:`JUMP_CHANGE` of its value, holds a jump of the states: by
#: the mean value theorem the change equals ``h X'`` somewhere inside, so a smooth curve would need a slope this
#: much steeper inside than at both ends
JUMP_FACTOR = 10.0
#: ... (a jump is a finite change, not the noise of a flat stretch whose slopes are nearly zero)
JUMP_CHANGE = 1e-3


def _first_jump(states: MembraneStates, quantities, slopes) -> int | None:
    """The first grid interval ``[i, i + 1]`` across which the states jump (:data:`JUMP_FACTOR`), judged where the
    exact slopes at both its ends are known (:func:`_node_slopes` asks for them where the secants bend sharply, as
    they do on either side of a jump); None if there is none. A tension-field ring electrode wrinkles over its whole
    width at once at its onset (Gent 97, ring 0.3–0.7, Φ̂ = 0.3: p̂ 1.3387 → 0.5427 and V̂ 4.295 → 13.83 between λ0
    2.44691 and 2.44692): the states beyond lie on another branch, and a limit point had been reported at the jump
    (review, helper-65)."""
    if slopes is None:
        return None
    h = np.diff(states.pole_stretch)
    first = None
    for attr in quantities:
        values, exact = getattr(states, attr), slopes.get(attr)
        if exact is None:
            continue
        change = np.abs(np.diff(values))
        with np.errstate(all="ignore"):
            allowed = JUMP_FACTOR * h * np.maximum(np.abs(exact[:-1]), np.abs(exact[1:]))
            big = JUMP_CHANGE * np.maximum(np.abs(values[:-1]), np.abs(values[1:]))
        known = np.isfinite(exact[:-1]) & np.isfinite(exact[1:])
        hits = np.flatnonzero(known & (change > allowed) & (change > big))
        if hits.size and (first is None or hits[0] < first):
            first = int(hits[0])
    return first


def _jump_within(states, bracket, slopes, samples, quantities) -> bool:
    """Do the states jump inside the grid interval of ``bracket``, between two of the states the exact-slope
    iteration evaluated there (``samples``, :func:`_slope_extrema`) or its ends: a change ten times what the exact
    slopes on both sides allow (:data:`JUMP_FACTOR`, :data:`JUMP_CHANGE`, as :func:`_first_jump`)? A tension-field
    ring electrode at Φ̂ = 0.4 (Gent 97, ring 0.3–0.7) bulges down (p̂, V̂ < 0) below λ0 = 1.01133 and up above:
    p̂ −0.0237 → 0.0238 within 5e-5 where the slopes are ±2.3; on the default grid that lies inside the first
    interval, whose end slopes allow the change, and pressure and volume minima had been reported there."""
    grid = states.pole_stretch
    points = [
        (grid[i], {a: getattr(states, a)[i] for a in quantities}, {a: slopes[a][i] for a in slopes})
        for i in (bracket.lo, bracket.hi)
    ]
    points = sorted(points + list(samples), key=lambda p: p[0])
    for (xa, va, ta), (xb, vb, tb) in zip(points[:-1], points[1:]):
        for attr in quantities:
            if attr not in ta or attr not in tb or not np.isfinite(ta[attr] + tb[attr] + va[attr] + vb[attr]):
                continue
            change = abs(vb[attr] - va[attr])
            allowed = JUMP_FACTOR * (xb - xa) * max(abs(ta[attr]), abs(tb[attr]))
            if change > allowed and change > JUMP_CHANGE * max(abs(va[attr]), abs(vb[attr])):
                return True
    return False


def _slope_sign_bisection(states, brackets, slopes, slopes_at, samples, quantities) -> None:
    """Bisect each one-interval ``bracket`` whose exact-slope iteration located nothing on the sign of its exact
    slope (opposite at its ends), appending every valid state to its ``samples``, until the slope there is below
    :data:`KINK_SLOPE` of its end slopes (an extremum is near: the values' extremum locates it), the states it
    holds show a jump in :data:`KINK_CONFIRM` rounds in a row (:func:`_jump_within` on the ``quantities``: across a
    jump the slope keeps its size on both sides, and once the two states straddling it are close enough their
    change exceeds what their slopes allow, the more so the closer they get), or :data:`KINK_BISECTIONS` halvings.
    On a 15-point grid of a tension-field ring electrode at Φ̂ = 0.4, and on 60 points at Φ̂ = 0.45, whose first
    interval holds the jump from down- to up-bulged states, the iteration had no start and minima had been reported
    at λ0 ≈ 1.0108 and 1.0128 (review, helper-68). On the default grid that jump (Δp̂ ≈ 0.047 where the slopes are
    ±2.3) shows after one halving; bisecting on to the 24th had cost 3.7 s of relaxed tension-field states, three
    quarters of that curve's time. A smooth rise steep enough to pass for a jump once is resolved as the states
    close in (review, helper-69: a tanh step of width 0.024 in a unit interval, 70 times steeper than the slopes at
    its ends, had been taken for a jump when the first sighting ended the bisection; on 3986 random such steps with
    a parabola, 4 still are with five rounds in a row, 31 with three, 0 with eight; 255 tension-field curves
    showed no such case)."""
    if not brackets:
        return
    grid = states.pole_stretch
    lo = np.array([grid[b.lo] for b in brackets])
    hi = np.array([grid[b.hi] for b in brackets])
    missing = sorted({i for b in brackets for i in (b.lo, b.hi) if not np.isfinite(slopes[b.attr][i])})
    if missing:  # the exact slopes at the bracket's ends (only the curve's ends and bends have them)
        st, slope = slopes_at(grid[missing])
        for row, i in enumerate(missing):
            for a in slopes:
                if a in slope and st.ok[row]:
                    slopes[a][i] = slope[a][row]
    t_lo = np.array([slopes[b.attr][b.lo] for b in brackets])
    t_hi = np.array([slopes[b.attr][b.hi] for b in brackets])
    scale = np.maximum(np.abs(t_lo), np.abs(t_hi))
    open_ = np.isfinite(t_lo * t_hi) & (t_lo * t_hi < 0)
    seen = np.zeros(len(brackets), dtype=int)  # rounds in a row whose states show a jump
    for _ in range(KINK_BISECTIONS):
        idx = np.flatnonzero(open_)
        if idx.size == 0:
            return
        mid = 0.5 * (lo[idx] + hi[idx])
        st, slope = slopes_at(mid)
        for row, j in enumerate(idx.tolist()):
            t = slope[brackets[j].attr][row]
            if not (st.ok[row] and np.isfinite(t)):
                open_[j] = False
                continue
            samples[j].append((mid[row], {a: getattr(st, a)[row] for a in slope}, {a: slope[a][row] for a in slope}))
            if abs(t) <= KINK_SLOPE * scale[j]:
                open_[j] = False  # near an extremum: the slope goes to zero
            elif np.sign(t) == np.sign(t_lo[j]):
                lo[j] = mid[row]
            else:
                hi[j] = mid[row]
            # a jump seen in KINK_CONFIRM rounds in a row (its straddling states each time twice as close) ends it: a
            # smooth rise steep enough to pass for a jump once is resolved as the states close in (review, helper-69)
            seen[j] = seen[j] + 1 if _jump_within(states, brackets[j], slopes, samples[j], quantities) else 0
            if open_[j] and seen[j] >= KINK_CONFIRM:
                open_[j] = False


#: :func:`_slope_sign_bisection`: halvings at most, and the fraction of the end slopes below which the slope counts
#: as going to zero (an extremum near) rather than jumping
KINK_BISECTIONS = 24
KINK_SLOPE = 1e-3
#: ... and the rounds in a row whose states must show the jump (:func:`_jump_within`) before it stops there
KINK_CONFIRM = 5


def _find_limit_points(states, quantities, evaluate_states, settings, slopes_at=None, same_states=False):
    """Locate every extremum of the named quantities that the grid shows (:func:`_grid_extrema`).

    ``quantities`` maps an attribute (``p_hat``) to its pair of kinds (``("pressure_max", "pressure_min")``).
    With ``slopes_at(λ0) -> (states, {attribute: d(attr)/dλ0})`` (exact slopes along the curve), the grid's
    node slopes come from it (:func:`_node_slopes`) and an extremum in one interval with both end slopes is
    the root of its slope (:func:`_slope_extrema`, from the extremum of the interval's cubic Hermite
    interpolant), its state then evaluated again by ``evaluate_states`` unless ``same_states`` (``slopes_at`` gives
    the same states); every other one, and any such root not located, by the extremum of the interpolated values
    (:func:`_refine_brackets`). Where the states jump only those before the jump are searched (after it, for a jump
    in the first interval).

    Returns
    -------
    limit_points : list of LimitPoint
    start : int
        The first node of the curve: 1 where the states jump in the first interval (:func:`_across_jump`), else 0.
    jump : int or None
        The node after which the states jump, if they do (found between nodes by :func:`_first_jump`, inside an
        interval by :func:`_jump_within`): the curve's last.
    """
    node = None if slopes_at is None else (lambda rows: slopes_at(states.pole_stretch[rows])[1])
    slopes = _node_slopes(states, quantities, node)
    jump = _first_jump(states, quantities, slopes)
    if jump is not None:
        return _across_jump(states, jump, quantities, evaluate_states, settings, slopes_at, same_states)
    probe = None if slopes_at is None else (lambda x: slopes_at(x)[1])
    brackets = _grid_extrema(states, quantities, slopes, settings.rtol, probe) if states.pole_stretch.size > 1 else []
    if not brackets:
        return [], 0, None
    found: list = [None] * len(brackets)
    if slopes_at is not None and slopes is not None:
        samples: list = [[] for _ in brackets]
        found = _slope_extrema(states, brackets, slopes, slopes_at, settings, samples)
        unsure = [j for j, (b, lp) in enumerate(zip(brackets, found)) if lp is None and b.hi - b.lo == 1]
        _slope_sign_bisection(
            states, [brackets[j] for j in unsure], slopes, slopes_at, [samples[j] for j in unsure], quantities
        )
        inside = [brackets[j].lo for j in unsure if _jump_within(states, brackets[j], slopes, samples[j], quantities)]
        if inside:
            return _across_jump(states, min(inside), quantities, evaluate_states, settings, slopes_at, same_states)
        done = [j for j, lp in enumerate(found) if lp is not None]
        # the states at the roots as the curve's own evaluation gives them (a shot with derivatives takes other
        # steps: 1e-11 apart), unless they are the same
        if done and not same_states:
            at = evaluate_states(np.array([found[j].pole_stretch for j in done]))
            for k, j in enumerate(done):
                found[j] = _limit_point(brackets[j].kind, _take(at, slice(k, k + 1)))
    rest = [j for j, lp in enumerate(found) if lp is None]
    if rest:
        for j, lp in zip(rest, _refine_brackets(states, [brackets[j] for j in rest], evaluate_states, settings)):
            found[j] = lp
    return sorted(found, key=lambda lp: lp.pole_stretch), 0, None


def _across_jump(states, i, quantities, evaluate_states, settings, slopes_at, same_states):
    """:func:`_find_limit_points` on the states before a jump in grid interval ``[i, i + 1]`` (the curve ends
    there), or, for a jump in the first interval, on those after it (the curve starts there: a single state before
    it is no curve). Returns ``(limit points, start, end)`` with ``start``, ``end`` indices of ``states``."""
    n = states.pole_stretch.size
    if i == 0 and n > 2:
        limits, start, end = _find_limit_points(
            _take(states, slice(1, n)), quantities, evaluate_states, settings, slopes_at, same_states
        )
        return limits, 1 + start, None if end is None else 1 + end
    limits, start, end = _find_limit_points(
        _take(states, slice(0, i + 1)), quantities, evaluate_states, settings, slopes_at, same_states
    )
    return limits, start, i if end is None else end


def _cubic_extremum(poly, h, is_max) -> float:
    """The first stationary point of its kind in ``(0, h)`` of a cubic (:func:`_interval_cubic`), NaN if none."""
    roots = poly.deriv().roots()
    roots = roots[np.abs(roots.imag) <= 1e-9 * h].real
    sign = -1.0 if is_max else 1.0
    roots = roots[(roots > 0) & (roots < h) & (sign * poly.deriv(2)(roots) > 0)]
    return float(roots[0]) if roots.size else np.nan


def _slope_extrema(states, brackets, slopes, slopes_at, settings, samples=None) -> list:
    """Extrema at a fixed parameter (a ``p̂–V̂`` curve's ``Φ̂``) as roots of their exact slopes ``t(λ0)``.

    A bracket of one interval with the exact slope at both ends starts at the extremum of the cubic Hermite
    interpolant there (values and exact slopes), with its curvature; each step is ``−t/t'`` with ``t'`` the
    secant of the last two slopes (first: the cubic's), all brackets in one shot with derivatives. Located as
    :func:`_slope_roots` locates them (the step at most ``limit_point_xtol/10``, or at most ``limit_point_xtol``
    and no longer shrinking; the slope falls through a maximum); None for a bracket without a start, or whose
    step leaves it or meets an invalid state. (The extremum of interpolated values is located only to about the
    square root of the values' noise where the curve is flat: 1e-7 in λ0 at rtol 1e-10, review, helper-61.)
    ``samples``, if given (a list per bracket), receives ``(λ0, values, exact slopes)`` of every valid state the
    iteration evaluates (:func:`_jump_within`)."""
    grid = states.pole_stretch
    m = len(brackets)
    lam, curvature = np.full(m, np.nan), np.full(m, np.nan)
    for j, b in enumerate(brackets):
        exact = slopes.get(b.attr)
        if b.hi - b.lo != 1 or exact is None or not np.isfinite(exact[b.lo] + exact[b.hi]):
            continue
        poly = _interval_cubic(grid, getattr(states, b.attr), exact, b.lo)
        offset = _cubic_extremum(poly, grid[b.hi] - grid[b.lo], b.is_max)
        if np.isfinite(offset):
            lam[j], curvature[j] = grid[b.lo] + offset, poly.deriv(2)(offset)
    found: list = [None] * m
    lo_b = np.array([grid[b.lo] for b in brackets])
    hi_b = np.array([grid[b.hi] for b in brackets])
    is_max = np.array([b.is_max for b in brackets])
    open_ = np.isfinite(lam) & np.isfinite(curvature)
    lam_prev, t_prev, step_prev = np.full(m, np.nan), np.full(m, np.nan), np.full(m, np.inf)
    for _ in range(LIMIT_POINT_ITERATIONS):
        idx = np.flatnonzero(open_)
        if idx.size == 0:
            break
        st, slope = slopes_at(lam[idx])
        if samples is not None:
            for row, b_j in enumerate(idx.tolist()):
                if st.ok[row]:
                    values = {a: getattr(st, a)[row] for a in slope}
                    samples[b_j].append((lam[b_j], values, {a: slope[a][row] for a in slope}))
        t = np.array([slope[brackets[j].attr][k] for k, j in enumerate(idx)])
        iterate = (lam, lam_prev, t_prev, curvature, step_prev)
        _, located, done = _secant_round(idx, t, st.ok, st.ok, iterate, is_max, lo_b, hi_b, settings.limit_point_xtol)
        for k in np.flatnonzero(located):
            found[idx[k]] = _limit_point(brackets[idx[k]].kind, _take(st, slice(k, k + 1)))
        open_[idx[done]] = False
    return found


def _secant_round(idx, t, ok, met, iterate, is_max, lo_b, hi_b, xtol):
    """One round of the secant iteration on exact slopes along a curve, shared by :func:`_slope_extrema` and
    :func:`_slope_roots`: at ``λ0 = lam[idx]`` the slopes ``t`` (``ok`` where valid, ``met`` where the state is on
    the curve); the step ``−t/t'`` with ``t'`` the secant of the last two slopes (first: the given curvature).
    Located when the state is met and the step is at most ``xtol/10`` (relative), or at most ``xtol`` and no
    longer shrinking, and the slope falls through a maximum (rises through a minimum); given up when the state
    is invalid, the step not finite or of the wrong kind, or it leaves ``(lo_b, hi_b)``. ``iterate = (lam,
    lam_prev, t_prev, curvature, step_prev)`` is updated in place (``lam`` moves by the step where not done).
    Returns ``(step, located, done)`` over ``idx``."""
    lam, lam_prev, t_prev, curvature, step_prev = iterate
    with np.errstate(all="ignore"):
        dlam = lam[idx] - lam_prev[idx]
        usable = np.abs(dlam) > 1e-12 * np.abs(lam[idx])
        secant = np.where(usable, (t - t_prev[idx]) / dlam, np.nan)
        curvature[idx] = np.where(usable & np.isfinite(secant), secant, curvature[idx])
        step = -t / curvature[idx]
    size = np.abs(step)
    tol = xtol * np.abs(lam[idx])
    bad = ~ok | ~np.isfinite(step)
    located = met & ~bad & ((size <= 0.1 * tol) | ((size <= tol) & (size >= 0.5 * step_prev[idx])))
    # a root of the slope where it falls (a maximum) or rises: two extrema may share a bracket
    wrong_kind = located & ~(np.where(is_max[idx], -1.0, 1.0) * curvature[idx] > 0)
    bad |= wrong_kind
    located &= ~wrong_kind
    new_lam = lam[idx] + step
    left = ~located & ~bad & ~((new_lam > lo_b[idx]) & (new_lam < hi_b[idx]))
    done = located | bad | left
    lam_prev[idx], t_prev[idx], step_prev[idx] = lam[idx], t, size
    lam[idx] = np.where(done, lam[idx], new_lam)
    return step, located, done


#: the step, relative to ``λ0``, between the two states at the tighter tolerance whose exact slopes give the
#: curvature at a limit point for its measured error (:func:`_limit_point_errors`)
ERROR_STEP = 1e-5


def _limit_point_errors(limit_points, quantities, rtol, fixed, slopes_along) -> None:
    """Measure every limit point's :attr:`~LimitPoint.errors` (in place) by locating it again at a tighter
    tolerance.

    ``slopes_along(λ0, Φ̂) -> (states, slopes)`` gives the curve's states at the pole stretches ``λ0`` at that
    tolerance (``Φ̂``: first guesses of their voltages) and the slopes ``dX/dλ0`` along the curve of every number
    ``X`` of :data:`LIMIT_POINT_FIELDS` (:func:`_slopes_along`). At ``λ0*`` and ``λ0*(1 + ERROR_STEP)`` the slope
    ``t`` of the extremal quantity gives its curvature ``c = Δt/Δλ0``, and one Newton step ``δ = −t(λ0*)/c`` the
    location at the tighter tolerance, where each number is ``X(λ0*) + X' δ + X'' δ²/2`` (``X''`` from the same
    two slopes). The error of each number is :func:`~coexist.settings.measured_error` of its value and the tight
    one (twice the change, plus ``rtol`` of it); the input held fixed (``fixed``: a ``p̂–V̂`` curve's ``Φ̂``) is
    exact. A limit point without a valid state at the tighter tolerance, or whose curvature there is not finite or
    of the other sign (no extremum of its kind is found again), keeps ``errors = None``."""
    if not limit_points:
        return
    attr_of = {kind: attr for attr, kinds in quantities.items() for kind in kinds}
    lam = np.array([lp.pole_stretch for lp in limit_points])
    phi = np.array([lp.phi_hat for lp in limit_points])
    m = lam.size
    h = ERROR_STEP * lam
    st, slope = slopes_along(np.r_[lam, lam + h], np.r_[phi, phi])
    ok = st.ok[:m] & st.ok[m:]
    slopes = {name: slope[name][:m] for name in LIMIT_POINT_FIELDS}
    with np.errstate(all="ignore"):
        curvature = {name: (slope[name][m:] - slopes[name]) / h for name in LIMIT_POINT_FIELDS}
    here = {name: getattr(st, name)[:m] for name in LIMIT_POINT_FIELDS}
    for j, lp in enumerate(limit_points):
        attr = attr_of[lp.kind]
        with np.errstate(all="ignore"):
            delta = -slopes[attr][j] / curvature[attr][j]
        # an extremum of the other kind there (or none): not found again, not measured
        of_its_kind = curvature[attr][j] < 0 if lp.kind == quantities[attr][0] else curvature[attr][j] > 0
        if not (ok[j] and np.isfinite(delta) and of_its_kind):
            continue
        errors = {}
        for name in LIMIT_POINT_FIELDS:
            tight = here[name][j] + slopes[name][j] * delta + 0.5 * curvature[name][j] * delta**2
            errors[name] = 0.0 if name == fixed else measured_error(getattr(lp, name), float(tight), rtol)
        if all(np.isfinite(v) for v in errors.values()):
            lp.errors = errors


def _slopes_along(st: MembraneStates, family: str) -> dict:
    """The slopes ``dX/dλ0`` along a curve of ``family`` of every number of :data:`LIMIT_POINT_FIELDS`, at states
    shot with derivatives (NaN where a state fails): along a ``p̂–V̂`` curve (``Φ̂`` fixed) the partial derivatives
    to ``λ0``; along a ``Φ̂–Q̂`` curve (``p̂`` fixed) ``dΦ̂/dλ0 = −(∂p̂/∂λ0)/(∂p̂/∂Φ̂)`` and ``dX/dλ0 = ∂X/∂λ0 +
    (∂X/∂Φ̂) dΦ̂/dλ0``; ``dΨ̂ = p̂ dV̂ − Q̂ dΦ̂`` for the potential."""
    dv = StateDerivatives.of(st)
    with np.errstate(all="ignore"):
        g = np.zeros(st.p_hat.size) if family == "pressure_volume" else -dv.dp_dl0 / dv.dp_dphi
        v = dv.dv_dl0 + dv.dv_dphi * g
        out = {
            "pole_stretch": np.ones(st.p_hat.size),
            "p_hat": dv.dp_dl0 + dv.dp_dphi * g,
            "v_hat": v,
            "phi_hat": g,
            "q_hat": dv.dq_dl0 + dv.dq_dphi * g,
            "psi_hat": st.p_hat * v - st.q_hat * g,
        }
    return {k: np.where(st.ok, x, np.nan) for k, x in out.items()}


def _refuse_huge_curve(points: int, patterned: bool = False) -> None:
    """Refuse, before any state is shot, a curve whose states would pass the memory or output limits of
    :mod:`coexist.cost` (as ``coexist curves`` is refused): ``SolverSettings(curve_points=10**7)`` allocated until a
    MemoryError (a raw numpy error) or the machine's memory ran out."""
    from .cost import (
        CURVES_BYTES_PER_PATTERNED_STATE,
        CURVES_BYTES_PER_STATE,
        CURVES_NUMBERS_PER_STATE,
        MAX_MEMORY_BYTES,
        MAX_OUTPUT_NUMBERS,
    )

    per_state = CURVES_BYTES_PER_PATTERNED_STATE if patterned else CURVES_BYTES_PER_STATE
    if points * per_state > MAX_MEMORY_BYTES or points * CURVES_NUMBERS_PER_STATE > MAX_OUTPUT_NUMBERS:
        fits = int(min(0.9 * MAX_MEMORY_BYTES / per_state, 0.9 * MAX_OUTPUT_NUMBERS / CURVES_NUMBERS_PER_STATE))
        raise SceneError(
            f"a curve of {points:,} pole stretches would need about {points * per_state / 1e9:.3g} GB and give "
            f"{points * CURVES_NUMBERS_PER_STATE:,} numbers; the limits are {MAX_MEMORY_BYTES / 1e9:g} GB and "
            f"{MAX_OUTPUT_NUMBERS:,} numbers: give {fits:,} or fewer (pole_stretch, or settings.curve_points / "
            "charge_curve_points)",
            "pole_stretch",
        )


def _check_range(pole_stretch, model):
    l0 = validation.real_array(pole_stretch, "pole_stretch")
    if l0.ndim != 1 or l0.size < 3:
        raise SceneError("needs at least 3 pole stretches", "pole_stretch")
    _refuse_huge_curve(l0.size, getattr(model, "pattern", None) is not None)
    if np.any(np.diff(l0) <= 0):
        raise SceneError("pole stretches must increase", "pole_stretch")
    if l0[0] <= model.prestretch:
        raise SceneError(f"pole stretch must exceed the prestretch {model.prestretch:g}, got {l0[0]:g}", "pole_stretch")
    return l0


def pressure_volume_curve(
    model: MembraneModel, phi_hat: float = 0.0, pole_stretch=None, settings: SolverSettings | None = None
) -> Curve:
    """The ``p̂–V̂`` curve of a clamped zone at fixed normalised voltage ``Φ̂``.

    Parameters
    ----------
    model : MembraneModel
        The membrane.
    phi_hat : float
        ``Φ̂ = (Φ/H)√(ε/μ)``.
    pole_stretch : array_like, optional
        Increasing pole stretches; default ``settings.curve_points`` (200) from ``1.01 λpre`` to ``4``
        (to ``1.5 λpre`` if that is larger).
    settings : SolverSettings, optional
        Tolerances and sample counts; default ``SolverSettings()``.

    Returns
    -------
    Curve
        With the pressure maxima/minima (and volume folds) refined to the solver tolerance.

    Raises
    ------
    SceneError
        Fewer than 3 pole stretches, not increasing or not above ``λpre``; an invalid voltage.
    ModelRangeError
        No valid state anywhere on the grid (the reason of the first).
    SolverError
        No valid state near a limit point while refining it (a state found failing between two valid states of
        the grid ends the curve before it instead: ``stopped_because`` names it).

    Examples
    --------
    >>> from coexist import MembraneModel, pressure_volume_curve
    >>> c = pressure_volume_curve(MembraneModel(), phi_hat=0.0)
    >>> round(c.limit_points[0].p_hat, 3)
    1.879
    """
    settings = validation.settings_or_default(settings)
    validation.membrane_model(model)
    phi_hat = validation.real(phi_hat, "phi_hat", lo=0.0)
    return _trace(
        "pressure_volume",
        phi_hat,
        model,
        pole_stretch,
        settings.curve_points,
        lambda x: solve_states(model, x, phi_hat, settings),
        {"p_hat": ("pressure_max", "pressure_min"), "v_hat": ("volume_max", "volume_min")},
        settings,
        lambda x: _pressure_volume_slopes(model, x, phi_hat, settings),
        lambda x, _: _pressure_volume_slopes(model, x, phi_hat, error_reference(settings)),
    )


def _pressure_volume_slopes(model, l0, phi_hat, settings) -> tuple[MembraneStates, dict]:
    """The states at ``λ0`` and fixed ``Φ̂`` with the slopes of :func:`_slopes_along` (``dp̂/dλ0``, ``dV̂/dλ0``, ...;
    the variational equations; NaN where a state fails)."""
    st = solve_states(model, l0, phi_hat, settings, derivatives=True)
    return st, _slopes_along(st, "pressure_volume")


def _trace(
    family,
    fixed,
    model,
    pole_stretch,
    points,
    evaluate,
    quantities,
    settings,
    slopes_at=None,
    errors_along=None,
    same_states=False,
) -> Curve:
    """A curve of ``family`` from ``evaluate(λ0) -> MembraneStates`` on ``pole_stretch`` (default: ``points``
    from ``1.01 λpre`` to ``max(4, 1.5 λpre)``): its valid run, and the extrema of ``quantities`` located
    (with the exact slopes of ``slopes_at(λ0) -> (states, {attribute: d(attr)/dλ0})``, if given:
    :func:`_find_limit_points`), with their errors measured (:func:`_limit_point_errors`) by
    ``errors_along(λ0, Φ̂)``, the same at the tighter tolerance. ``same_states``: the states ``slopes_at`` gives
    are those ``evaluate`` gives (its derivatives computed apart, as a patterned zone's are), so a limit point's
    state need not be evaluated again."""
    if pole_stretch is None:
        _refuse_huge_curve(points, getattr(model, "pattern", None) is not None)
        pole_stretch = np.linspace(1.01 * model.prestretch, max(4.0, 1.5 * model.prestretch), points)
    l0 = _check_range(pole_stretch, model)
    states = evaluate(l0)
    run, starts, stopped = _valid_run(states, l0)
    states = _take(states, run)
    while True:
        try:
            limits, start, jump = _find_limit_points(states, quantities, evaluate, settings, slopes_at, same_states)
            break
        except _FailsInside as gap:
            states, stopped = _before(states, gap)
    grid = states.pole_stretch

    def changes(i):
        return ", ".join(
            f"{name} {getattr(states, attr)[i]:.6g} → {getattr(states, attr)[i + 1]:.6g}"
            for name, attr in (("p̂", "p_hat"), ("V̂", "v_hat"))
        )

    if jump is not None:
        stopped = (
            f"jump: beyond pole stretch {grid[jump]:.6g} the states change discontinuously (at {grid[jump + 1]:.6g}: "
            f"{changes(jump)}), to another branch of equilibria; the curve ends before it"
        )
    if start:
        starts = (
            f"jump: below pole stretch {grid[start]:.6g} the states change discontinuously (from "
            f"{grid[start - 1]:.6g}: {changes(start - 1)}), from another branch of equilibria; the curve starts "
            "after it"
        )
    states = _take(states, slice(start, None if jump is None else jump + 1))
    if errors_along is not None:
        _limit_point_errors(limits, quantities, settings.rtol, "phi_hat", errors_along)
    return Curve(family, float(fixed), states, limits, starts, stopped, settings.rtol)


def _pole_voltage_squared(model: MembraneModel, l0: np.ndarray) -> np.ndarray:
    """``s_pole = Φ̂²`` at which the pole tension ``T̂1(λ0, λ0; Φ̂)`` vanishes, per pole stretch (grown by
    doubling from 1, then located to 1e-15): no state exists at or above it. Zero where the pole tension
    is not positive (or not defined: Gent locking) even without voltage.

    A patterned zone (a model with a ``pattern``): its pole region of ``n1`` layers carries ``Φ̂/n1`` per layer,
    so its pole wrinkles at ``n1²`` times the one-layer ``s_pole``; a pole region without electrode does not
    wrinkle by the voltage at all, and the bound is then ``4 max_k nk²`` times the one-layer value over the
    electrode regions ``k`` (states fail well before it: the voltage search brackets their failure)."""
    pattern = getattr(model, "pattern", None)
    if pattern is not None:
        one = _pole_voltage_squared(getattr(model, "uniform", model), l0)
        pole = pattern.regions[0]
        if pole.electrode:
            return pole.layers**2 * one
        return 4.0 * max((r.layers**2 for r in pattern.regions if r.electrode), default=1) * one
    n = l0.size
    s_pole = np.zeros(n)
    with np.errstate(all="ignore"):
        t0 = np.broadcast_to(np.asarray(model.pole(l0, 0.0)[0], dtype=float), (n,))
        live = np.flatnonzero(np.isfinite(t0) & (t0 > 0))
        if live.size == 0:
            return s_pole
        lv = l0[live]
        hi_s = np.ones(live.size)
        for _ in range(60):
            grow = model.pole(lv, np.sqrt(hi_s))[0] > 0
            if not np.any(grow):
                break
            hi_s = np.where(grow, hi_s * 2, hi_s)
        root = bracketed_root(
            lambda x, idx: model.pole(lv[idx], np.sqrt(x))[0], np.zeros(live.size), hi_s, rtol=1e-15, ftol=1e-14 * lv
        )
    s_pole[live] = root.x
    return s_pole


#: a Newton step from the valid lower end that overshoots a failed upper end by this many bracket widths
#: shows that the pressure is not reached before the states fail (see :meth:`_VoltageRoots.newton`)
NO_ROOT_OVERSHOOT = 10.0
#: ... once the bracket is at most this fraction of the voltage (the slope cannot change much across it)
NO_ROOT_WIDTH = 1e-2
#: ... and until then the next voltage tried lies this far from the valid lower end towards the failed one
LEAN = 0.9
#: a pressure residual of a shot without derivatives counts for the bracket only above this multiple of ``p̂``:
#: shots with and without derivatives take different steps and differ at the 1e-11 level
PLAIN_SIGN_LEVEL = 1e-8
#: a Newton step below this fraction of ``s`` is the noise of the shooting (at ``rtol ≤ 1e-12`` the residual
#: ``inner_ftol p̂`` lies at the level of rounding): the voltage has converged
NOISE_STEP = 1e-14
#: Newton steps below this fraction of ``s`` are taken even when they do not halve (near the root the
#: shooting's noise, not a poor model, keeps them from shrinking)
NEAR_STEP = 1e-9
_DERIVATIVE_FIELDS = ("dp_dl0", "dv_dl0", "dq_dl0", "dp_dphi", "dv_dphi", "dq_dphi")


def _inverse_hermite_root(fa, xa, da, fb, xb, db):
    """``s(0)`` of the cubic Hermite interpolant of the inverse function ``s(f)`` through ``(fa, xa)`` and
    ``(fb, xb)`` with slopes ``1/da`` and ``1/db`` (vectorised; NaN where ``fa = fb``)."""
    h = fb - fa
    z = -fa / h
    h00, h10 = 2 * z**3 - 3 * z**2 + 1, z**3 - 2 * z**2 + z
    h01, h11 = -2 * z**3 + 3 * z**2, z**3 - z**2
    return h00 * xa + h10 * h / da + h01 * xb + h11 * h / db


def _inverse_quadratic_root(f0, f, x, d):
    """``s(0)`` of the inverse quadratic ``s(f)`` through ``(f, x)`` with slope ``1/d`` and through ``(f0, 0)``
    (the zero-voltage state): Newton's step with the curvature of the inverse function."""
    c = -(x + (f0 - f) / d) / (f0 - f) ** 2
    return x - f / d + c * f**2


class _VoltageRoots:
    """The roots ``p̂(λ0, s) = p̂`` in ``s = Φ̂²`` at many pole stretches, with the bookkeeping of the
    voltage search: the bracket of every root (``lo`` with ``p̂(lo) > p̂``, ``hi`` beyond the root: a
    pressure below ``p̂``, a failed state, or the pole-wrinkling voltage), every state evaluated (the last
    valid one is kept, with its derivatives when it was shot with them), and whether a root was found.

    ``states0``, if given, are the zero-voltage states of every pole stretch; otherwise they are shot on
    demand (:meth:`zero`) and a pole stretch without one is ``known = False``. A pole stretch whose
    ``p̂(λ0, 0) < p̂`` (or whose zero-voltage state fails) carries no voltage that reaches the pressure and is
    finished as soon as that is known; one not (yet) shot at zero voltage is taken to be feasible (the
    pressure falls as the voltage rises, so a root found proves it).
    """

    def __init__(self, model, l0, p_hat, settings, states0=None):
        self.model, self.l0, self.p_hat, self.settings = model, l0, p_hat, settings
        n = l0.size
        self.ftol = settings.inner_ftol * p_hat
        self.s_pole = _pole_voltage_squared(model, l0)
        self._result: MembraneStates | None = None  # created from the first states shot
        self.known = np.zeros(n, dtype=bool)  # the zero-voltage state was shot
        self.status0 = np.full(n, NO_VOLTAGE)
        self.f0 = np.full(n, np.nan)
        self.feasible = np.ones(n, dtype=bool)
        self.shot = np.zeros(n, dtype=bool)  # shot at a voltage
        self.derivatives = {k: np.full(n, np.nan) for k in _DERIVATIVE_FIELDS}
        self.converged = np.zeros(n, dtype=bool)
        self.finished = np.zeros(n, dtype=bool)
        self.lo, self.f_lo = np.zeros(n), np.full(n, np.nan)
        self.hi, self.f_hi = self.s_pole.copy(), np.full(n, -np.inf)  # no state at the pole-wrinkling voltage
        self.status_hi = np.full(n, WRINKLED_AT_POLE)  # why there is no state at ``hi`` (when ``f_hi = −∞``)
        self.f_last = np.full(n, np.nan)
        if states0 is not None:
            self._record_zero(np.arange(n), states0)

    @property
    def result(self) -> MembraneStates:
        """Every pole stretch's state so far (the last valid one evaluated)."""
        if self._result is None:
            raise SolverError("internal: no state of the voltage search has been shot yet")
        return self._result

    def zero(self, rows):
        """Shoot the zero-voltage states of ``rows`` (one batch) and record them (:meth:`_record_zero`)."""
        rows = np.asarray(rows, dtype=int)
        if rows.size:
            self._record_zero(rows, solve_states(self.model, self.l0[rows], 0.0, self.settings))

    def _record_zero(self, rows, st):
        """The zero-voltage states ``st`` of ``rows``: ``f0 = p̂(λ0, 0) − p̂`` (``−∞`` for a failed state) is
        the lower end of the bracket; ``f0 < 0`` finishes the problem (no root), ``f0 = 0`` converges it. A
        state not yet shot at a voltage starts as this one."""
        if self._result is None:
            self._result = _blank_states(st, self.l0)
        f0 = np.where(st.ok, st.p_hat - self.p_hat, -np.inf)
        fresh = ~self.shot[rows]
        _merge(self.result, _take(st, fresh), rows[fresh])
        self.f_last[rows[fresh]] = f0[fresh]
        self.known[rows], self.status0[rows], self.f0[rows] = True, st.status, f0
        feasible = f0 >= 0
        self.feasible[rows] = feasible
        self.f_lo[rows] = f0
        done = feasible & (f0 == 0)
        self.converged[rows[done]] = True
        self.finished[rows[~feasible | done]] = True

    def regula_falsi(self, rows):
        """The first guesses of ``rows``: the secant point of the bracket ``[0, s_pole]``, the pressure taken
        to fall to zero at the pole-wrinkling voltage (as the spherical-cap estimate, proportional to the
        pole tension, does)."""
        f0 = self.f0[rows]
        return self.s_pole[rows] * f0 / (f0 + self.p_hat)

    def _shoot(self, rows, x, derivatives):
        """Shoot ``rows`` at ``s = x`` and record the states; returns (residual, ok, dp/ds)."""
        st = solve_states(self.model, self.l0[rows], np.sqrt(x), self.settings, derivatives=derivatives)
        ok = st.ok
        if self._result is None:
            self._result = _blank_states(st, self.l0)
        self.shot[rows] = True
        _merge(self.result, _take(st, ok), rows[ok])
        self.result.status[rows[~ok]] = st.status[~ok]  # as the old search: the last state evaluated decides
        with np.errstate(all="ignore"):
            if derivatives:
                dv = StateDerivatives.of(st)
                for k in _DERIVATIVE_FIELDS:
                    self.derivatives[k][rows[ok]] = getattr(dv, k)[ok]
                slope = dv.dp_dphi / (2 * np.sqrt(x))
            else:
                for k in _DERIVATIVE_FIELDS:
                    self.derivatives[k][rows[ok]] = np.nan
                slope = np.full(rows.size, np.nan)
        f = np.where(ok, st.p_hat - self.p_hat, -np.inf)  # an invalid state: beyond the root
        self.f_last[rows] = f
        # the bracket (a shot without derivatives moves it only where its sign is beyond doubt)
        clear = np.abs(f) > (0.0 if derivatives else PLAIN_SIGN_LEVEL * self.p_hat)
        below = ok & (f > 0) & clear
        above = ~ok | ((f < 0) & clear)
        self.lo[rows[below]], self.f_lo[rows[below]] = x[below], f[below]
        self.hi[rows[above]], self.f_hi[rows[above]] = x[above], f[above]
        self.status_hi[rows[above]] = st.status[above]
        met = ok & (np.abs(f) <= self.ftol)
        self.converged[rows[met]] = True
        self.finished[rows[met]] = True
        return f, ok, slope

    def newton(self, rows, x, iterations, prune=None, handoff=None):
        """Safeguarded Newton iteration in ``s`` with the exact slope ``∂p̂/∂s = (∂p̂/∂Φ̂)/(2Φ̂)`` on the
        problems ``rows`` from the points ``x`` (all evaluated with derivatives).

        Each step is the root of the inverse cubic Hermite interpolant ``s(p̂)`` of the last two shots
        (values and exact slopes; on the first step the inverse quadratic through the shot and the
        zero-voltage state), which converges faster than Newton's tangent (order ``1 + √3``); it is
        taken when it stays inside the bracket and at most halves the previous step (``rtsafe``),
        else the Newton step under the same conditions, else the bracket is bisected. A problem is
        converged when ``|p̂ − p̂*| ≤ inner_ftol p̂``, or noise-limited when its bracket has closed to
        1e-15 (relative) or the Newton step falls below :data:`NOISE_STEP` of ``s``. It is given up (no
        root) when its upper end is a failed state (or the pole-wrinkling voltage) and the Newton step
        from a valid lower end overshoots that end by :data:`NO_ROOT_OVERSHOOT` bracket widths on a
        bracket narrower than :data:`NO_ROOT_WIDTH` of ``s``: the slope would have to grow that much
        within the bracket for the pressure to reach ``p̂`` before the states fail. ``prune(self)``, if
        given, may finish problems that no longer matter before each round.

        With ``handoff`` (a relative residual), a problem whose shot with derivatives meets
        ``|p̂ − p̂*| ≤ handoff · p̂`` without meeting ``inner_ftol`` leaves the iteration with its next
        point ``s'`` (the step above, inside the bracket) and the slope there,
        ``∂p̂/∂s + (∂²p̂/∂s²)(s' − s)`` (the curvature from the slopes of its last two shots, when it has
        two): the quadratic rate puts ``s'`` within ``O(handoff²)`` of the root, and the shots without
        derivatives that finish it (:meth:`polish`, which takes the same tolerance) cost half as much.
        (A shot without derivatives takes other steps, ~1e-11 apart, so one more step is needed anyway.)

        Returns
        -------
        rows, x, slope : ndarray
            The problems handed off, their next points and slopes (empty without ``handoff``).
        """
        rows = np.asarray(rows)
        x = np.array(x, dtype=float)
        previous = np.full(rows.size, np.inf)
        x1, f1, d1 = (np.full(rows.size, np.nan) for _ in range(3))  # the last valid shot of each problem
        handed = np.zeros(rows.size, dtype=bool)
        handed_slope = np.full(rows.size, np.nan)
        for _ in range(iterations):
            if prune is not None:
                prune(self)
            live = np.flatnonzero(~self.finished[rows] & ~handed)
            if live.size == 0:
                break
            r, xr = rows[live], x[live]
            f, ok, slope = self._shoot(r, xr, derivatives=True)
            lo, hi = self.lo[r], self.hi[r]
            with np.errstate(all="ignore"):
                step = -f / slope
                usable = ok & np.isfinite(step)
                memory = np.where(
                    np.isfinite(x1[live]) & (f1[live] != f),
                    _inverse_hermite_root(f1[live], x1[live], d1[live], f, xr, slope),
                    _inverse_quadratic_root(self.f0[r], f, xr, slope),
                )
            closed = (hi - lo) <= np.maximum(1e-15, 4 * _EPS) * np.abs(xr)
            stalled = usable & (np.abs(step) <= NOISE_STEP * np.abs(xr))
            failed_above = ~np.isfinite(self.f_hi[r])
            no_root = (
                usable
                & (f > 0)
                & failed_above
                & (step >= NO_ROOT_OVERSHOOT * (hi - xr))
                & (hi - xr <= NO_ROOT_WIDTH * hi)
            )
            self.converged[r[closed | stalled]] = True
            self.finished[r[closed | stalled | no_root]] = True
            nxt = np.full(live.size, np.nan)
            for candidate in (memory, xr + step):
                move = np.abs(candidate - xr)
                shrinking = (move <= 0.5 * previous[live]) | (move <= NEAR_STEP * np.abs(xr))
                take = usable & np.isnan(nxt) & np.isfinite(candidate) & (candidate > lo) & (candidate < hi)
                nxt = np.where(take & shrinking, candidate, nxt)
            # the Newton step from a valid state overshoots a failed upper end: the failure may lie just
            # below that end (as at the pole-wrinkling voltage), so look there first
            lean = usable & (f > 0) & failed_above & (xr + step >= hi)
            nxt = np.where(np.isnan(nxt), np.where(lean, lo + LEAN * (hi - lo), 0.5 * (lo + hi)), nxt)
            if handoff is not None:
                stepped = np.isfinite(nxt) & (nxt > lo) & (nxt < hi) & ~np.isnan(nxt)
                leave = usable & stepped & (np.abs(f) <= handoff * self.p_hat) & ~self.finished[r]
                leave &= np.abs(nxt - xr) <= 0.5 * previous[live]  # a Newton-type step, not a bisection
                with np.errstate(all="ignore"):
                    curvature = np.where(
                        np.isfinite(x1[live]) & (x1[live] != xr), (slope - d1[live]) / (xr - x1[live]), 0.0
                    )
                    moved = slope + np.where(np.isfinite(curvature), curvature, 0.0) * (nxt - xr)
                leave &= np.isfinite(moved) & (moved < 0)
                handed[live[leave]] = True
                handed_slope[live[leave]] = moved[leave]
            previous[live] = np.abs(nxt - xr)
            x1[live] = np.where(usable, xr, x1[live])
            f1[live] = np.where(usable, f, f1[live])
            d1[live] = np.where(usable, slope, d1[live])
            x[live] = nxt
        handed &= ~self.finished[rows]
        return rows[handed], x[handed], handed_slope[handed]

    def polish(self, rows, x, slope, rounds, prune=None):
        """Chord steps ``s ← s − (p̂ − p̂*)/slope`` with shots without derivatives, for problems whose guess
        ``x`` and slope ``∂p̂/∂s`` come from converged neighbours (or from their own Newton iteration, see
        ``handoff`` in :meth:`newton`); the slope is replaced by the secant of the last two shots once there
        are two. A step must stay inside the bracket, widened by what a shot without derivatives may differ
        from one with them (:data:`PLAIN_SIGN_LEVEL` ``· p̂`` in pressure); a problem whose step leaves it
        goes to the Newton iteration, from its last valid point. Returns the problems still open and their
        next points."""
        rows, x, slope = np.asarray(rows), np.array(x, dtype=float), np.array(slope, dtype=float)
        x_prev, f_prev = np.full(rows.size, np.nan), np.full(rows.size, np.nan)
        active = np.ones(rows.size, dtype=bool)
        for _ in range(rounds):
            if prune is not None:
                prune(self)
            live = np.flatnonzero(active & ~self.finished[rows])
            if live.size == 0:
                break
            r, xr = rows[live], x[live]
            f, ok, _ = self._shoot(r, xr, derivatives=False)
            with np.errstate(all="ignore"):
                secant = (f - f_prev[live]) / (xr - x_prev[live])
                fresh = ok & np.isfinite(secant) & (secant < 0) & (np.abs(xr - x_prev[live]) > 1e-12 * xr)
                d = np.where(fresh, secant, slope[live])
                nxt = xr - f / d
                # a bracket end set by a shot with derivatives is uncertain by the ~1e-11 between the two
                margin = PLAIN_SIGN_LEVEL * self.p_hat / np.abs(d)
            inside = ok & np.isfinite(nxt) & (nxt > 0) & (nxt > self.lo[r] - margin) & (nxt < self.hi[r] + margin)
            noise = inside & (np.abs(nxt - xr) <= NOISE_STEP * np.abs(xr))
            self.converged[r[noise]] = True
            self.finished[r[noise]] = True
            x_prev[live], f_prev[live], slope[live] = xr, f, d
            active[live[~inside]] = False  # left for the Newton iteration, from here if the state is valid
            x[live] = np.where(inside, nxt, np.where(ok, xr, 0.5 * (self.lo[r] + self.hi[r])))
        still = ~self.finished[rows]
        return rows[still], x[still]

    def accepted(self):
        """Converged with the pressure met to ``10 residual_tol p̂`` at the last state evaluated."""
        tol = 10 * self.settings.residual_tol * self.p_hat
        return self.converged & np.isfinite(self.f_last) & (np.abs(self.f_last) <= tol)

    def why_no_voltage(self, i: int) -> str:
        """Why pole stretch ``i`` has no voltage that carries ``p̂``: its zero-voltage pressure is already below
        ``p̂``, or its pressure stays above ``p̂`` up to the voltage where its states fail (and how they fail)."""
        p0 = self.f0[i] + self.p_hat
        if self.known[i] and not self.feasible[i] and np.isfinite(p0):
            return (
                f"no voltage Φ̂ ≥ 0 holds this pole stretch at p̂ = {self.p_hat:g}: at zero voltage its pressure is "
                f"already below, p̂ = {p0:.6g} (a voltage lowers it)"
            )
        if np.isfinite(self.f_lo[i]) and self.f_lo[i] > 0 and not np.isfinite(self.f_hi[i]):
            return (
                f"no voltage Φ̂ ≥ 0 holds this pole stretch at p̂ = {self.p_hat:g}: its pressure stays above it up "
                f"to Φ̂ = {np.sqrt(self.hi[i]):.6g} (p̂ = {self.f_lo[i] + self.p_hat:.6g} at Φ̂ = "
                f"{np.sqrt(self.lo[i]):.6g}), where its states fail: {reason_text(self.status_hi[i])}"
            )
        return reason_text(NO_VOLTAGE)

    def states(self, with_derivatives: bool) -> MembraneStates:
        """The states found (flags and NaN set as :func:`voltage_at_pressure` documents)."""
        result = self.result
        status = result.status.copy()
        open_ = ~self.accepted() & (status == OK)
        # a search still open when its iterations ran out (a valid last state, not at the pressure): said as such, not
        # as a pole stretch that no voltage holds (voltage_at_pressure(iterations=1) had called every one so)
        status[open_] = np.where(self.finished[open_], NO_VOLTAGE, VOLTAGE_ITERATIONS)
        infeasible = self.known & ~self.feasible
        status[infeasible] = np.where(self.status0[infeasible] == OK, NO_VOLTAGE, self.status0[infeasible])
        result.status = status
        bad = status != OK
        # the voltage too: a failed entry's was the last valid one tried, which does not carry the pressure
        for name in ("phi_hat", "p_hat", "v_hat", "q_hat", "psi_hat", "apex_height", "max_field", "min_tension"):
            getattr(result, name)[bad] = np.nan
        if result.wrinkled_stiffness is not None:  # NaN when failed, as MembraneStates documents
            result.wrinkled_stiffness[bad] = np.nan
        if with_derivatives:
            for k in _DERIVATIVE_FIELDS:
                self.derivatives[k][bad] = np.nan
            result.derivatives = StateDerivatives(**self.derivatives)
        else:
            result.derivatives = None
        return result


def _checked_voltage_inputs(model, p_hat, settings):
    settings = validation.settings_or_default(settings)
    validation.membrane_model(model)
    p_hat = validation.real(p_hat, "p_hat", lo=0.0, lo_open=True)
    return p_hat, settings


def _require_voltage(model):
    if not model.has_voltage:
        raise SceneError("a voltage-charge curve needs a model with electrostatics", "voltage")


def voltage_at_pressure(
    model: MembraneModel, pole_stretch, p_hat: float, settings: SolverSettings | None = None, iterations: int = 60
) -> MembraneStates:
    """States at given pole stretches that carry the pressure ``p̂``: solves ``p̂(λ0, Φ̂) = p̂`` for ``Φ̂``.

    The pressure falls as the voltage rises at fixed pole stretch; the root in ``s = Φ̂²`` is found by a
    safeguarded Newton iteration with the exact slope of the variational equations (every shot with
    derivatives),

    ``s ← s − (p̂(λ0, s) − p̂) / (∂p̂/∂s)``,  ``∂p̂/∂s = (∂p̂/∂Φ̂) / (2Φ̂)``,

    accelerated by memory: the step actually tried first is the root of the inverse cubic Hermite
    interpolant ``s(p̂)`` through the last two shots (their values and exact slopes; on the first step the
    inverse quadratic through the shot, its slope and the zero-voltage state), of order ``1 + √3``. Steps
    stay inside the bracket ``[0, s_pole]``, where ``s_pole`` is the voltage at which the pole tension
    vanishes; the iteration starts at the regula falsi point of that bracket (the pressure taken to fall
    linearly to zero at ``s_pole``), and a step that would leave the bracket, or that does not at least
    halve the previous one, is replaced by bisection. Pole stretches with ``p̂(λ0, 0) < p̂`` carry no voltage
    that reaches the pressure and are flagged ``no_equilibrium``; voltages at which the state fails
    (wrinkling at the clamp, ...) shrink the bracket from above, and a root is given up when the Newton step
    from the last valid state overshoots a failed upper end by far on a narrow bracket (the pressure stays
    above ``p̂`` up to the failure).

    Parameters
    ----------
    model : MembraneModel
        A membrane with electrostatics.
    pole_stretch : array_like
        Pole stretches ``λ0 > λpre``.
    p_hat : float
        The normalised pressure ``p̂ > 0`` to carry.
    settings : SolverSettings, optional
        Shooting tolerances; the root is converged to ``inner_ftol · p̂`` (or, noise-limited, until its
        bracket closes to 1e-15 or the Newton step falls below 1e-14 of ``s``) and accepted within
        ``10 residual_tol · p̂``.
    iterations : int
        Largest number of Newton (or bisection) steps per pole stretch.

    Returns
    -------
    MembraneStates
        One entry per pole stretch, ``phi_hat`` the voltage found, with the exact derivatives of the
        states found (``derivatives``); entries without one have status ``NO_VOLTAGE`` (or the failure of
        their zero-voltage state, or of the last voltage tried; ``VOLTAGE_ITERATIONS`` where the search was still
        open when its ``iterations`` ran out) and NaN quantities, ``phi_hat`` too (no voltage carries ``p̂`` there).

    Raises
    ------
    SceneError
        If the model has no electrostatics, or for invalid pole stretches or ``iterations`` (a whole number ≥ 1).
    """
    p_hat, settings = _checked_voltage_inputs(model, p_hat, settings)
    iterations = validation.integer(iterations, "iterations", lo=1)
    _require_voltage(model)
    l0 = validation.real_array(pole_stretch, "pole_stretch")
    roots = _VoltageRoots(model, l0, p_hat, settings, solve_states(model, l0, 0.0, settings))
    open_ = np.flatnonzero(~roots.finished)
    if open_.size:
        roots.newton(open_, roots.regula_falsi(open_), iterations)
    return roots.states(with_derivatives=True)


def _blank_states(like: MembraneStates, l0: np.ndarray) -> MembraneStates:
    """States at the pole stretches ``l0`` with nothing found yet (status ``NO_VOLTAGE``, NaN quantities, zero
    voltage), with the fields of ``like``."""
    blank = _take(like, np.zeros(l0.size, dtype=int))
    for value in blank.__dict__.values():
        if isinstance(value, np.ndarray):
            value[...] = np.nan if value.dtype.kind == "f" else 0
    blank.pole_stretch[:] = l0
    blank.phi_hat[:] = 0.0
    blank.status[:] = NO_VOLTAGE
    blank.derivatives = None
    return blank


def _merge(base: MembraneStates, new: MembraneStates, where) -> MembraneStates:
    for name, value in base.__dict__.items():
        if isinstance(value, np.ndarray):
            value[where] = getattr(new, name)
        elif name in ("shapes", "wrinkled_radii") and value is not None and getattr(new, name) is not None:
            for j, i in enumerate(np.arange(len(value))[where]):
                value[i] = getattr(new, name)[j]
    return base


#: the first voltages of a Φ̂–Q̂ curve are solved on every this-many-th pole stretch; the rest start from
#: the Hermite interpolant of those (values and exact slopes ``ds/dλ0``)
COARSE_STRIDE = 8
#: chord steps (shots without derivatives) for the voltage of an interpolated pole stretch before it is
#: handed to the Newton iteration
POLISH_ROUNDS = 3
#: a coarse voltage leaves the Newton iteration for the chord steps once its shot with derivatives meets
#: this relative residual (:meth:`_VoltageRoots.newton`): the next point is then within ~1e-10 of the root
HANDOFF = 1e-6


def _hermite_at(l0, at, nodes, s, tangent, slope):
    """At the pole stretches ``l0[at]``: the Hermite interpolant of ``s(λ0)`` through the ``nodes`` (one row
    per point, values ``s`` and slopes ``tangent``; degree ``2 × nodes − 1``), and the polynomial through
    the nodes' ``slope`` (``∂p̂/∂s``)."""
    m, n = nodes.shape
    width = l0[nodes[:, n // 2]] - l0[nodes[:, n // 2 - 1]]
    u = (l0[nodes] - l0[at][:, None]) / width[:, None]
    powers = np.arange(2 * n)
    A = np.empty((m, 2 * n, 2 * n))
    A[:, 0::2, :] = u[:, :, None] ** powers
    with np.errstate(divide="ignore", invalid="ignore"):
        A[:, 1::2, :] = np.where(powers > 0, powers * u[:, :, None] ** (powers - 1), 0.0)
    rhs = np.empty((m, 2 * n))
    rhs[:, 0::2] = s[nodes]
    rhs[:, 1::2] = tangent[nodes] * width[:, None]
    value = np.linalg.solve(A, rhs[..., None])[:, 0, 0]
    V = u[:, :, None] ** np.arange(n)
    slope_at = np.linalg.solve(V, slope[nodes][..., None])[:, 0, 0]
    return value, slope_at


def _beyond_first_run(roots: _VoltageRoots) -> None:
    """Give up the open problems beyond the first finished failure after an accepted state: the first valid
    run of the grid ends before it, so they cannot change the curve."""
    good = roots.accepted()
    if not good.any():
        return
    first = int(np.argmax(good))
    failed = np.flatnonzero(roots.finished[first:] & ~good[first:])
    if failed.size:
        roots.finished[first + failed[0] + 1 :] = True


def _zero_voltage_plan(roots: _VoltageRoots, coarse: np.ndarray) -> tuple[np.ndarray, int]:
    """Which fine pole stretches need their zero-voltage state, given those of the ``coarse`` ones, and where
    the pole stretches stop mattering.

    Between two feasible coarse pole stretches (``p̂(λ0, 0) ≥ p̂``) the fine ones are taken to be feasible:
    their voltages are solved, and one whose root is not found is shot at zero voltage then. Every other
    interval up to the first feasible coarse pole stretch is shot (an isolated feasible stretch there would
    be the curve), and so is the first interval after it that ends at an infeasible one (where the curve
    ends); beyond that infeasible coarse pole stretch nothing can belong to the first run of valid states
    while one before it is valid.

    Returns
    -------
    rows : ndarray
        The fine pole stretches to shoot at zero voltage.
    beyond : int
        The first pole stretch that no longer matters (``l0.size`` when all do).
    """
    n = roots.l0.size
    feasible = roots.feasible[coarse]
    if not feasible.any():
        return np.setdiff1d(np.arange(n), coarse), n
    k = int(np.argmax(feasible))
    rows = [np.setdiff1d(np.arange(coarse[k]), coarse)]
    while k + 1 < coarse.size and feasible[k + 1]:
        k += 1
    if k + 1 == coarse.size:
        return np.concatenate(rows), n
    rows.append(np.arange(coarse[k] + 1, coarse[k + 1]))
    return np.concatenate(rows), int(coarse[k + 1]) + 1


def _voltage_charge_states(model, l0, p_hat, settings, iterations=60) -> tuple[MembraneStates, _VoltageRoots]:
    """:func:`voltage_at_pressure` on an increasing grid, using that the voltage is a smooth function of the
    pole stretch.

    1. Zero-voltage states only where they decide something (:func:`_zero_voltage_plan`): every
       :data:`COARSE_STRIDE`-th pole stretch, then the fine ones up to the first feasible coarse one and
       in the interval where the feasible stretch ends.
    2. The coarse open pole stretches (and the ends of every run of open ones) by the Newton iteration with
       derivatives, each until its shot meets :data:`HANDOFF` ``· p̂`` (or converges); its next point then
       lies within ``O(HANDOFF²)`` of the root.
    3. The fine ones between two of those start at the Hermite interpolant of ``s(λ0)`` through up to
       two on either side, with the exact slopes ``ds/dλ0 = −(∂p̂/∂λ0)/(∂p̂/∂s)`` (degree up to 7), and
       are finished together with the handed-off coarse ones by chord steps without derivatives
       (:meth:`_VoltageRoots.polish`: the interpolated or exact ``∂p̂/∂s``, then the secant of the last
       two shots).
    4. Whatever is left is shot at zero voltage if it was not, and goes to the Newton iteration, from the
       tangent of a converged neighbour where there is one.
    5. Any pole stretch before the first run of accepted states (or just after it) that was set aside in
       step 1 is solved from scratch, until none is left.

    The same acceptance as :func:`voltage_at_pressure`: every state meets ``inner_ftol · p̂`` (or is
    noise-limited); problems beyond the end of the first valid run are given up as soon as that end is
    known (:func:`_beyond_first_run`). Returns the states and the search (which says why a pole stretch has no
    voltage, :meth:`_VoltageRoots.why_no_voltage`)."""
    n = l0.size
    roots = _VoltageRoots(model, l0, p_hat, settings)
    coarse = unique_sorted(np.r_[np.arange(0, n, COARSE_STRIDE), n - 1])
    roots.zero(coarse)
    need, beyond = _zero_voltage_plan(roots, coarse)
    roots.zero(need)
    skipped = np.zeros(n, dtype=bool)
    skipped[beyond:] = ~roots.finished[beyond:]
    roots.finished[skipped] = True

    is_open = ~roots.finished
    open_ = np.flatnonzero(is_open)
    if open_.size:
        # the ends of every run of open pole stretches are coarse, and every COARSE_STRIDE-th in between
        edges = np.flatnonzero(np.diff(np.r_[False, is_open, False].astype(int)))
        firsts, lasts = edges[::2], edges[1::2] - 1
        nodes = unique_sorted(np.r_[coarse[is_open[coarse]], firsts, lasts])
        roots.zero(nodes[~roots.known[nodes]])  # a run end next to an exact zero-voltage root (rare)
        nodes = nodes[~roots.finished[nodes]]
        handed, handed_x, handed_slope = roots.newton(
            nodes, roots.regula_falsi(nodes), iterations, _beyond_first_run, handoff=HANDOFF
        )
        _fine_voltages(roots, is_open, nodes, (handed, handed_x, handed_slope), iterations)

    # pole stretches set aside that decide where the first run of accepted states starts or ends
    for _ in range(n):
        good = roots.accepted()
        if good.any():
            run = first_valid_run(good)
            where = np.r_[np.arange(run.start), [run.stop] if run.stop < n else []].astype(int)
        else:
            where = np.arange(n)
        rows = where[skipped[where]]
        if rows.size == 0:
            break
        skipped[rows] = False
        roots.finished[rows] = False
        roots.zero(rows)
        rows = rows[~roots.finished[rows]]
        roots.newton(rows, roots.regula_falsi(rows), iterations, _beyond_first_run)
    return roots.states(with_derivatives=False), roots


def _fine_voltages(roots: _VoltageRoots, is_open, nodes, handed, iterations) -> None:
    """Steps 3 and 4 of :func:`_voltage_charge_states`: the open pole stretches other than ``nodes``, and the
    ``handed`` ``(rows, next points, slopes)`` of the nodes' Newton iteration."""
    l0 = roots.l0
    handed_rows, handed_x, handed_slope = handed
    open_ = np.flatnonzero(is_open)
    fine = np.setdiff1d(open_, nodes)
    good = roots.accepted()
    good[handed_rows] = True
    d = roots.derivatives
    phi = roots.result.phi_hat
    s = phi**2
    s[handed_rows] = handed_x
    with np.errstate(all="ignore"):
        slope = d["dp_dphi"] / (2 * phi)  # ∂p̂/∂s (of the last shot with derivatives)
        tangent = -d["dp_dl0"] / slope  # ds/dλ0 along the curve
        slope[handed_rows] = handed_slope
    usable = good & np.isfinite(slope) & np.isfinite(tangent) & (slope < 0)
    run_id = np.cumsum(np.r_[0, np.diff(is_open.astype(int)) != 0])
    pos = np.searchsorted(nodes, fine)
    # up to two usable nodes on either side, in the same run of open pole stretches
    near: dict[str, tuple[np.ndarray, np.ndarray]] = {}
    for name, shift, inner in (("a1", -1, None), ("a2", -2, "a1"), ("b1", 0, None), ("b2", 1, "b1")):
        k = pos + shift
        inside_k = (k >= 0) & (k < nodes.size)
        idx = nodes[np.clip(k, 0, max(nodes.size - 1, 0))] if nodes.size else np.zeros(fine.size, dtype=int)
        valid = inside_k & usable[idx] & (run_id[idx] == run_id[fine])
        if inner is not None:
            valid &= near[inner][1]
        near[name] = (idx, valid)
    both = near["a1"][1] & near["b1"][1]
    guess, guess_slope = np.full(fine.size, np.nan), np.full(fine.size, np.nan)
    for with_a2 in (False, True):
        for with_b2 in (False, True):
            sel = both & (near["a2"][1] == with_a2) & (near["b2"][1] == with_b2)
            if not sel.any():
                continue
            names = ["a2"] * with_a2 + ["a1", "b1"] + ["b2"] * with_b2
            at = np.stack([near[k][0][sel] for k in names], axis=1)
            guess[sel], guess_slope[sel] = _hermite_at(l0, fine[sel], at, s, tangent, slope)
    inside = both & np.isfinite(guess) & (guess > roots.lo[fine]) & (guess < roots.hi[fine])
    inside &= np.isfinite(guess_slope) & (guess_slope < 0)
    left, nxt = roots.polish(
        np.r_[fine[inside], handed_rows],
        np.r_[guess[inside], handed_x],
        np.r_[guess_slope[inside], handed_slope],
        POLISH_ROUNDS,
        _beyond_first_run,
    )
    # the rest: known at zero voltage first; then from one converged neighbour's tangent, else from the
    # regula falsi point
    rest = fine[~inside]
    late = np.r_[left, rest]
    roots.zero(late[~roots.known[late] & ~roots.finished[late]])
    start = roots.regula_falsi(rest)
    from_a = near["a1"][1][~inside]
    from_b = near["b1"][1][~inside] & ~from_a
    for side, end in ((from_a, near["a1"][0][~inside]), (from_b, near["b1"][0][~inside])):
        j, e = rest[side], end[side]
        start[side] = s[e] + tangent[e] * (l0[j] - l0[e])
    lo, hi = roots.lo[rest], roots.hi[rest]
    start = np.where(np.isfinite(start), np.clip(start, lo + 0.01 * (hi - lo), hi - 0.01 * (hi - lo)), np.nan)
    start = np.where(np.isfinite(start), start, roots.regula_falsi(rest))
    nxt = np.where(np.isfinite(nxt), nxt, roots.regula_falsi(left))
    if late.size:
        roots.newton(late, np.r_[nxt, start], iterations, _beyond_first_run)


#: the first guess of a Φ̂–Q̂ limit point is the extremum of the polynomial through the grid values at up to
#: this many pole stretches on either side of the grid extremum
LIMIT_POINT_HALF_STENCIL = 3


def _local_polynomial(grid, values, i):
    """The polynomial (in ``λ0 − λ0[i]``) through the grid values at up to ``2 LIMIT_POINT_HALF_STENCIL + 1``
    pole stretches around ``i``."""
    lo, hi = max(0, i - LIMIT_POINT_HALF_STENCIL), min(grid.size, i + LIMIT_POINT_HALF_STENCIL + 1)
    x = grid[lo:hi] - grid[i]
    scale = grid[i + 1] - grid[i] if i + 1 < grid.size else grid[i] - grid[i - 1]
    return np.polynomial.Polynomial.fit(x, values[lo:hi], x.size - 1, domain=[-scale, scale])


def _stationary_point(grid, poly, i, is_max):
    """Where ``poly`` (:func:`_local_polynomial` around ``i``) has its largest (``is_max``) or smallest value
    among its stationary points in ``(λ0[i−1], λ0[i+1])`` and ``λ0[i]``, as an offset from ``λ0[i]``."""
    a, b = grid[i - 1] - grid[i], grid[i + 1] - grid[i]
    roots = poly.deriv().roots()
    roots = roots[np.abs(roots.imag) <= 1e-9 * (b - a)].real
    cand = np.r_[roots[(roots > a) & (roots < b)], 0.0]
    return cand[np.argmax(poly(cand) * (1 if is_max else -1))]


#: Newton/secant steps of a Φ̂–Q̂ limit point at most, before the generic extremum search takes it over
LIMIT_POINT_ITERATIONS = 12


_CHARGE_QUANTITIES = {"phi_hat": ("voltage_max", "voltage_min"), "q_hat": ("charge_max", "charge_min")}


def _voltage_charge_slopes(model, l0, phi_hat, settings) -> dict:
    """``dΦ̂/dλ0 = −(∂p̂/∂λ0)/(∂p̂/∂Φ̂)`` and ``dQ̂/dλ0 = ∂Q̂/∂λ0 + (∂Q̂/∂Φ̂) dΦ̂/dλ0`` along a ``Φ̂–Q̂`` curve at
    its states ``(λ0, Φ̂)`` (one shot with derivatives; NaN where a state fails)."""
    return _slopes_along(solve_states(model, l0, phi_hat, settings, derivatives=True), "voltage_charge")


def _interval_cubic(grid, values, exact, lo):
    """The cubic Hermite interpolant (in ``λ0 − λ0[lo]``) on ``[λ0[lo], λ0[lo+1]]`` through the values and
    slopes at both ends: the exact slope where ``exact`` has it, else that of :func:`_local_polynomial`."""
    h = grid[lo + 1] - grid[lo]
    d0, d1 = (
        exact[i] if exact is not None and np.isfinite(exact[i]) else _local_polynomial(grid, values, i).deriv()(0.0)
        for i in (lo, lo + 1)
    )
    secant = (values[lo + 1] - values[lo]) / h
    return np.polynomial.Polynomial(
        [values[lo], d0, (3 * secant - 2 * d0 - d1) / h, (d0 + d1 - 2 * secant) / h**2], domain=[0, h], window=[0, h]
    )


def _first_guess(grid, states, slopes, bracket):
    """The first ``(λ0, Φ̂)`` of a ``Φ̂–Q̂`` limit point in ``bracket``, and the curvatures there of its quantity
    and of ``Φ̂`` along the curve: on two intervals, the extremum of :func:`_local_polynomial` around the
    middle node (:func:`_stationary_point`); on one, the stationary point of its kind of
    :func:`_interval_cubic` (the middle of the interval if it has none)."""
    values = getattr(states, bracket.attr)
    if bracket.hi - bracket.lo >= 2:  # around the interior node of the extreme value
        inner = values[bracket.lo + 1 : bracket.hi]
        i = bracket.lo + 1 + int(np.argmax(inner) if bracket.is_max else np.argmin(inner))
        poly = _local_polynomial(grid, values, i)
        offset = _stationary_point(grid, poly, i, bracket.is_max)
        phi_poly = _local_polynomial(grid, states.phi_hat, i)
        return grid[i] + offset, phi_poly(offset), poly.deriv(2)(offset), phi_poly.deriv(2)(offset)
    exact = None if slopes is None else slopes
    poly = _interval_cubic(grid, values, None if exact is None else exact.get(bracket.attr), bracket.lo)
    h = grid[bracket.hi] - grid[bracket.lo]
    offset = _cubic_extremum(poly, h, bracket.is_max)
    offset = offset if np.isfinite(offset) else 0.5 * h
    phi_poly = _interval_cubic(grid, states.phi_hat, None if exact is None else exact.get("phi_hat"), bracket.lo)
    return grid[bracket.lo] + offset, phi_poly(offset), poly.deriv(2)(offset), phi_poly.deriv(2)(offset)


def _charge_limit_points(model, p_hat, states, settings, evaluate):
    """The voltage and charge extrema of a ``Φ̂–Q̂`` curve, as roots of their exact derivatives along it.

    Along the curve ``p̂(λ0, Φ̂) = p̂``: ``dΦ̂/dλ0 = −(∂p̂/∂λ0)/(∂p̂/∂Φ̂)`` and ``dQ̂/dλ0 = ∂Q̂/∂λ0 +
    (∂Q̂/∂Φ̂) dΦ̂/dλ0``, both from one shot with derivatives. Every extremum the grid shows
    (:func:`_grid_extrema`, with the exact slopes at the ends of the curve and around its sharp bends,
    :func:`_node_slopes`) starts at the extremum of an interpolant of the grid values (:func:`_first_guess`);
    each step then moves ``λ0`` by the secant (first: the interpolant's curvature) step on the derivative and
    ``Φ̂`` by the Newton step onto the curve plus the tangent ``dΦ̂/dλ0`` (and curvature) times that move, all
    extrema in one batched shot. A limit point is located when its voltage meets ``inner_ftol · p̂`` and the
    ``λ0`` step is at most ``limit_point_xtol/10`` (relative), or at most ``limit_point_xtol`` and no longer
    shrinking (the noise of the derivatives); one that fails (leaves its grid bracket, meets no valid state,
    runs out of steps) is located by :func:`_refine_brackets` in its bracket.
    """
    grid = states.pole_stretch
    slopes = _node_slopes(
        states,
        _CHARGE_QUANTITIES,
        lambda rows: _voltage_charge_slopes(model, grid[rows], states.phi_hat[rows], settings),
    )
    brackets = _grid_extrema(
        states, _CHARGE_QUANTITIES, slopes, settings.rtol, lambda x: _slopes_along(evaluate(x), "voltage_charge")
    )
    if not brackets:
        return []
    m = len(brackets)
    lam, phi = np.empty(m), np.empty(m)
    curvature, phi_curvature = np.empty(m), np.empty(m)
    for j, bracket in enumerate(brackets):
        lam[j], phi[j], curvature[j], phi_curvature[j] = _first_guess(grid, states, slopes, bracket)
    lo_b = np.array([grid[b.lo] for b in brackets])
    hi_b = np.array([grid[b.hi] for b in brackets])
    found = _slope_roots(model, p_hat, settings, brackets, lam, phi, curvature, phi_curvature, lo_b, hi_b)
    for stage in (_from_sampled_slopes, _from_interpolated_values):
        rest = [j for j in range(m) if found[j] is None]
        if not rest:
            break
        for j, lp in zip(rest, stage(model, p_hat, settings, states, [brackets[j] for j in rest], evaluate)):
            found[j] = lp
    return sorted(found, key=lambda lp: lp.pole_stretch)


#: interior points of a bracket at which the slope along a ``Φ̂–Q̂`` curve is sampled when the iteration from
#: the interpolated first guess failed (:func:`_from_sampled_slopes`)
SLOPE_SAMPLES = 8


def _slope_of(bracket, slopes: dict) -> np.ndarray:
    return slopes["phi_hat"] if bracket.attr == "phi_hat" else slopes["q_hat"]


def _from_sampled_slopes(model, p_hat, settings, states, brackets, evaluate) -> list:
    """Limit points whose iteration from the interpolated first guess failed (two or three extrema may share a
    grid interval near the centre of a spiral): the exact slope is sampled at :data:`SLOPE_SAMPLES` interior
    points of each bracket (the states of :func:`voltage_at_pressure`, all brackets in one call), and the
    iteration (:func:`_slope_roots`) restarts from the first change of sign of its kind, inside it. None for
    a bracket without one, or whose iteration fails again."""
    grid = states.pole_stretch
    k = SLOPE_SAMPLES
    lo = np.array([grid[b.lo] for b in brackets])
    hi = np.array([grid[b.hi] for b in brackets])
    x = lo[:, None] + (hi - lo)[:, None] * (np.arange(1, k + 1) / (k + 1))[None, :]
    st = evaluate(x.ravel())
    slopes = _slopes_along(st, "voltage_charge")
    m = len(brackets)
    guess = [np.full(m, np.nan) for _ in range(6)]  # λ0, Φ̂, curvature, Φ̂ curvature, lo, hi
    for j, b in enumerate(brackets):
        t = _slope_of(b, slopes).reshape(m, k)[j]
        g = slopes["phi_hat"].reshape(m, k)[j]
        phi = np.where(st.ok, st.phi_hat, np.nan).reshape(m, k)[j]
        sign = 1.0 if b.is_max else -1.0
        for i in range(k - 1):
            if sign * t[i] > 0 > sign * t[i + 1] and np.isfinite(phi[i] + phi[i + 1]):
                xa, xb = x[j, i], x[j, i + 1]
                w = t[i] / (t[i] - t[i + 1])
                values = (xa + w * (xb - xa), phi[i] + w * (phi[i + 1] - phi[i]), (t[i + 1] - t[i]) / (xb - xa))
                for arr, v in zip(guess, (*values, (g[i + 1] - g[i]) / (xb - xa), xa, xb)):
                    arr[j] = v
                break
    have = [int(j) for j in np.flatnonzero(np.isfinite(guess[0]))]
    found: list = [None] * m
    if have:
        sub = [brackets[j] for j in have]
        again = _slope_roots(model, p_hat, settings, sub, *(arr[have] for arr in guess))
        for j, lp in zip(have, again):
            found[j] = lp
    return found


def _from_interpolated_values(model, p_hat, settings, states, brackets, evaluate) -> list:
    """The last resort of :func:`_charge_limit_points`: the extremum of the interpolated values in each bracket
    (:func:`_refine_brackets`: exact to the values' precision, its location only to about the square root of
    that where the curve is flat), then the root of the slope from there (:func:`_slope_roots`), which
    replaces it where it converges."""
    grid = states.pole_stretch
    rough = _refine_brackets(states, brackets, evaluate, settings)
    x = np.array([lp.pole_stretch for lp in rough])
    delta = 1e-3 * np.array([grid[b.hi] - grid[b.lo] for b in brackets])
    here = evaluate(np.r_[x, x + delta])
    slopes = _slopes_along(here, "voltage_charge")
    k = len(brackets)
    is_q = np.array([b.attr == "q_hat" for b in brackets])
    t = np.where(np.r_[is_q, is_q], slopes["q_hat"], slopes["phi_hat"])
    with np.errstate(all="ignore"):
        curvature = (t[k:] - t[:k]) / delta
        phi_curvature = (slopes["phi_hat"][k:] - slopes["phi_hat"][:k]) / delta
    # a state that fails here again carries no voltage (NaN): start from the rough limit point's, which is valid
    phi = np.where(here.ok[:k], here.phi_hat[:k], np.array([lp.phi_hat for lp in rough]))
    again = _slope_roots(
        model,
        p_hat,
        settings,
        brackets,
        x,
        phi,
        curvature,
        phi_curvature,
        np.array([grid[b.lo] for b in brackets]),
        np.array([grid[b.hi] for b in brackets]),
    )
    return [lp if polished is None else polished for lp, polished in zip(rough, again)]


def _slope_roots(model, p_hat, settings, brackets, lam, phi, curvature, phi_curvature, lo_b, hi_b) -> list:
    """The roots of the slopes along a ``Φ̂–Q̂`` curve (:func:`_charge_limit_points`) from the first guesses
    ``(λ0, Φ̂)`` with the curvatures there, each kept inside ``(lo_b, hi_b)``; None for those not located."""
    m = len(brackets)
    lam, phi = np.array(lam, dtype=float), np.array(phi, dtype=float)
    curvature, phi_curvature = np.array(curvature, dtype=float), np.array(phi_curvature, dtype=float)
    ftol = settings.inner_ftol * p_hat
    is_voltage = np.array([b.attr == "phi_hat" for b in brackets])
    is_max = np.array([b.is_max for b in brackets])
    found: list = [None] * m
    open_ = np.ones(m, dtype=bool)
    lam_prev, t_prev, g_prev = np.full(m, np.nan), np.full(m, np.nan), np.full(m, np.nan)
    step_prev = np.full(m, np.inf)
    for _ in range(LIMIT_POINT_ITERATIONS):
        idx = np.flatnonzero(open_)
        if idx.size == 0:
            break
        st = solve_states(model, lam[idx], phi[idx], settings, derivatives=True)
        dv = StateDerivatives.of(st)
        with np.errstate(all="ignore"):
            f = st.p_hat - p_hat
            g = -dv.dp_dl0 / dv.dp_dphi  # dΦ̂/dλ0 along the curve
            t = dv.dq_dl0 + dv.dq_dphi * g  # dQ̂/dλ0 along the curve
            t[is_voltage[idx]] = g[is_voltage[idx]]
            dlam = lam[idx] - lam_prev[idx]
            g_secant = np.where(np.abs(dlam) > 1e-12 * np.abs(lam[idx]), (g - g_prev[idx]) / dlam, np.nan)
            phi_curvature[idx] = np.where(np.isfinite(g_secant), g_secant, phi_curvature[idx])
        g_prev[idx] = g
        ok = st.ok & np.isfinite(g)
        with np.errstate(all="ignore"):
            # on the curve: the pressure met, or (at rtol ≤ 1e-12, where inner_ftol lies below the states' rounding)
            # the Newton step onto it within the noise of the shooting, as voltage_at_pressure accepts a voltage
            noise = np.abs(f / dv.dp_dphi) <= 0.5 * NOISE_STEP * np.abs(phi[idx])
        met = st.ok & ((np.abs(f) <= ftol) | noise)
        iterate = (lam, lam_prev, t_prev, curvature, step_prev)
        step, located, done = _secant_round(idx, t, ok, met, iterate, is_max, lo_b, hi_b, settings.limit_point_xtol)
        for k in np.flatnonzero(located):
            j = idx[k]
            found[j] = _limit_point(brackets[j].kind, _take(st, slice(k, k + 1)))
        open_[idx[done]] = False
        with np.errstate(all="ignore"):
            phi[idx] = phi[idx] - f / dv.dp_dphi + g * step + 0.5 * phi_curvature[idx] * step**2
        open_[idx[open_[idx] & ~(phi[idx] > 0)]] = False
    return found


def voltage_charge_curve(
    model: MembraneModel, p_hat: float, pole_stretch=None, settings: SolverSettings | None = None
) -> Curve:
    """The ``Φ̂–Q̂`` curve of a clamped zone at fixed normalised pressure ``p̂``.

    Traced by the pole stretch; at each ``λ0`` the voltage is the root of ``p̂(λ0, Φ̂) = p̂``, found as by
    :func:`voltage_at_pressure` (safeguarded Newton in ``s = Φ̂²`` with the exact slope), where the
    voltages of most pole stretches start from the cubic Hermite interpolant of a coarser set along the
    curve (exact slopes ``dΦ̂/dλ0 = −(∂p̂/∂λ0)/(∂p̂/∂Φ̂)``) and are polished by chord steps, and the
    zero-voltage states are shot only where they decide where the curve starts or ends (see
    :func:`_voltage_charge_states`; the states are those :func:`voltage_at_pressure` accepts). The voltage and
    charge extrema are located as roots of the exact ``dΦ̂/dλ0`` and
    ``dQ̂/dλ0 = ∂Q̂/∂λ0 + (∂Q̂/∂Φ̂) dΦ̂/dλ0``, to the solver tolerance.

    Parameters
    ----------
    model : MembraneModel
        A membrane with electrostatics.
    p_hat : float
        The fixed normalised pressure ``p̂ = pA/(μH) > 0``.
    pole_stretch : array_like, optional
        Increasing pole stretches; default ``settings.charge_curve_points`` (120) from ``1.01 λpre``
        to ``max(4, 1.5 λpre)``.
    settings : SolverSettings, optional
        Tolerances and sample counts; default ``SolverSettings()``.

    Returns
    -------
    Curve
        Family ``voltage_charge``, with the voltage and charge extrema refined to the solver tolerance. A state's
        ``Φ̂`` carries the shooting's error in ``p̂`` (about ``rtol p̂``) divided by ``∂p̂/∂Φ̂``: about ``rtol`` in
        absolute terms, but where ``Φ̂ → 0`` (``p̂ ≈ p̂0 − kΦ̂²``, ``∂p̂/∂Φ̂ ≈ 2kΦ̂``) its relative error, and ``Q̂``'s,
        grows like ``1/Φ̂²`` (an independent solver: 1.3e-5 at ``Φ̂ = 1.2e-3``, rtol 1e-8; review, helper-72).

    Raises
    ------
    SceneError
        ``p̂`` not positive, a model without electrostatics, or fewer than 3 pole stretches, not
        increasing or not above ``λpre``.
    ModelRangeError
        No pole stretch of the grid carries ``p̂`` (the reason of the first).
    SolverError
        No valid state near a limit point while refining it (a state found failing between two valid states of
        the grid ends the curve before it instead: ``stopped_because`` names it).
    """
    p_hat, settings = _checked_voltage_inputs(model, p_hat, settings)
    if pole_stretch is None:
        _refuse_huge_curve(settings.charge_curve_points, getattr(model, "pattern", None) is not None)
        pole_stretch = np.linspace(
            1.01 * model.prestretch, max(4.0, 1.5 * model.prestretch), settings.charge_curve_points
        )
    l0 = _check_range(pole_stretch, model)
    _require_voltage(model)
    states, roots = _voltage_charge_states(model, l0, p_hat, settings)
    run, starts, stopped = _valid_run(states, l0, roots.why_no_voltage)
    states = _take(states, run)
    while True:
        try:
            limits = _charge_limit_points(
                model, p_hat, states, settings, _warm_evaluate(model, p_hat, settings, states)
            )
            break
        except _FailsInside as gap:
            states, stopped = _before(states, gap)
    tight = error_reference(settings)

    def along(x, phi):
        st = _voltages_from(model, x, p_hat, tight, phi)
        return st, _slopes_along(st, "voltage_charge")

    _limit_point_errors(limits, _CHARGE_QUANTITIES, settings.rtol, None, along)
    return Curve("voltage_charge", float(p_hat), states, limits, starts, stopped, settings.rtol)


def _local_cubic(grid, values, x):
    """The cubic through the ``values`` at the four grid nodes around each ``x`` (two on either side; the first
    or last four at the ends), or the straight line on a grid of fewer than four nodes."""
    if grid.size < 4:
        return np.interp(x, grid, values)
    i = np.clip(np.searchsorted(grid, x) - 2, 0, grid.size - 4)
    nodes = i[:, None] + np.arange(4)
    g, v = grid[nodes], values[nodes]
    out = np.zeros(x.size)
    for a in range(4):
        w = np.ones(x.size)
        for b in range(4):
            if b != a:
                w *= (x - g[:, b]) / (g[:, a] - g[:, b])
        out += w * v[:, a]
    return out


def _warm_evaluate(model, p_hat, settings, states: MembraneStates):
    """``evaluate(λ0)``: the states of :func:`voltage_at_pressure` at pole stretches between the curve's first
    and last ``states``, the Newton iteration started at ``s = Φ̂²`` interpolated by the cubic through the four
    states around each (:func:`_local_cubic`, :func:`_voltages_from`) instead of at the regula falsi point after
    a zero-voltage shot (2–3 shots with derivatives instead of 6–7: the root is the same, the pressure falls
    monotonically with the voltage). A batch with a pole stretch outside the curve, or one that fails this way,
    is solved again by :func:`voltage_at_pressure` from scratch, so that a failure is named as there."""
    grid, s = states.pole_stretch, states.phi_hat**2

    def evaluate(x):
        x = np.asarray(x, dtype=float)
        if x.size and np.all((x >= grid[0]) & (x <= grid[-1])):
            st = _voltages_from(model, x, p_hat, settings, np.sqrt(np.maximum(_local_cubic(grid, s, x), 0.0)))
            if st.ok.all():
                return st
        return voltage_at_pressure(model, x, p_hat, settings)

    return evaluate


def _voltages_from(model, l0, p_hat, settings, phi_hat, iterations=60) -> MembraneStates:
    """:func:`voltage_at_pressure` with derivatives at the pole stretches ``l0``, the Newton iteration started at the
    voltages ``phi_hat`` (near the roots) instead of the regula falsi point; the zero-voltage states are not
    shot (the feasibility they decide is known)."""
    roots = _VoltageRoots(model, l0, p_hat, settings)
    roots.newton(np.arange(l0.size), np.asarray(phi_hat, dtype=float) ** 2, iterations)
    return roots.states(with_derivatives=True)


def curves_csv(curves) -> str:
    """CSV text, one row per state of every curve: its family, the name and value held fixed, and the
    state quantities (:data:`STATE_FIELDS`; the field and the smallest tension as ``max_field_hat``,
    ``min_tension_hat``). Values are written with ``repr`` (every digit).

    Parameters
    ----------
    curves : iterable of Curve
        Curves of either family.

    Returns
    -------
    str
        The CSV text, with a header row.
    """
    import csv
    import io

    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    header = [{"max_field": "max_field_hat", "min_tension": "min_tension_hat"}.get(k, k) for k in STATE_FIELDS]
    w.writerow(["family", "fixed_name", "fixed_value", *header])
    for c in curves:
        s = c.states
        name = "phi_hat" if c.family == "pressure_volume" else "p_hat"
        for i in range(s.pole_stretch.size):
            w.writerow([c.family, name, repr(c.fixed)] + [repr(float(getattr(s, k)[i])) for k in STATE_FIELDS])
    return buf.getvalue()
