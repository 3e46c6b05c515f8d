"""A slow voltage ramp up and back down: which configuration the zones are in at each voltage.

A slow experiment stays on the stable equilibrium it is in until that equilibrium loses stability
or ceases to exist (a spinodal), then jumps to a stable equilibrium (the nearest one in zone-volume
space, the one the unstable mode leads to); the path therefore shows hysteresis. Beside the
path, the voltages where each configuration's total free energy equals the homogeneous one's are
reported: where an ideal, fluctuating system would switch (the equal-free-energy or Maxwell
voltage of that configuration).
"""

from __future__ import annotations

from dataclasses import dataclass, field

from .branches import ZoneFamily
from .errors import ModelRangeError
from .zones import Equilibrium, continue_equilibrium, equilibria


@dataclass
class RampStep:
    """One voltage of the path: the state the zones are in and every equilibrium at that voltage."""

    phi_hat: float
    state: Equilibrium | None
    equilibria: list
    direction: str
    note: str | None = None
    max_field: float | None = None  # V/m, set when the scene checks for breakdown


@dataclass
class Transition:
    """A change of configuration along the path (``spinodal``) or an equal-free-energy voltage."""

    phi_hat: float
    kind: str
    from_label: str
    to_label: str
    direction: str
    phi_hat_bracket: tuple = ()


@dataclass
class RampResult:
    """The path, its transitions and the equal-free-energy voltages."""

    steps: list
    transitions: list
    equal_free_energy: list
    zones: int
    notes: list = field(default_factory=list)


#: transitions are located to this in Φ̂ (≈ 2e-6 kV for the default scene): well below the
#: interpolation error of the curves they are found on (~1e-5 relative, see ``coexist ramp``)
BISECTION_TOLERANCE = 1e-7

#: largest relative jump of any zone volume between two path voltages that still counts as the
#: same state continued (a larger change is a jump to another state)
CONTINUATION_TOLERANCE = 0.05


def _continue(state: Equilibrium, candidates: list, stable_only=True):
    """The equilibrium at the next voltage that continues ``state``: same number of bulged zones,
    nearest in zone-volume space, within :data:`CONTINUATION_TOLERANCE` of it — or within four times
    that when it is also the nearest of all candidates (a state moving fast near a fold, on a
    coarse voltage path). Branch indices are not compared: the curve's branch structure can change
    with the voltage."""
    scale = max(max(state.zone_volumes), 1e-12)
    pool = [e for e in candidates if e.stable or not stable_only]
    if not pool:
        return None
    nearest = min(pool, key=lambda e: e.distance(state))
    same = [e for e in pool if e.k == state.k and e.distance(state) <= CONTINUATION_TOLERANCE * scale]
    if same:
        return min(same, key=lambda e: e.distance(state))
    if nearest.k == state.k and nearest.distance(state) <= 4 * CONTINUATION_TOLERANCE * scale:
        return nearest
    return None


def _initial_state(eqs: list):
    """The homogeneous stable state on the first rising branch (the state when the valves close)."""
    start = [e for e in eqs if e.k == 0 and e.branch_unbulged == 0 and e.stable]
    if not start:
        start = [e for e in eqs if e.stable]
    return min(start, key=lambda e: e.v_unbulged) if start else None


def run_ramp(family: ZoneFamily, gas, zones: int, phi_path, refine: bool = True, progress=None) -> RampResult:
    """Follow the zones along a voltage path.

    Parameters
    ----------
    family : ZoneFamily
        Zone curves for every voltage of the path.
    gas : GasChamber or PressureReservoir
    zones : int
    phi_path : sequence of float
        Normalised voltages in the order applied (up and back down for a ramp).
    refine : bool
        Locate each transition between its two path voltages by bisection (to :data:`BISECTION_TOLERANCE`).
    progress : callable, optional
        Called with the step index after each step.

    Returns
    -------
    RampResult
    """
    phi_path = [float(p) for p in phi_path]
    if not phi_path:
        raise ModelRangeError("empty voltage path", "out_of_range")
    cache = {}

    def eqs_at(phi):
        key = round(phi, 14)
        if key not in cache:
            try:
                cache[key] = equilibria(family.curve(phi), gas, zones)
            except ModelRangeError as exc:  # nothing valid at this voltage: no equilibrium at all
                cache[key] = []
                notes.append(f"Φ̂ = {phi:.6g}: {exc}")
        return cache[key]

    # every equilibrium (for the figure and the equal-free-energy scan) on every 4th distinct voltage;
    # the path itself is followed at every voltage by continuing its own state
    distinct = sorted({round(p, 14) for p in phi_path})
    full_grid = set(distinct[::4]) | {distinct[-1]}

    steps, transitions, notes = [], [], []
    state = _initial_state(eqs_at(phi_path[0]))
    if state is None:
        raise ModelRangeError(f"no stable equilibrium at the start of the path (Φ̂ = {phi_path[0]:.6g})",
                              "no_equilibrium")
    for i, phi in enumerate(phi_path):
        direction = "up" if i == 0 or phi >= phi_path[i - 1] else "down"
        local = _local(family, gas, state, phi) if (i > 0 and state is not None) else None
        if local is not None and round(phi, 14) not in full_grid:
            steps.append(RampStep(phi, local, [local], direction, None))
            state = local
            if progress is not None:
                progress(i)
            continue
        eqs = eqs_at(phi)
        note = None
        if i > 0 and state is None:
            stable = [e for e in eqs if e.stable]
            if stable:
                # back inside the model's range: the zones that left it were the most bulged
                state = max(stable, key=lambda e: (e.k, max(e.zone_volumes)))
                note = f"a stable state exists again: {state.label} (re-entering the model's range)"
                transitions.append(Transition(phi, "re_entry", "none", state.label, direction,
                                              (phi_path[i - 1], phi)))
                notes.append(note)
        elif i > 0:
            nxt = local if local is not None else _continue(state, eqs)
            if nxt is None:
                stable = [e for e in eqs if e.stable]
                target = min(stable, key=lambda e: e.distance(state)) if stable else None
                lo, hi = phi_path[i - 1], phi
                if refine:
                    lo, hi = _bisect_loss(family, gas, zones, state, lo, hi)
                try:
                    stopped = family.curve(phi).stopped_because
                except ModelRangeError as exc:
                    stopped = str(exc)
                kind = "spinodal"
                why = "loses stability" if _continue(state, eqs, stable_only=False) else "ceases to exist"
                if target is None:
                    kind = "no_stable_state"
                    reason = stopped or "no stable equilibrium in the model's range"
                    note = (f"{state.label} {why} and no stable state remains: a zone bulges without bound "
                            f"or leaves the model's range ({reason})")
                    notes.append(note)
                transitions.append(Transition(0.5 * (lo + hi), kind, state.label,
                                              target.label if target else "none", direction, (lo, hi)))
                nxt = target
            state = nxt
        steps.append(RampStep(phi, state, eqs, direction, note))
        if progress is not None:
            progress(i)
    equal = _equal_free_energy(family, gas, zones, sorted(full_grid), eqs_at, refine)
    return RampResult(steps, transitions, equal, zones, notes)


