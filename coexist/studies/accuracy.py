"""What accuracy costs in time: work-precision studies of the project's headline outputs.

In the style of the SciML work-precision benchmarks: for each headline output, the error against a
tight reference (computed once, at settings tighter than any in the sweep) is set against the wall
time, for every solver setting the project offers. Two kinds of setting are swept, each as its own
*family* (one line in the figure), every family passing through the project's default:

- the integrator tolerance ``rtol`` (:class:`~coexist.settings.SolverSettings`), sampling fixed at
  its default;
- the sampling (curve points, spline points), ``rtol`` fixed at its default ``1e-10``.

The three studies
-----------------
1. ``pressure_max``: the snap-through pressure ``p̂max`` of the neo-Hookean ``p̂–V̂`` curve at
   ``Φ̂ = 0.1`` (:func:`~coexist.curves.pressure_volume_curve`, limit point refined), against the
   number of pole-stretch points and ``rtol``. Also the *tolerance* data: achieved relative error
   (of ``p̂max`` and of every state of the curve) against the requested ``rtol``.
2. ``maxwell_pressure``: the Maxwell coexistence pressure of a Gent (``Jlim = 100``) zone at
   ``Φ̂ = 0`` (:func:`~coexist.coexistence.maxwell_coexistence` on a
   :class:`~coexist.zone_curves.ZoneCurve`), against the spline points ``n`` and ``rtol``.
3. ``transition_voltage``: the first (spinodal) transition voltage, in kV, of the built-in
   ``tricircle`` scene (:func:`~coexist.fit.transition_voltage`: an event of the continuation on the
   exact equations), against ``rtol``. The scene is read when the study runs; if its transition cannot
   be computed (:class:`~coexist.errors.ModelRangeError`), the study falls back to
   :data:`FALLBACK_SCENE_CHANGES` and says so in its notes.

Errors are relative, ``|x − x_ref| / |x_ref|``. Times are wall times (``time.perf_counter``) of the
whole computation a user would run for that output (model construction excluded for studies 1–2,
included for study 3), the best of a few repeats.
Each study also reports the *resolution* of its reference (its difference from a second reference
computed differently); errors below it are not resolved and are drawn at it.

Everything returned is a plain dataclass with a ``to_dict()`` for JSON.
"""

from __future__ import annotations

import dataclasses
import math
import time
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from ..errors import CoexistError, ModelRangeError
from ..settings import SolverSettings

#: the project's default tolerance (``SolverSettings()``)
DEFAULT_RTOL = SolverSettings().rtol
#: tightest tolerance the project accepts is 1e-14; references use this one
REFERENCE_RTOL = 1e-13
#: study 1: voltage and pole-stretch range of the curve (the ``curves`` command's default range)
STUDY1_PHI_HAT = 0.1
STUDY1_POLE_STRETCH = (1.01, 4.0)
#: study 2: material, voltage and the lower end of the ``u`` grid
STUDY2_JLIM = 100.0
STUDY2_PHI_HAT = 0.0
STUDY2_U_MIN = math.sqrt(0.002)
#: study 3: what replaces the scene's material and radius when its transition cannot be computed
FALLBACK_SCENE_CHANGES = {"material": "gent", "jlim": 97.0, "zone_radius": 0.0214165}
#: a point whose time is within this factor of a front point of at least equal accuracy is
#: "near" the front (timings on a shared machine scatter by about this much)
TIME_NOISE_FACTOR = 1.5
#: smallest relative error that is meaningful at all (double precision, a few roundings)
ROUNDOFF = 1e-15


def _defaults():
    """The project's default sampling, read from :class:`SolverSettings` so the study follows any change."""
    defaults = SolverSettings()
    return {"curve_points": defaults.curve_points, "spline_points": defaults.phase_diagram_points}


