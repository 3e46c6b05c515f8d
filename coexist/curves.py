"""The two curve families of one zone: ``p̂(V̂)`` at fixed ``Φ̂`` and ``Φ̂(Q̂)`` at fixed ``p̂``.

Both are traced by the pole stretch ``λ0``, which does not turn where pressure, voltage or volume
do, so the curves pass through their limit points. Limit points are then located precisely by
solving for the extremum (Chebyshev interpolation of the quantity on a shrinking bracket around
the grid extremum, converged to the solver tolerance), not read off the grid.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from . import validation
from .errors import ModelRangeError, SceneError, SolverError
from .model import MembraneModel
from .numerics.roots import bracketed_root, chebyshev_extremum
from .settings import SolverSettings
from .shooting import OK, MembraneStates, first_valid_run, reason_tag, reason_text, solve_states

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


@dataclass
class LimitPoint:
    """A turning point along a curve: ``kind`` is e.g. ``pressure_max`` or ``voltage_max``."""

    kind: str
    pole_stretch: float
    p_hat: float
    v_hat: float
    phi_hat: float
    q_hat: float
    psi_hat: float

    def to_dict(self) -> dict:
        """JSON-ready dict of the fields.

        Returns
        -------
        dict
            ``kind``, ``pole_stretch``, ``p_hat``, ``v_hat``, ``phi_hat``, ``q_hat``, ``psi_hat``.
        """
        return dict(self.__dict__)


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
        Why the curve starts later or ends earlier than the requested pole-stretch range.
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
            ``starts_because`` / ``stopped_because``; arrays as lists of floats.
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
        if self.starts_because:
            out["starts_because"] = self.starts_because
        if self.stopped_because:
            out["stopped_because"] = self.stopped_because
        return out


def _take(states: MembraneStates, index) -> MembraneStates:
    kw = {}
    for name, value in states.__dict__.items():
        if isinstance(value, np.ndarray):
            kw[name] = value[index]
        elif name == "shapes" and value is not None:
            kw[name] = [value[i] for i in np.arange(len(value))[index]]
        elif name == "derivatives" and value is not None:
            kw[name] = value.take(index)
        else:
            kw[name] = value
    return MembraneStates(**kw)


def _valid_run(states: MembraneStates, pole_stretch):
    """The first contiguous run of valid states, and why the range was cut before and after it."""
    ok = states.ok
    if not ok.any():
        i = 0
        raise ModelRangeError(
            f"no valid state anywhere in pole stretch {pole_stretch[0]:.4g}..{pole_stretch[-1]:.4g}"
            f" (at {pole_stretch[i]:.4g}: {reason_text(states.status[i])})",
            reason_tag(states.status[i]),
        )
    run = first_valid_run(ok)
    first, last = run.start, run.stop - 1
    starts = None
    if first > 0:
        code = states.status[first - 1]
        starts = f"{reason_tag(code)}: below pole stretch {pole_stretch[first]:.6g} {reason_text(code)}"
    stopped = None
    if last + 1 < ok.size:
        code = states.status[last + 1]
        stopped = f"{reason_tag(code)}: beyond pole stretch {pole_stretch[last]:.6g} {reason_text(code)}"
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


def _find_limit_points(states, quantities, evaluate_states, settings):
    """Refine every interior discrete extremum of the named quantities along the grid.

    ``quantities`` maps an attribute (``p_hat``) to its pair of kinds
    (``("pressure_max", "pressure_min")``); all brackets are refined together.
    """
    grid = states.pole_stretch
    brackets, kinds, attrs = [], [], []
    for attr, names in quantities.items():
        values = getattr(states, attr)
        d = np.diff(values)
        for i in range(1, values.size - 1):
            if d[i - 1] > 0 and d[i] <= 0:
                brackets.append((grid[i - 1], grid[i + 1], True))
                kinds.append(names[0])
            elif d[i - 1] < 0 and d[i] >= 0:
                brackets.append((grid[i - 1], grid[i + 1], False))
                kinds.append(names[1])
            else:
                continue
            attrs.append(attr)
    if not brackets:
        return []
    per_attr: dict[str, list[int]] = {}
    for j, attr in enumerate(attrs):
        per_attr.setdefault(attr, []).append(j)

    found: list = [None] * len(brackets)
    for attr, sel in per_attr.items():

        def g_of(x, attr=attr):
            st = evaluate_states(x)
            return np.where(st.ok, getattr(st, attr), np.nan)

        lo, hi, is_max = (np.array([brackets[j][k] for j in sel]) for k in range(3))
        try:
            x_star, _ = chebyshev_extremum(
                g_of,
                lo,
                hi,
                is_max,
                ftol=0.5 * settings.rtol,
                xtol=settings.limit_point_xtol,
                nodes=settings.limit_point_nodes,
            )
        except ValueError as exc:
            raise SolverError(f"no valid state near a limit point of {attr}: {exc}") from None
        at = evaluate_states(x_star)
        for k, j in enumerate(sel):
            found[j] = _limit_point(kinds[j], _take(at, slice(k, k + 1)))
    return sorted(found, key=lambda lp: lp.pole_stretch)


def _check_range(pole_stretch, model):
    l0 = validation.real_array(pole_stretch, "pole_stretch")
    if l0.ndim != 1 or l0.size < 3:
        raise SceneError("needs at least 3 pole stretches", "pole_stretch")
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
        No valid state near a limit point while refining it.

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
    )


def _trace(family, fixed, model, pole_stretch, points, evaluate, quantities, settings) -> Curve:
    """A curve of ``family`` from ``evaluate(λ0) -> MembraneStates`` on ``pole_stretch`` (default: ``points``
    from ``1.01 λpre`` to ``max(4, 1.5 λpre)``): its valid run, and the extrema of ``quantities`` located."""
    if pole_stretch is None:
        pole_stretch = np.linspace(1.01 * model.prestretch, max(4.0, 1.5 * model.prestretch), points)
    l0 = _check_range(pole_stretch, model)
    states = evaluate(l0)
    run, starts, stopped = _valid_run(states, l0)
    states = _take(states, run)
    limits = _find_limit_points(states, quantities, evaluate, settings)
    return Curve(family, float(fixed), states, limits, starts, stopped, settings.rtol)


def voltage_at_pressure(
    model: MembraneModel, pole_stretch, p_hat: float, settings: SolverSettings | None = None, iterations: int = 60
) -> MembraneStates:
    """States at given pole stretches that carry the pressure ``p̂``: solves ``p̂(λ0, Φ̂) = p̂`` for ``Φ̂``.

    The pressure falls as the voltage rises at fixed pole stretch; the root in ``s = Φ̂²`` is found by
    a safeguarded regula falsi (Illinois) on ``[0, s_pole]``, where ``s_pole`` is the voltage at
    which the pole tension vanishes. Pole stretches with ``p̂(λ0, 0) < p̂`` carry no voltage that
    reaches the pressure and are flagged ``no_equilibrium``; voltages at which the state fails
    (wrinkling at the clamp, ...) shrink the bracket from above.

    Parameters
    ----------
    model : MembraneModel
        A membrane with electrostatics.
    pole_stretch : array_like
        Pole stretches ``λ0 > λpre``.
    p_hat : float
        The normalised pressure ``p̂ > 0`` to carry.
    settings : SolverSettings, optional
        Shooting tolerances; the root is converged to ``inner_ftol · p̂`` and accepted within
        ``10 residual_tol · p̂``.
    iterations : int
        Largest number of regula falsi iterations.

    Returns
    -------
    MembraneStates
        One entry per pole stretch, ``phi_hat`` the voltage found; entries without one have status
        ``NO_VOLTAGE`` (or the failure of their zero-voltage state) and NaN quantities.

    Raises
    ------
    SceneError
        If the model has no electrostatics, or for invalid pole stretches.
    """
    from .shooting import NO_VOLTAGE

    settings = validation.settings_or_default(settings)
    validation.membrane_model(model)
    p_hat = validation.real(p_hat, "p_hat", lo=0.0, lo_open=True)
    if not model.has_voltage:
        raise SceneError("a voltage-charge curve needs a model with electrostatics", "voltage")
    l0 = validation.real_array(pole_stretch, "pole_stretch")
    n = l0.size
    # bracket: s = 0 and the voltage that makes the pole tension vanish (grown by doubling, then located)
    hi_s = np.ones(n)
    for _ in range(60):
        grow = model.pole(l0, np.sqrt(hi_s))[0] > 0
        if not np.any(grow):
            break
        hi_s = np.where(grow, hi_s * 2, hi_s)
    pole_root = bracketed_root(
        lambda x, idx: model.pole(l0[idx], np.sqrt(x))[0], np.zeros(n), hi_s, rtol=1e-15, ftol=1e-14 * l0
    )
    s0 = solve_states(model, l0, 0.0, settings)
    f0 = np.where(s0.ok, s0.p_hat - p_hat, -np.inf)
    feasible = f0 >= 0
    result = s0
    converged = feasible & (f0 == 0)
    open_ = np.flatnonzero(feasible & (f0 > 0))
    if open_.size:

        def residual(x, idx):
            rows = open_[idx]
            st = solve_states(model, l0[rows], np.sqrt(x), settings)
            _merge(result, _take(st, st.ok), rows[st.ok])
            result.status[rows[~st.ok]] = st.status[~st.ok]
            return np.where(st.ok, st.p_hat - p_hat, -np.inf)  # an invalid state: beyond the root

        # towards the pole-wrinkling voltage the pressure falls to zero: f = −p̂ at the upper end
        root = bracketed_root(
            residual,
            np.zeros(open_.size),
            pole_root.x[open_],
            f0[open_],
            np.full(open_.size, -p_hat),
            rtol=1e-15,
            ftol=settings.inner_ftol * p_hat,
            max_iter=iterations,
        )
        # converged: the pressure is met to the solver's accuracy, or the bracket closed with the residual
        # still at that level (noise-limited); anything else failed
        met = root.converged & np.isfinite(root.f) & (np.abs(root.f) <= 10 * settings.residual_tol * p_hat)
        converged[open_] = met
    status = result.status.copy()
    status[~converged & (status == OK)] = NO_VOLTAGE
    status[~feasible] = np.where(s0.ok[~feasible], NO_VOLTAGE, s0.status[~feasible])
    result.status = status
    for name in ("p_hat", "v_hat", "q_hat", "psi_hat", "apex_height", "max_field", "min_tension"):
        getattr(result, name)[status != OK] = np.nan
    return result


def _merge(base: MembraneStates, new: MembraneStates, where) -> MembraneStates:
    for name, value in base.__dict__.items():
        if isinstance(value, np.ndarray):
            value[where] = getattr(new, name)
    return base


def voltage_charge_curve(
    model: MembraneModel, p_hat: float, pole_stretch=None, settings: SolverSettings | None = None
) -> Curve:
    """The ``Φ̂–Q̂`` curve of a clamped zone at fixed normalised pressure ``p̂``.

    Traced by the pole stretch; at each ``λ0`` the voltage is the root of ``p̂(λ0, Φ̂) = p̂``
    (:func:`voltage_at_pressure`). The voltage maximum (snap-through voltage under pressure
    control) is refined to the solver tolerance.

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
        Family ``voltage_charge``, with the voltage and charge extrema refined to the solver tolerance.

    Raises
    ------
    SceneError
        ``p̂`` not positive, a model without electrostatics, or fewer than 3 pole stretches, not
        increasing or not above ``λpre``.
    ModelRangeError
        No pole stretch of the grid carries ``p̂`` (the reason of the first).
    SolverError
        No valid state near a limit point while refining it.
    """
    settings = validation.settings_or_default(settings)
    validation.membrane_model(model)
    p_hat = validation.real(p_hat, "p_hat", lo=0.0, lo_open=True)
    return _trace(
        "voltage_charge",
        p_hat,
        model,
        pole_stretch,
        settings.charge_curve_points,
        lambda x: voltage_at_pressure(model, x, p_hat, settings),
        {"phi_hat": ("voltage_max", "voltage_min"), "q_hat": ("charge_max", "charge_min")},
        settings,
    )


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