def _local(family, gas, state, phi):
    """``state`` continued to ``Φ̂`` by Newton on the curve there, if it stays stable and close."""
    try:
        nxt = continue_equilibrium(family.curve(phi), gas, state)
    except ModelRangeError:
        return None
    if nxt is None or not nxt.stable:
        return None
    scale = max(max(state.zone_volumes), 1e-12)
    return nxt if nxt.distance(state) <= CONTINUATION_TOLERANCE * scale else None


def eqs_at_exact(family, gas, zones):
    """Equilibria at any voltage (not cached: used by the bisections); none where nothing is valid."""
    def at(phi):
        try:
            return equilibria(family.curve(phi), gas, zones)
        except ModelRangeError:
            return []
    return at


def _bisect_loss(family, gas, zones, state, lo, hi, tol=None):
    """Shrink [lo, hi] around the voltage where ``state``'s configuration stops being stable (or
    stops existing), following it by local continuation: Newton from the last voltage where it held
    either converges to a stable state close by, or the state is lost (unstable, or at its fold)."""
    ref = state
    tol = BISECTION_TOLERANCE if tol is None else tol
    for _ in range(60):
        if abs(hi - lo) <= tol:
            break
        mid = 0.5 * (lo + hi)
        nxt = _local(family, gas, ref, mid)
        if nxt is not None:
            lo, ref = mid, nxt
        else:
            hi = mid
    return lo, hi


def _delta_k(eqs, k):
    """``G(k bulged, stable) − G(homogeneous)`` among ``eqs``, or None where either is missing."""
    hom = [e for e in eqs if e.k == 0 and e.branch_unbulged == 0]
    mix = [e.free_energy for e in eqs if e.k == k and e.stable]
    if not hom or not mix:
        return None
    return min(mix) - min(hom, key=lambda e: e.v_unbulged).free_energy


def _equal_free_energy(family, gas, zones, phi_path, eqs_at, refine):
    """Voltages where a stable configuration with k bulged zones has the total free energy of the
    homogeneous one: sign changes of their difference along the grid, and configurations that appear
    (between two grid voltages) already lower, bisected to :data:`BISECTION_TOLERANCE`."""
    grid = sorted(set(round(p, 14) for p in phi_path))
    find_all = eqs_at_exact(family, gas, zones)

    def delta(phi, k):
        return _delta_k(find_all(phi), k)

    found = []
    prev = None
    for phi in grid:
        eqs = eqs_at(phi)
        diffs = {k: d for k in range(1, zones) if (d := _delta_k(eqs, k)) is not None}
        for k, d in diffs.items():
            if prev is None or d > 0:
                continue
            lo, hi = prev[0], phi
            if k in prev[1]:
                if prev[1][k] <= 0:
                    continue
            else:
                # the configuration appears inside (lo, hi): locate where, then compare there
                for _ in range(60):
                    if hi - lo <= BISECTION_TOLERANCE:
                        break
                    mid = 0.5 * (lo + hi)
                    lo, hi = (lo, mid) if delta(mid, k) is not None else (mid, hi)
                d_app = delta(hi, k)
                if d_app is None or d_app <= 0:
                    found.append(Transition(hi, "equal_free_energy", "homogeneous", f"{k} of {zones} bulged",
                                            "either", (lo, hi)))
                    continue
                lo, hi = hi, phi
            if refine:
                lo, hi = _bisect_sign(delta, k, lo, hi)
            found.append(Transition(0.5 * (lo + hi), "equal_free_energy", "homogeneous",
                                    f"{k} of {zones} bulged", "either", (lo, hi)))
        prev = (phi, diffs)
    return found


def _bisect_sign(delta, k, lo, hi, tol=None):
    """Bisect the sign change of ``delta(Φ̂, k)`` (positive at ``lo``) in [lo, hi]."""
    tol = BISECTION_TOLERANCE if tol is None else tol
    for _ in range(60):
        if hi - lo <= tol:
            break
        mid = 0.5 * (lo + hi)
        d = delta(mid, k)
        if d is None:
            break
        lo, hi = (mid, hi) if d > 0 else (lo, mid)
    return lo, hi