# --- results -------------------------------------------------------------------------------------
@dataclass
class Measurement:
    """One solver setting of one study: the value it gives, its error and what it cost.

    Attributes
    ----------
    family : str
        The sweep it belongs to: ``"rtol"`` or the name of a sampling parameter (``"points"``,
        ``"n"``, ``"n_u"``, ``"n_s"``, ``"grid"`` for ``n_u`` and ``n_s`` refined together).
    label : str
        The setting, e.g. ``"rtol=1e-08"`` or ``"n_u=96"``.
    rtol : float
    sampling : dict
        The sampling parameters, e.g. ``{"points": 200}``.
    value : float or None
        The output (None if the computation failed; ``failed`` says why).
    error, abs_error : float or None
        Relative and absolute error against the reference.
    time : float or None
        Wall time in seconds, best of ``repeats``.
    repeats : int
        Runs timed.
    default : bool
        This is the project's default setting.
    failed : str or None
        Why the computation failed (the library error's message); None if it did not.
    extra : dict
        Further errors measured with this setting (study 1: ``states_max_error`` over the curve).
    """

    family: str
    label: str
    rtol: float
    sampling: dict
    value: float | None
    error: float | None
    abs_error: float | None
    time: float | None
    repeats: int
    default: bool = False
    failed: str | None = None
    extra: dict = field(default_factory=dict)

    def to_dict(self) -> dict:
        """JSON-ready copy of the fields.

        Returns
        -------
        dict
            Every field by name; numpy scalars as Python numbers, non-finite floats as None.
        """
        return _clean(dataclasses.asdict(self))


@dataclass
class Study:
    """One headline output: reference, measurements, Pareto front and where the default sits.

    ``measurements`` lists each setting once per family it belongs to (the default is in every
    family; it is measured once and shared).
    """

    number: int
    key: str
    title: str
    quantity: str
    unit: str
    reference: dict
    reference_checks: list
    resolution: float
    measurements: list
    families: dict
    notes: list = field(default_factory=list)
    tolerance: list = field(default_factory=list)
    setup: dict = field(default_factory=dict)

    @property
    def default(self) -> Measurement | None:
        """The measurement of the project's default setting, or None if there is none."""
        return next((m for m in self.measurements if m.default), None)

    def unique(self) -> list[Measurement]:
        """Every measured setting once (the default appears in several families).

        Returns
        -------
        list of Measurement
            In the order first measured; a setting is its ``rtol`` and ``sampling``.
        """
        seen, out = set(), []
        for m in self.measurements:
            key = (m.rtol, tuple(sorted(m.sampling.items())))
            if key not in seen:
                seen.add(key)
                out.append(m)
        return out

    def front(self) -> list[Measurement]:
        """The Pareto front of (time, error) over all settings, fastest first.

        Errors below the reference's resolution are not resolved and count as equal to it.

        Returns
        -------
        list of Measurement
            The non-dominated settings (:func:`pareto_front`) among those with an error and a time.
        """
        pts = [m for m in self.unique() if m.error is not None and m.time is not None]
        idx = pareto_front([m.time for m in pts], [self._floor(m.error) for m in pts])
        return [pts[i] for i in idx]

    def _floor(self, error):
        return max(error, self.resolution)

    def default_vs_front(self) -> dict:
        """Is the default on the Pareto front, and if not, how far from it.

        ``time_excess``: the default's time over the least time of any setting at least as
        accurate (1 on the front). ``error_excess``: the default's error over the least error of
        any setting at most as slow (1 on the front). ``near_front``: on it, or a setting of at least
        equal accuracy saves less than the timing noise (``time_excess ≤ 1.5``).

        Returns
        -------
        dict
            ``on_front``, ``near_front``, ``time_excess``, ``fastest_as_accurate`` and
            ``most_accurate_as_fast`` (labels), ``error_excess``, ``dominated_by`` (labels of the settings
            that dominate the default); if the default failed, ``on_front`` and ``near_front`` are None
            and ``note`` says so.
        """
        d = self.default
        if d is None or d.error is None:
            return {"on_front": None, "near_front": None, "note": "the default setting failed"}
        # (time, error, label) of every measured setting, the default's first
        pts = [(m.time, self._floor(m.error), m) for m in self.unique() if m.error is not None and m.time is not None]
        t_d, e_d = float(d.time or 0.0), self._floor(d.error)
        as_good = [p for p in pts if p[1] <= e_d]
        as_fast = [p for p in pts if p[0] <= t_d]
        fastest = min(as_good, key=lambda p: p[0])[2]
        best = min(as_fast, key=lambda p: p[1])[2]
        dominated_by = [m.label for t, e, m in pts if m is not d and t <= t_d and e <= e_d and (t < t_d or e < e_d)]
        time_excess = t_d / float(fastest.time or t_d)
        return {
            "on_front": not dominated_by,
            "near_front": (not dominated_by) or time_excess <= TIME_NOISE_FACTOR,
            "time_excess": time_excess,
            "fastest_as_accurate": fastest.label,
            "error_excess": e_d / self._floor(best.error),
            "most_accurate_as_fast": best.label,
            "dominated_by": dominated_by,
        }

    def to_dict(self) -> dict:
        """JSON-ready study.

        Returns
        -------
        dict
            The fields (``number`` as ``study``), the ``default`` measurement, the ``pareto_front`` labels
            and :meth:`default_vs_front`; numpy scalars as Python numbers, non-finite floats as None.
        """
        d = self.default
        return _clean(
            {
                "study": self.number,
                "key": self.key,
                "title": self.title,
                "quantity": self.quantity,
                "unit": self.unit,
                "setup": self.setup,
                "families": self.families,
                "reference": self.reference,
                "reference_checks": self.reference_checks,
                "resolution": self.resolution,
                "measurements": [m.to_dict() for m in self.measurements],
                "default": None if d is None else d.to_dict(),
                "pareto_front": [m.label for m in self.front()],
                "default_vs_front": self.default_vs_front(),
                "tolerance": self.tolerance,
                "notes": self.notes,
            }
        )


def _clean(obj):
    """JSON-safe: numpy scalars to Python, non-finite floats to None."""
    if isinstance(obj, dict):
        return {str(k): _clean(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_clean(v) for v in obj]
    if isinstance(obj, (np.floating, float)):
        x = float(obj)
        return x if math.isfinite(x) else None
    if isinstance(obj, np.integer):
        return int(obj)
    if isinstance(obj, np.bool_):
        return bool(obj)
    return obj


def pareto_front(times, errors) -> list[int]:
    """Indices of the non-dominated points of ``(time, error)``, fastest first.

    A point is dominated when another is no slower and no less accurate, and better in one.

    Parameters
    ----------
    times, errors : array_like
        Time and error of each point, shape ``(n,)``.

    Returns
    -------
    list of int
        Indices into ``times``, by increasing time (and decreasing error).
    """
    t = np.asarray(times, dtype=float)
    e = np.asarray(errors, dtype=float)
    order = np.lexsort((e, t))  # by time, ties by error
    front, best = [], math.inf
    for i in order:
        if e[i] < best:
            front.append(int(i))
            best = e[i]
    return front


# --- measuring -----------------------------------------------------------------------------------
def _timed(fn, repeats):
    """``(result, best wall time)`` of ``fn()`` over ``repeats`` runs."""
    best, out = math.inf, None
    for _ in range(max(1, repeats)):
        t0 = time.perf_counter()
        out = fn()
        best = min(best, time.perf_counter() - t0)
    return out, best


def _label(family, rtol, sampling):
    if family == "rtol":
        return f"rtol={rtol:.0e}"
    if family == "grid":
        return "n_u×n_s=" + "×".join(str(v) for v in sampling.values())
    return f"{family}={sampling[family]}"


class _Sweep:
    """Measures settings once each (shared between families) against a reference value."""

    def __init__(self, compute, reference_value, repeats, progress, default_key, extra=None):
        self.compute = compute
        self.ref = reference_value
        self.repeats = repeats
        self.progress = progress
        self.default_key = default_key
        self.extra = extra
        self.cache = {}
        self.measurements = []

    def add(self, family, rtol, sampling):
        key = (rtol, tuple(sorted(sampling.items())))
        is_default = key == self.default_key
        if key not in self.cache:
            label = _label(family, rtol, sampling)
            try:
                (value, payload), t = _timed(lambda: self.compute(rtol, **sampling), self.repeats)
                err = abs(value - self.ref) / abs(self.ref)
                extra = self.extra(rtol, sampling, payload) if self.extra else {}
                self.cache[key] = dict(
                    value=value, error=err, abs_error=abs(value - self.ref), time=t, failed=None, extra=extra
                )
                self.progress(f"  {label:<22} value {value:.12g}  error {err:.2e}  time {t:.3f} s")
            except CoexistError as exc:
                self.cache[key] = dict(value=None, error=None, abs_error=None, time=None, failed=str(exc), extra={})
                self.progress(f"  {label:<22} failed: {exc}")
        m = Measurement(
            family=family,
            label=_label(family, rtol, sampling),
            rtol=rtol,
            sampling=dict(sampling),
            repeats=self.repeats,
            default=is_default,
            **self.cache[key],
        )
        self.measurements.append(m)
        return m


def _noop(_msg):
    pass


# --- study 1: p̂max of a p̂–V̂ curve -----------------------------------------------------------------
def pressure_max_study(
    quick: bool = False, progress: Callable[[str], None] | None = None, repeats: int | None = None
) -> Study:
    """Study 1: the pressure maximum ``p̂max`` of the neo-Hookean ``p̂–V̂`` curve at ``Φ̂ = 0.1``.

    Families: ``rtol`` (at the default 200 points) and ``points`` (at the default ``rtol``).
    Reference: ``rtol = 1e-13``, 400 points; checked against 800 points (600 when ``quick``).
    The ``tolerance`` list holds, per requested ``rtol``, the achieved relative error of ``p̂max`` and
    the largest relative error of ``p̂`` and ``V̂`` over the 200 states of the curve.

    Parameters
    ----------
    quick : bool
        Fewer settings, 2 repeats and a 600-point check.
    progress : callable, optional
        Called with each line of progress (a ``str``).
    repeats : int, optional
        Runs per setting, the best time kept; default 2 if ``quick``, else 5.

    Returns
    -------
    Study
        The measurements, the reference and its checks and the ``tolerance`` data.

    Raises
    ------
    CoexistError
        If a computation outside the sweep (the warm-up, the reference or its checks) fails; a failure
        at a measured setting is recorded in its :class:`Measurement` instead.
    """
    from ..curves import pressure_volume_curve
    from ..model import MembraneModel
    from ..shooting import solve_states

    progress = progress or _noop
    repeats = repeats or (2 if quick else 5)
    model = MembraneModel()
    defaults = _defaults()
    n_default = defaults["curve_points"]

    def grid(points):
        return np.linspace(*STUDY1_POLE_STRETCH, int(points))

    def compute(rtol, points):
        curve = pressure_volume_curve(model, STUDY1_PHI_HAT, grid(points), SolverSettings(rtol=rtol))
        lp = [p for p in curve.limit_points if p.kind == "pressure_max"]
        if not lp:
            raise ModelRangeError("the curve has no pressure maximum", "no_limit_point")
        return lp[0].p_hat, curve

    progress("study 1: p̂max of the neo-Hookean p̂–V̂ curve at Φ̂ = 0.1")
    ref_points, check_points = 400, (600 if quick else 800)
    (ref, _), t_ref = _timed(lambda: compute(REFERENCE_RTOL, ref_points), 1)
    check, _ = compute(REFERENCE_RTOL, check_points)
    check_diff = abs(check - ref) / abs(ref)
    resolution = max(check_diff, ROUNDOFF)
    progress(
        f"  reference p̂max = {ref:.15g} (rtol 1e-13, {ref_points} points, {t_ref:.2f} s); "
        f"{check_points} points differ by {check_diff:.1e}"
    )
    ref_states = solve_states(model, grid(n_default), STUDY1_PHI_HAT, SolverSettings(rtol=REFERENCE_RTOL))

    def states_error(rtol, sampling, curve):
        if sampling["points"] != n_default:
            return {}
        s = curve.states
        r_p = np.interp(s.pole_stretch, ref_states.pole_stretch, ref_states.p_hat)
        r_v = np.interp(s.pole_stretch, ref_states.pole_stretch, ref_states.v_hat)
        return {
            "states_max_error_p_hat": float(np.max(np.abs(s.p_hat - r_p) / np.abs(r_p))),
            "states_max_error_v_hat": float(np.max(np.abs(s.v_hat - r_v) / np.abs(r_v))),
        }

    compute(1e-6, 25)  # warm-up
    sweep = _Sweep(compute, ref, repeats, progress, (DEFAULT_RTOL, (("points", n_default),)), states_error)
    rtols = [1e-4, 1e-6, 1e-8, 1e-10, 1e-12] if quick else [10.0**-k for k in range(4, 13)]
    points = [25, 100, 200] if quick else [25, 50, 100, 200]
    for r in rtols:
        sweep.add("rtol", r, {"points": n_default})
    for n in points:
        sweep.add("points", DEFAULT_RTOL, {"points": n})
    tolerance = [
        {
            "requested_rtol": m.rtol,
            "achieved_error": m.error,
            "states_max_error_p_hat": m.extra.get("states_max_error_p_hat"),
            "states_max_error_v_hat": m.extra.get("states_max_error_v_hat"),
        }
        for m in sweep.measurements
        if m.family == "rtol" and m.error is not None
    ]
    notes = []
    errs = [max(m.error, resolution) for m in sweep.measurements if m.family == "points" and m.error is not None]
    if errs and max(errs) <= 2 * min(errs):
        notes.append(
            f"the number of curve points ({min(points)}..{max(points)}) does not change the error of "
            "p̂max: the limit point is refined by Chebyshev interpolation on shrinking brackets, "
            "whatever grid found it"
        )
    return Study(
        number=1,
        key="pressure_max",
        title="p̂max, neo-Hookean p̂–V̂ curve at Φ̂ = 0.1",
        quantity="p̂max",
        unit="",
        resolution=resolution,
        reference={"rtol": REFERENCE_RTOL, "points": ref_points, "value": ref, "time": t_ref},
        reference_checks=[
            {"rtol": REFERENCE_RTOL, "points": check_points, "value": check, "relative_difference": check_diff}
        ],
        measurements=sweep.measurements,
        families={
            "rtol": f"integrator tolerance, {n_default} curve points",
            "points": f"pole-stretch points of the curve, rtol {DEFAULT_RTOL:.0e}",
        },
        tolerance=tolerance,
        notes=notes,
        setup={
            "material": "neo-hookean",
            "phi_hat": STUDY1_PHI_HAT,
            "pole_stretch": f"linspace({STUDY1_POLE_STRETCH[0]}, {STUDY1_POLE_STRETCH[1]}, points)",
            "timed": "pressure_volume_curve (states + refined limit points)",
        },
    )


# --- study 2: Maxwell pressure of a Gent zone ------------------------------------------------------
def maxwell_pressure_study(
    quick: bool = False, progress: Callable[[str], None] | None = None, repeats: int | None = None
) -> Study:
    """Study 2: the Maxwell coexistence pressure of a Gent (``Jlim = 100``) zone at ``Φ̂ = 0``.

    ``u = linspace(√0.002, √(0.95 √((Jlim + 3)/2) − 1), n)``, pole stretch ``1 + u²``. Families:
    ``rtol`` (at the default ``n = 128``) and ``n`` (at the default ``rtol``). Reference:
    ``rtol = 1e-13``, ``n = 1024``, checked against ``n = 512`` and (unless ``quick``) ``n = 2048``.

    Parameters
    ----------
    quick : bool
        Fewer settings and 1 repeat.
    progress : callable, optional
        Called with each line of progress (a ``str``).
    repeats : int, optional
        Runs per setting, the best time kept; default 1 if ``quick``, else 3.

    Returns
    -------
    Study
        The measurements, the reference and its checks.

    Raises
    ------
    CoexistError
        If a computation outside the sweep (the warm-up, the reference or its checks) fails; a failure
        at a measured setting is recorded in its :class:`Measurement` instead.
    """
    from ..coexistence import maxwell_coexistence
    from ..model import build_model
    from ..zone_curves import ZoneCurve

    progress = progress or _noop
    repeats = repeats or (1 if quick else 3)
    model = build_model("gent", STUDY2_JLIM)
    u_max = math.sqrt(0.95 * math.sqrt((STUDY2_JLIM + 3) / 2) - 1)
    n_default = _defaults()["spline_points"]

    def compute(rtol, n):
        u = np.linspace(STUDY2_U_MIN, u_max, int(n))
        curve = ZoneCurve.compute(model, STUDY2_PHI_HAT, 1 + u**2, SolverSettings(rtol=rtol))
        return maxwell_coexistence(curve, SolverSettings(rtol=rtol)).p_hat, None

    progress(f"study 2: Maxwell pressure of a Gent (Jlim = {STUDY2_JLIM:g}) zone at Φ̂ = 0")
    compute(1e-6, 64)  # warm-up (CasADi)
    ref_n = 1024
    (ref, _), t_ref = _timed(lambda: compute(REFERENCE_RTOL, ref_n), 1)
    checks = []
    for n in [512] if quick else [512, 2048]:
        v, _ = compute(REFERENCE_RTOL, n)
        checks.append({"rtol": REFERENCE_RTOL, "n": n, "value": v, "relative_difference": abs(v - ref) / abs(ref)})
    finer = [c for c in checks if c["n"] > ref_n]
    resolution = max((finer or checks)[0]["relative_difference"], ROUNDOFF)
    progress(
        f"  reference p̂ = {ref:.15g} (rtol 1e-13, n = {ref_n}, {t_ref:.2f} s); "
        + "; ".join(f"n = {c['n']} differs by {c['relative_difference']:.1e}" for c in checks)
    )
    sweep = _Sweep(compute, ref, repeats, progress, (DEFAULT_RTOL, (("n", n_default),)))
    rtols = [1e-4, 1e-6, 1e-8, 1e-10, 1e-12] if quick else [10.0**-k for k in range(4, 13)]
    ns = [32, 64, 128, 256] if quick else [32, 64, 128, 256, 512]
    for r in rtols:
        sweep.add("rtol", r, {"n": n_default})
    for n in ns:
        sweep.add("n", DEFAULT_RTOL, {"n": n})
    notes = [
        f"reference check: n = 512 and n = 1024 differ by {checks[0]['relative_difference']:.1e}"
        + (f", n = 1024 and n = 2048 by {checks[1]['relative_difference']:.1e}" if len(checks) > 1 else "")
    ]
    return Study(
        number=2,
        key="maxwell_pressure",
        title=f"Maxwell pressure, Gent Jlim = {STUDY2_JLIM:g}, Φ̂ = 0",
        quantity="p̂ (coexistence)",
        unit="",
        resolution=resolution,
        reference={"rtol": REFERENCE_RTOL, "n": ref_n, "value": ref, "time": t_ref},
        reference_checks=checks,
        measurements=sweep.measurements,
        families={
            "rtol": f"integrator tolerance, n = {n_default} spline points",
            "n": f"spline points in u = √(λ0 − 1), rtol {DEFAULT_RTOL:.0e}",
        },
        notes=notes,
        setup={
            "material": "gent",
            "jlim": STUDY2_JLIM,
            "phi_hat": STUDY2_PHI_HAT,
            "u": f"linspace(√0.002, {u_max:.6g}, n)",
            "timed": "ZoneCurve.compute + maxwell_coexistence",
        },
    )


# --- study 3: transition voltage of the tricircle scene ----------------------------------------------
def _transition_kV(scene, rtol):
    from ..fit import Shared, transition_voltage

    settings = SolverSettings(rtol=rtol, error_estimates=False)
    return transition_voltage(scene, "spinodal", Shared.of(scene, settings))[0] / 1e3


def transition_voltage_study(
    quick: bool = False,
    progress: Callable[[str], None] | None = None,
    repeats: int | None = None,
    scene_name: str = "tricircle",
) -> Study:
    """Study 3: the spinodal transition voltage (kV) of the built-in ``tricircle`` scene.

    The transition is an event of the continuation on the exact equations (the symmetric branch point
    where the homogeneous state is lost), so the one setting is the integrator tolerance ``rtol``.
    Reference: ``rtol = 1e-13``, checked against ``rtol = 1e-12``. Timed: the model, the closing state
    and the continuation up to the event (:func:`coexist.fit.transition_voltage`). If the scene as
    loaded has no transition (:class:`ModelRangeError`), the study uses it with
    :data:`FALLBACK_SCENE_CHANGES` and notes it.

    Parameters
    ----------
    quick : bool
        Fewer settings and 1 repeat.
    progress : callable, optional
        Called with each line of progress (a ``str``).
    repeats : int, optional
        Runs per setting, the best time kept; default 1 if ``quick``, else 3.
    scene_name : str
        The scene (:func:`~coexist.scene.load_scene`: a built-in name or a path).

    Returns
    -------
    Study
        The measurements, the reference and its checks.

    Raises
    ------
    CoexistError
        If the scene cannot be loaded (:class:`~coexist.errors.SceneError`), or a computation outside the
        sweep (the default setting's probe, also with the fallback, the reference or its check) fails; a
        failure at a measured setting is recorded in its :class:`Measurement` instead.
    """
    from ..scene import load_scene

    progress = progress or _noop
    repeats = repeats or (1 if quick else 3)
    scene = load_scene(scene_name)
    notes = []
    progress(
        f"study 3: spinodal transition voltage of the {scene_name} scene "
        f"({scene.material}{'' if scene.jlim is None else f', Jlim = {scene.jlim:g}'}, "
        f"zone radius {scene.zone_radius * 1e3:g} mm)"
    )
    used = scene
    try:  # the default setting first: says whether the scene has a transition, and warms up
        probe = _transition_kV(scene, DEFAULT_RTOL)
    except ModelRangeError as exc:
        used = dataclasses.replace(scene, **FALLBACK_SCENE_CHANGES)  # type: ignore[arg-type]
        msg = (
            f"the {scene_name} scene as loaded ({scene.material}, zone radius {scene.zone_radius * 1e3:g} mm) "
            f"has no transition: {exc}; using it with "
            + ", ".join(f"{k} = {v}" for k, v in FALLBACK_SCENE_CHANGES.items())
            + " instead"
        )
        notes.append(msg)
        progress("  note: " + msg)
        probe = _transition_kV(used, DEFAULT_RTOL)
    progress(f"  default setting gives {probe:.12g} kV")
    ref, t_ref = _timed(lambda: _transition_kV(used, REFERENCE_RTOL), 1)
    v = _transition_kV(used, 1e-12)
    checks = [{"rtol": 1e-12, "value": v, "relative_difference": abs(v - ref) / abs(ref)}]
    resolution = max(checks[0]["relative_difference"], ROUNDOFF)
    progress(
        f"  reference {ref:.14g} kV (rtol 1e-13, {t_ref:.1f} s); rtol 1e-12 differs by "
        f"{checks[0]['relative_difference']:.1e}"
    )

    def compute(rtol):
        return _transition_kV(used, rtol), None

    sweep = _Sweep(compute, ref, repeats, progress, (DEFAULT_RTOL, ()))
    rtols = [1e-6, 1e-8, 1e-10] if quick else [1e-4, 1e-6, 1e-8, 1e-10, 1e-12]
    for r in rtols:
        sweep.add("rtol", r, {})
    return Study(
        number=3,
        key="transition_voltage",
        title=f"transition voltage, {scene_name} scene (spinodal)",
        quantity="transition voltage",
        unit="kV",
        resolution=resolution,
        reference={"rtol": REFERENCE_RTOL, "value": ref, "time": t_ref},
        reference_checks=checks,
        measurements=sweep.measurements,
        families={"rtol": "integrator tolerance (the continuation's Newton and event tolerances follow it)"},
        notes=notes,
        setup={
            "scene": scene_name,
            "material": used.material,
            "jlim": used.jlim,
            "zone_radius_mm": used.zone_radius * 1e3,
            "fallback": used is not scene,
            "timed": "model + closing state + continuation to the first event (fit.transition_voltage)",
        },
    )


#: the studies by number
STUDIES = {1: pressure_max_study, 2: maxwell_pressure_study, 3: transition_voltage_study}


def run_studies(studies=(1, 2, 3), quick: bool = False, progress: Callable[[str], None] | None = None) -> list[Study]:
    """Run the chosen studies (numbers 1–3) in order.

    Parameters
    ----------
    studies : iterable of int
        Study numbers, keys of :data:`STUDIES`.
    quick : bool
        Fewer settings and repeats (see each study).
    progress : callable, optional
        Called with each line of progress (a ``str``).

    Returns
    -------
    list of Study
        In the order asked for.
    """
    return [STUDIES[int(k)](quick=quick, progress=progress) for k in studies]


def report(studies: list[Study], quick: bool = False, load_before=None) -> dict:
    """JSON-ready report of a set of studies, with the defaults and the machine it ran on.

    ``load_before``: ``os.getloadavg()`` taken before the studies ran (timings on a shared machine
    depend on its load; the load after is added here).

    Parameters
    ----------
    studies : list of Study
        The studies run.
    quick : bool
        Whether they ran with ``quick``.
    load_before : sequence of float, optional
        The 1, 5 and 15 minute load averages before the run.

    Returns
    -------
    dict
        ``quick``, ``defaults``, ``reference_rtol``, what ``error`` and ``time`` mean, ``machine`` (versions,
        CPUs, platform, load averages) and ``studies`` (each :meth:`Study.to_dict`); JSON-safe.
    """
    import os
    import platform

    try:
        load_after = list(os.getloadavg())
    except OSError:  # not available on every platform
        load_after = None

    return _clean(
        {
            "quick": bool(quick),
            "defaults": {"rtol": DEFAULT_RTOL, **_defaults()},
            "reference_rtol": REFERENCE_RTOL,
            "error": "relative, |x − x_ref| / |x_ref|",
            "time": "wall time in s (time.perf_counter), best of `repeats`",
            "machine": {
                "python": platform.python_version(),
                "numpy": np.__version__,
                "cpus": os.cpu_count(),
                "platform": platform.platform(),
                "load_average_before": None if load_before is None else list(load_before),
                "load_average_after": load_after,
            },
            "studies": [s.to_dict() for s in studies],
        }
    )


def summary_lines(study: Study) -> list[str]:
    """A plain-text table of one study.

    Parameters
    ----------
    study : Study
        The study.

    Returns
    -------
    list of str
        Title, reference, one row per measurement (the default starred), where the default sits
        relative to the Pareto front, and the notes.
    """
    lines = [
        f"study {study.number}: {study.title}",
        f"  reference {study.reference['value']:.15g} {study.unit}".rstrip() + f"  (resolution {study.resolution:.1e})",
    ]
    lines.append(f"  {'family':<7} {'setting':<22} {'value':>20} {'rel. error':>11} {'time (s)':>9}")
    for m in study.measurements:
        star = " *" if m.default else ""
        if m.failed:
            lines.append(f"  {m.family:<7} {m.label:<22} failed: {m.failed}")
            continue
        lines.append(f"  {m.family:<7} {m.label:<22} {m.value:>20.14g} {m.error:>11.2e} {m.time:>9.3f}{star}")
    dv = study.default_vs_front()
    if dv.get("on_front") is not None:
        where = (
            "on the Pareto front"
            if dv["on_front"]
            else ("near the Pareto front" if dv["near_front"] else "off the Pareto front")
        )
        lines.append(
            f"  default (*) is {where}: time ×{dv['time_excess']:.2f} of the fastest setting as accurate "
            f"({dv['fastest_as_accurate']}), error ×{dv['error_excess']:.3g} of the best as fast "
            f"({dv['most_accurate_as_fast']})"
        )
    for n in study.notes:
        lines.append(f"  note: {n}")
    return lines
