"""The shape of a zone: its meridian ``(r, z)`` in physical units, apex height, apex curvature.

Lenses, grippers and haptic bumps are designed by their shape. For a state ``(λ0, Φ̂)`` of one clamped
zone this module gives

- the **profile**: the meridian ``(r(R), z(R))`` at reference radii ``R̂ = R/A`` from the pole to the
  clamp, ``z`` measured up from the clamp plane. It is integrated again, for all requested states at
  once, by the project's vectorised DOP853 (:func:`coexist.numerics.dop853.integrate`) on the same
  equations (:meth:`MembraneModel.rhs`), from the same series start, with the same trial pressure and
  tolerances as :func:`coexist.shooting.solve_states`, *stopping at every output radius* (so every
  point is a solution value at the integrator's tolerance, not an interpolation between the shooting's
  few nodes); the last step lands on the clamp with ``λ2`` as the independent variable, as the shooting's
  does. The points are equally spaced in the reference radius ``R̂`` (material points). A hoop-wrinkled
  state of a tension-field model (:mod:`coexist.wrinkling`, docs/physics.md sections 10 and 11) is
  integrated the same way, segment by segment between the switches its shooting located, on the relaxed
  equations (:func:`coexist.wrinkling.segment_equations`; :func:`_relaxed_points`). In a wrinkled band
  ``r = ρ R`` is the *geometric* radius of the wrinkled surface (its mean, the wrinkles' amplitude unresolved):
  the material there is wider than the surface, ``λ2* > ρ``, and its excess is taken up by the wrinkles;
- the **apex height** ``h``: :attr:`MembraneStates.apex_height` of the converged state;
- the **apex curvature** ``κ0``, exact at the pole from the Laplace law of the equibiaxial pole
  (docs/physics.md, section 11): ``κ0 A = p̂ λ0 / (2 T̂0)``, ``T̂0 = T̂1(λ0, λ0; Φ̂)`` — never fitted to points;
- the **electrode edges**: where the electrode begins or ends on the deformed membrane, from the pole out.
  A uniform electrode covers the whole zone, so its one edge is the clamp, ``R̂ = 1``: ``(r, z) = (λpre A, 0)``;
  an inner circle has one edge (its disc's rim), a ring two (its inner and its outer edge, the latter the clamp
  when the ring reaches it) (:func:`patterned_profiles`).

A state is checked against the shooting: the re-integration must land on the clamp at the shooting's
clamp radius, with its apex height and volume (to ``10⁴ rtol``), else :class:`~coexist.errors.SolverError`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from . import validation
from .errors import ModelRangeError, SceneError, SolverError
from .model import QUADRATURE_FACTORS, MembraneModel
from .numerics import dop853 as _int
from .numerics.sets import unique_sorted
from .settings import SolverSettings
from .shooting import ROUNDOFF_TOLERANCE, _integrators, solve_states, start_rows

#: the re-integrated state must agree with the shooting's (clamp radius, apex height, volume) to this many
#: of its relative tolerances; beyond it something is wrong and the profile is refused
AGREEMENT_FACTOR = 1e4
#: fewest points of a profile (the pole, one interior point, the clamp)
MIN_POINTS = 3
#: values of :func:`profiles`' ``wrinkled``: every one gives a hoop-wrinkled state its profile; ``"raise"`` and
#: ``"numbers"`` (before, a refusal and the apex numbers without points) are kept for the callers that pass them
WRINKLED_OPTIONS = ("profile", "raise", "numbers")


@dataclass
class Profile:
    """The meridian of one zone's state and its shape numbers.

    Lengths are stored over the zone radius ``A`` (``*_hat``); the properties without the hat give them
    in metres (``A = zone_radius``).

    Attributes
    ----------
    pole_stretch, phi_hat, p_hat, v_hat : float
        The state: ``λ0``, ``Φ̂``, ``p̂ = pA/(μH)`` and ``V̂ = V/A³``.
    zone_radius : float
        ``A`` in metres.
    prestretch : float
        ``λpre``: the clamp lies at ``r = λpre A``.
    R_hat : numpy.ndarray
        Reference radii ``R/A`` of the points, from 0 (pole) to 1 (clamp).
    r_hat, z_hat : numpy.ndarray
        ``r/A`` and ``z/A`` of the points (``z`` up from the clamp plane).
    apex_height_hat : float
        ``h/A``: the pole's height, :attr:`MembraneStates.apex_height` of the converged state.
    apex_curvature_hat : float
        ``κ0 A = p̂ λ0 / (2 T̂0)`` (Laplace law at the equibiaxial pole; 0 for the flat membrane).
    electrode_edge_R_hat : float
        Reference radius of the electrode's first edge from the pole (1: a uniform electrode, whose edge is the
        clamp; a ring's inner edge).
    electrode_edge_hat : tuple of float
        ``(r/A, z/A)`` of that edge on the deformed membrane.
    wrinkled_radii : tuple of (float, float)
        Hoop-wrinkled intervals ``(R̂start, R̂end)`` of a tension-field state (empty when taut). Its points are
        computed as a taut state's; inside these intervals ``r_hat`` is the *geometric* radius ``ρR̂`` of the
        wrinkled surface (shorter than the material across the wrinkles, docs/physics.md section 11).
    electrode_edges_hat : tuple of (float, float, float)
        Every edge of the electrode, from the pole out, as ``(R̂, r/A, z/A)``: one for a uniform electrode (the
        clamp) and an inner circle, two for a ring (inner and outer edge; the outer one is the clamp when the
        ring reaches it). The first is ``(electrode_edge_R_hat, *electrode_edge_hat)``; left empty, it is filled
        with that one edge.
    """

    pole_stretch: float
    phi_hat: float
    p_hat: float
    v_hat: float
    zone_radius: float
    prestretch: float
    R_hat: np.ndarray
    r_hat: np.ndarray
    z_hat: np.ndarray
    apex_height_hat: float
    apex_curvature_hat: float
    electrode_edge_R_hat: float
    electrode_edge_hat: tuple
    wrinkled_radii: tuple = ()
    electrode_edges_hat: tuple = ()

    def __post_init__(self) -> None:
        if not self.electrode_edges_hat:
            self.electrode_edges_hat = ((self.electrode_edge_R_hat, *self.electrode_edge_hat),)

    @property
    def r(self) -> np.ndarray:
        """Radial positions of the points in metres, ``r̂ A``."""
        return self.r_hat * self.zone_radius

    @property
    def z(self) -> np.ndarray:
        """Heights of the points above the clamp plane in metres, ``ẑ A``."""
        return self.z_hat * self.zone_radius

    @property
    def apex_height(self) -> float:
        """Height of the pole above the clamp plane in metres."""
        return self.apex_height_hat * self.zone_radius

    @property
    def apex_curvature(self) -> float:
        """Curvature ``κ0`` of the meridian at the pole in 1/m (both principal curvatures there)."""
        return self.apex_curvature_hat / self.zone_radius

    @property
    def radius_of_curvature(self) -> float:
        """``1/κ0`` in metres (``inf`` for the flat membrane)."""
        return math.inf if self.apex_curvature_hat == 0 else 1.0 / self.apex_curvature

    @property
    def electrode_edge(self) -> tuple:
        """``(r, z)`` of the electrode's edge in metres."""
        return (self.electrode_edge_hat[0] * self.zone_radius, self.electrode_edge_hat[1] * self.zone_radius)

    @property
    def electrode_edges(self) -> tuple:
        """``(r, z)`` of every edge of the electrode in metres, from the pole out (:attr:`electrode_edges_hat`)."""
        return tuple((r * self.zone_radius, z * self.zone_radius) for _, r, z in self.electrode_edges_hat)

    def to_dict(self, points: bool = True) -> dict:
        """The shape, JSON-ready, in mm and 1/m.

        Parameters
        ----------
        points : bool
            Include the profile's points (``profile``: ``r_mm``, ``z_mm``).

        Returns
        -------
        dict
            ``pole_stretch``, ``apex_height_mm``, ``apex_curvature_per_m``, ``radius_of_curvature_mm``
            (None for the flat membrane), ``electrode_edge_mm`` (``[r, z]`` of the first edge from the pole),
            ``electrode_edges_mm`` (``[r, z]`` of every edge, from the pole out: a ring's inner and outer edge),
            ``wrinkled_radii`` (the hoop-wrinkled ``[R̂start, R̂end]`` intervals, empty when taut) and, with
            ``points``, ``profile`` (in a wrinkled interval ``r_mm`` is the geometric radius; None for a profile
            without points).
        """
        roc = self.radius_of_curvature
        out: dict = {
            "pole_stretch": float(self.pole_stretch),
            "apex_height_mm": float(self.apex_height * 1e3),
            "apex_curvature_per_m": float(self.apex_curvature),
            "radius_of_curvature_mm": None if math.isinf(roc) else float(roc * 1e3),
            "electrode_edge_mm": [float(x * 1e3) for x in self.electrode_edge],
            "electrode_edges_mm": [[float(r * 1e3), float(z * 1e3)] for r, z in self.electrode_edges],
        }
        out["wrinkled_radii"] = [[float(a), float(b)] for a, b in self.wrinkled_radii]
        if points:
            out["profile"] = (
                {"r_mm": [float(x) for x in self.r * 1e3], "z_mm": [float(x) for x in self.z * 1e3]}
                if self.r_hat.size
                else None
            )
        return out


def apex_curvature_hat(model: MembraneModel, pole_stretch, phi_hat, p_hat):
    """``κ0 A = p̂ λ0 / (2 T̂0)``: the meridian's curvature at the pole times the zone radius.

    The pole is equibiaxial (``λ1 = λ2 = λ0``), so both principal curvatures equal ``κ0`` and the true
    tension (per deformed length) is ``t = μH T̂0/λ0`` in every direction; the Laplace law
    ``p = 2 t κ0`` with ``p = p̂ μH/A`` gives the formula (docs/physics.md, section 11). It is the
    series start's ``θ = cR̂`` read on the unit membrane: ``κ0 A = c/λ0``, ``c = p̂ λ0²/(2T̂0)``.

    Parameters
    ----------
    model : MembraneModel
        The membrane (its pole tension :meth:`MembraneModel.pole`).
    pole_stretch, phi_hat, p_hat : float or array_like
        ``λ0``, ``Φ̂`` and the state's pressure ``p̂``, broadcast.

    Returns
    -------
    float or numpy.ndarray
        ``κ0 A`` (0 where ``p̂ = 0``).
    """
    l0 = np.asarray(pole_stretch, dtype=float)
    T0 = np.asarray(model.pole(l0, phi_hat)[0], dtype=float)
    out = np.asarray(p_hat, dtype=float) * l0 / (2 * T0)
    return float(out) if out.ndim == 0 else out


def _flat(model, phi, zone_radius, s):
    """The flat membrane at ``p̂ = 0``: ``r = λpre R``, ``z = 0``, no curvature; it needs ``T̂0 ≥ 0`` (``T̂0 = 0``:
    the stress-free disc, ``λpre = 1`` at ``Φ̂ = 0``; below, it would be compressed: it wrinkles)."""
    lam = model.prestretch
    T1, _, T11, _, margin, _, _ = (float(x) for x in model.tensions(lam, lam, phi))
    if not (T1 >= 0 and margin > 0 and T11 > 0):
        raise ModelRangeError(
            f"the flat membrane at Φ̂ = {phi:.6g} is not taut (pole tension {T1:.3g}): it wrinkles or is "
            "beyond the model's range",
            "wrinkling",
        )
    return Profile(
        pole_stretch=lam,
        phi_hat=phi,
        p_hat=0.0,
        v_hat=0.0,
        zone_radius=zone_radius,
        prestretch=lam,
        R_hat=s.copy(),
        r_hat=lam * s,
        z_hat=np.zeros_like(s),
        apex_height_hat=0.0,
        apex_curvature_hat=0.0,
        electrode_edge_R_hat=1.0,
        electrode_edge_hat=(lam, 0.0),
    )


def profiles(
    model: MembraneModel,
    pole_stretch,
    phi_hat=0.0,
    *,
    zone_radius: float,
    points: int = 201,
    settings: SolverSettings | None = None,
    wrinkled: str = "profile",
) -> list[Profile]:
    """The profiles of many states of one zone (:class:`Profile`), integrated together.

    Each state is first shot (:func:`~coexist.shooting.solve_states`, which checks it: a locked,
    unreachable, or (for a model that refuses wrinkling) wrinkled state raises); then its meridian is
    integrated again from the pole with the same trial pressure ``p̂t``, series start and tolerances, stopping
    at the radii ``R̂ = k/(points − 1)`` of the unit membrane (``R = R̂ R*`` of the trial integration; below the
    series radius the series itself), the last step onto the clamp ``λ2 = λpre`` with ``λ2`` as the independent
    variable. With the clamp radius ``R*`` so found: ``R̂ = R/R*``, ``r̂ = λ2 R/R*``, ``ẑ = (z(R*) − z(R))/R*``.

    A hoop-wrinkled state of a tension-field model (``wrinkled_radii`` not empty) is integrated segment by
    segment between the switches its shooting located: taut equations up to a band's start ``R̂s`` (where
    ``T̂2 = 0``), the relaxed ones through the band (``R̂T̂1`` constant, ``θ' = p̂t λ1 ρ/T̂1``,
    ``λ1' = −T̂1/(R̂K)``, the natural width ``w`` with ``T̂2(λ1, w) = 0``, docs/physics.md section 10), taut again
    from its end (``w = ρ``); each switch is moved onto the re-integrated trajectory's own zero of the switching
    function by one Newton step. There ``r̂ = ρ R/R*`` is the *geometric* radius: the surface is shorter than
    the material across the wrinkles (``ρ < w``). The clamp is reached by a Newton step along the trajectory
    from the shooting's ``R*``. Its apex numbers are those of a taut state (the pole is taut).

    A pole stretch equal to the prestretch is the flat membrane (``p̂ = 0``, ``r = λpre R``, ``z = 0``,
    no curvature), provided its tension is not negative at that voltage (else it wrinkles: refused).

    Parameters
    ----------
    model : MembraneModel
        The membrane.
    pole_stretch : float or array_like
        ``λ0 ≥ λpre``.
    phi_hat : float or array_like
        ``Φ̂ ≥ 0``, broadcast against ``pole_stretch``.
    zone_radius : float
        ``A`` in metres (the physical lengths of the profiles).
    points : int
        Points per profile, pole and clamp included (at least 3).
    settings : SolverSettings, optional
        Tolerances (default :class:`SolverSettings`), the same as the shooting's.
    wrinkled : {"profile", "raise", "numbers"}
        What a hoop-wrinkled state of a tension-field model gives: its :class:`Profile` with points, apex
        numbers and wrinkled intervals, whichever value. ``"raise"`` (the former default: a refusal) and
        ``"numbers"`` (the apex numbers without points) are the values of the time its profile was not
        computed, kept for the callers that pass them; they now give the profile too.

    Returns
    -------
    list of Profile
        One per state, in the order given.

    Raises
    ------
    SceneError
        If an input is out of range (names it).
    ModelRangeError
        If a state does not exist (wrinkling under a model that refuses it, pull-in, locking, no clamp;
        :meth:`MembraneStates.require_ok`), or the flat membrane is not taut at that voltage.
    SolverError
        If the re-integration does not reach the clamp or disagrees with the shooting.
    """
    settings, A = _checked_profile_inputs(model, zone_radius, points, settings)
    if wrinkled not in WRINKLED_OPTIONS:
        raise SceneError(f"must be one of {', '.join(map(repr, WRINKLED_OPTIONS))}, got {wrinkled!r}", "wrinkled")
    l0, phi = validation.broadcastable(
        "pole_stretch, phi_hat",
        validation.real_array(pole_stretch, "pole_stretch"),
        validation.real_array(phi_hat, "phi_hat", lo=0.0),
    )
    l0 = np.array(l0, dtype=float).ravel()
    phi = np.array(phi, dtype=float).ravel()
    n = l0.size
    _refuse_huge_profiles(n, int(points))
    s = np.linspace(0.0, 1.0, int(points))
    out: list[Profile | None] = [None] * n
    flat = l0 == model.prestretch
    for i in np.flatnonzero(flat):
        out[i] = _flat(model, float(phi[i]), A, s)
    live = np.flatnonzero(~flat)
    if live.size:
        for i, prof in zip(live, _integrate(model, l0[live], phi[live], A, s, settings)):
            out[i] = prof
    return [p for p in out if p is not None]


def profile(
    model: MembraneModel,
    pole_stretch,
    phi_hat=0.0,
    *,
    zone_radius: float,
    points: int = 201,
    settings: SolverSettings | None = None,
):
    """The profile of one state (a number ``pole_stretch``), or of many (an array): :func:`profiles`.

    Parameters
    ----------
    model : MembraneModel
        The membrane.
    pole_stretch : float or array_like
        ``λ0 ≥ λpre`` (``λ0 = λpre``: the flat membrane).
    phi_hat : float or array_like
        ``Φ̂ ≥ 0``.
    zone_radius : float
        ``A`` in metres.
    points : int
        Points per profile (at least 3).
    settings : SolverSettings, optional
        Tolerances (default :class:`SolverSettings`).

    Returns
    -------
    Profile or list of Profile
        A :class:`Profile` when both ``pole_stretch`` and ``phi_hat`` are numbers, else a list.

    Raises
    ------
    SceneError, ModelRangeError, SolverError
        As :func:`profiles`.

    Examples
    --------
    >>> from coexist import MembraneModel
    >>> prof = profile(MembraneModel(), 1.5, 0.0, zone_radius=0.02, points=41)
    >>> round(prof.apex_height * 1e3, 4), round(prof.apex_curvature, 3)  # mm, 1/m
    (15.9758, 45.044)
    """
    many = profiles(model, pole_stretch, phi_hat, zone_radius=zone_radius, points=points, settings=settings)
    if np.ndim(pole_stretch) == 0 and np.ndim(phi_hat) == 0:
        return many[0]
    return many


def _integrate(model, l0, phi, A, s, settings) -> list[Profile]:
    """The profiles of the inflated states ``(l0, phi)`` (module docstring, :func:`profiles`): taut states by
    :func:`_points`, hoop-wrinkled ones (a tension-field model, :mod:`coexist.wrinkling`) by
    :func:`_relaxed_points`."""
    st = solve_states(model, l0, phi, settings).require_ok()
    kappa = np.atleast_1d(apex_curvature_hat(model, l0, phi, st.p_hat))
    rings = st.wrinkled_radii or [[] for _ in range(l0.size)]
    wrinkled = np.array([len(w) > 0 for w in rings], dtype=bool)
    result: list[Profile] = []
    for j in range(l0.size):
        result.append(
            Profile(
                pole_stretch=float(l0[j]),
                phi_hat=float(phi[j]),
                p_hat=float(st.p_hat[j]),
                v_hat=float(st.v_hat[j]),
                zone_radius=A,
                prestretch=model.prestretch,
                R_hat=np.empty(0),
                r_hat=np.empty(0),
                z_hat=np.empty(0),
                apex_height_hat=float(st.apex_height[j]),
                apex_curvature_hat=float(kappa[j]),
                electrode_edge_R_hat=1.0,
                electrode_edge_hat=(model.prestretch, 0.0),
                wrinkled_radii=tuple((float(a), float(b)) for a, b in rings[j]),
            )
        )
    for group, points_of in ((np.flatnonzero(~wrinkled), _points), (np.flatnonzero(wrinkled), _relaxed_points)):
        if group.size:
            sub = st if group.size == l0.size else _take(st, group)
            for jj, pts in zip(group, points_of(model, l0[group], phi[group], s, settings, sub)):
                result[jj].R_hat, result[jj].r_hat, result[jj].z_hat = pts
    return result


def _take(st, idx):
    """The fields of ``st`` this module reads, at the states ``idx``."""
    from types import SimpleNamespace

    out = SimpleNamespace(**{k: getattr(st, k)[idx] for k in ("clamp_radius", "apex_height", "v_hat")})
    out.wrinkled_radii = None if st.wrinkled_radii is None else [st.wrinkled_radii[i] for i in idx]
    return out


def _points(model, l0, phi, s, settings, st) -> list:
    """``(R̂, r̂, ẑ)`` at the output radii ``s`` of the taut states ``(l0, phi)`` shot as ``st``."""
    m = l0.size
    lam = model.prestretch
    eq = _integrators(model)
    R0 = settings.series_radius
    # the shooting's start (the series at R0) and tolerances (from the size of every row at R̂ = 1)
    pt, y, atol, rtol = start_rows(model, settings, l0, phi, False)
    pt = np.asarray(pt, dtype=float) * np.ones(m)
    k_last = s.size - 1
    rows = np.full((s.size, 7, m), np.nan)  # the state at every output radius (trial units)
    radii = np.outer(s, st.clamp_radius)
    near = _series_rows(model, l0, pt, phi, radii, R0, rows)
    t = np.full(m, R0)
    for k in range(1, k_last):
        cols = np.flatnonzero(~near[k])
        if not cols.size:
            continue
        res = _int.integrate(
            eq.radius, t[cols], y[:, cols], radii[k, cols], rtol[cols], atol[:, cols], settings.max_steps
        )
        bad = (res.status != _int.REACHED_END) | (res.y[1] <= lam)
        if bad.any():
            j = cols[np.flatnonzero(bad)[0]]
            raise SolverError(
                f"profile at pole stretch {l0[j]:.6g}, Φ̂ = {phi[j]:.6g}: the re-integration stopped before the "
                f"clamp (at R̂ = {s[k]:.4g})"
            )
        t[cols], y[:, cols] = res.t, res.y
        rows[k][:, cols] = res.y[:7]
    # the last step onto the clamp, λ2 as the independent variable (Hénon's trick, as the shooting)
    z0 = np.vstack([t, y[0], y[2:7], y[7:9]])
    atol_h = np.vstack([np.full(m, settings.atol), atol[0], atol[2:7], atol[7:9]])
    hop = _int.integrate(eq.hoop, y[1], z0, np.full(m, lam), rtol, atol_h, settings.max_steps)
    missed = (hop.status != _int.REACHED_END) | ~np.all(np.isfinite(hop.y), axis=0) | ~(hop.y[0] > t)
    if missed.any():
        j = int(np.flatnonzero(missed)[0])
        raise SolverError(
            f"profile at pole stretch {l0[j]:.6g}, Φ̂ = {phi[j]:.6g}: the last step does not land on the clamp"
        )
    Rs = hop.y[0]
    rows[k_last] = np.vstack([hop.y[1], np.full(m, lam), hop.y[2:7]])
    radii[k_last] = Rs
    ztot = hop.y[6]
    apex = ztot / Rs
    v_hat = QUADRATURE_FACTORS[0] * hop.y[3] / Rs**3
    _agree(l0, phi, rtol, st, Rs, apex, v_hat)
    return _scaled_points(l0, phi, radii, rows, Rs, ztot)


def _relaxed_points(model, l0, phi, s, settings, st) -> list:
    """``(R̂, r̂, ẑ)`` at the output radii ``s`` of the hoop-wrinkled states ``(l0, phi)`` of a tension-field model,
    shot as ``st``.

    The meridian is integrated again as :func:`_points` does (the shooting's series start, trial pressure ``p̂t``
    and tolerances, :func:`coexist.shooting.start_rows`; a stop at every output radius ``R = R̂k R*``) but segment
    by segment between the switches the shooting located (``st.wrinkled_radii``, known to ~1e-13, times ``R*``),
    on :func:`coexist.wrinkling.segment_equations`: the taut right-hand side up to a band's start, where the width
    row is set to the hoop stretch (``w = ρ``: ``T̂2 = 0`` there) and the hoop-wrinkled one takes over (``R̂T̂1``
    constant, the width polished on every evaluation, row 1 the geometric hoop stretch ``ρ``), the taut one again
    from the band's end (``λ2 = ρ``). ``λ1, ρ, θ`` and the quadratures are continuous at a switch (only the slopes
    jump), so each segment starts from the last one's end. The last stop is the shooting's clamp radius ``R*``;
    one Newton step along the trajectory lands on ``ρ = λpre`` (``R*`` moves by ``d = (ρ − λpre)/ρ'``, about the
    tolerance, and the landing's error is ``~ρ'' d²``)."""
    from .wrinkling import TAUT, WRINKLED, segment_equations

    m = l0.size
    lam = model.prestretch
    eqs = segment_equations(model)
    fun = (eqs.taut, eqs.wrinkled)
    R0 = settings.series_radius
    pt, y0, atol0, rtol = start_rows(model, settings, l0, phi, False)
    pt = np.asarray(pt, dtype=float) * np.ones(m)
    # the relaxed rows: the state, the width (polished at every evaluation: not error-controlled), p̂t, Φ̂
    y = np.vstack([y0[:7], y0[1:2], y0[7:]])
    atol = np.vstack([atol0[:7], np.full((1, m), 1e300), atol0[7:]])
    Rs_shot = np.asarray(st.clamp_radius, dtype=float)
    k_last = s.size - 1
    rows = np.full((s.size, 7, m), np.nan)  # the state at every output radius (trial units)
    radii = np.outer(s, Rs_shot)
    near = _series_rows(model, l0, pt, phi, radii, R0, rows)
    # per state its stops in trial radius, in order: output radii (their index k), switches (−1), the clamp
    SWITCH = -1
    stops = []
    for j in range(m):
        sw = [x * Rs_shot[j] for a, b in st.wrinkled_radii[j] for x in (a, b) if x < 1.0]
        out = [(radii[k, j], k) for k in range(1, k_last) if not near[k, j]]
        stops.append(sorted(out + [(x, SWITCH) for x in sw], key=lambda e: e[0]) + [(Rs_shot[j], k_last)])
    n_stops = max(len(x) for x in stops)
    stop_R = np.array([[e[0] for e in x] + [np.nan] * (n_stops - len(x)) for x in stops]).T
    stop_k = np.array([[e[1] for e in x] + [k_last] * (n_stops - len(x)) for x in stops]).T
    mode = np.full(m, TAUT)  # TAUT (0) or WRINKLED (1), the index into fun
    t = np.full(m, R0)
    for i in range(n_stops):
        target = stop_R[i]
        live = np.isfinite(target)
        for md in (TAUT, WRINKLED):
            cols = np.flatnonzero((mode == md) & live & (target != t))
            if not cols.size:
                continue
            res = _int.integrate(
                fun[md], t[cols], y[:, cols], target[cols], rtol[cols], atol[:, cols], settings.max_steps
            )
            bad = (res.status != _int.REACHED_END) | ~np.all(np.isfinite(res.y), axis=0)
            if bad.any():
                j = cols[np.flatnonzero(bad)[0]]
                raise SolverError(
                    f"profile at pole stretch {l0[j]:.6g}, Φ̂ = {phi[j]:.6g}: the re-integration of the wrinkled "
                    f"state stopped at R̂ = {t[j] / Rs_shot[j]:.6g}, before R̂ = {target[j] / Rs_shot[j]:.6g}"
                )
            t[cols], y[:, cols] = res.t, res.y
        k = stop_k[i]
        here = np.flatnonzero(live & (k >= 0) & (k < k_last))
        rows[k[here], :, here] = y[:7, here].T
        turns = [np.flatnonzero(live & (k == SWITCH) & (mode == md)) for md in (TAUT, WRINKLED)]
        for md, turn in zip((TAUT, WRINKLED), turns):
            if turn.size:
                _turn(eqs, md, turn, t, y, rtol, Rs_shot, l0, phi)
                mode[turn] = 1 - md
    # every state is at the shooting's clamp radius: one Newton step along the trajectory onto ρ = λpre
    f = np.empty_like(y)
    for md in (TAUT, WRINKLED):
        cols = np.flatnonzero(mode == md)
        if cols.size:
            f[:, cols] = fun[md](t[cols], y[:, cols])
    d = (y[1] - lam) / f[1]
    Rs = t - d
    yc = y - f * d
    if not (np.all(np.isfinite(Rs)) and np.all(np.isfinite(yc[:7]))):
        j = int(np.flatnonzero(~np.isfinite(Rs) | ~np.all(np.isfinite(yc[:7]), axis=0))[0])
        raise SolverError(
            f"profile at pole stretch {l0[j]:.6g}, Φ̂ = {phi[j]:.6g}: the wrinkled state does not land on the clamp"
        )
    rows[k_last] = yc[:7]
    rows[k_last, 1] = lam
    radii[k_last] = Rs
    ztot = yc[6]
    apex = ztot / Rs
    v_hat = QUADRATURE_FACTORS[0] * yc[3] / Rs**3
    _agree(l0, phi, rtol, st, Rs, apex, v_hat)
    return _scaled_points(l0, phi, radii, rows, Rs, ztot)


def _turn(eqs, md, cols, t, y, rtol, Rs_shot, l0, phi) -> None:
    """Switch the columns ``cols`` (in segments of kind ``md``, at the shooting's switch radius) to the other kind,
    in place: the switch is moved onto this trajectory's own zero of the switching function ``g`` (``T̂2`` taut,
    ``w − ρ`` wrinkled) by one Newton step along it, ``δ = −g/g'`` (the shooting located it on its own trajectory,
    which differs from this one by the tolerance: switching at its radius would carry the jump of ``λ1'`` times
    that offset into the rest of the meridian); a band's start sets the width row to ``ρ``. An offset beyond
    ``AGREEMENT_FACTOR rtol R*`` is not the shooting's switch: :class:`SolverError`."""
    from .wrinkling import TAUT

    f = (eqs.taut, eqs.wrinkled)[md](t[cols], y[:, cols])
    g, dg = eqs.switching(md, y[:, cols], f)
    delta = -np.asarray(g, dtype=float).ravel() / np.asarray(dg, dtype=float).ravel()
    off = ~(np.abs(delta) <= AGREEMENT_FACTOR * rtol[cols] * Rs_shot[cols])
    if off.any():
        j = cols[np.flatnonzero(off)[0]]
        raise SolverError(
            f"profile at pole stretch {l0[j]:.6g}, Φ̂ = {phi[j]:.6g}: the re-integrated meridian does not switch "
            f"where the shooting did (R̂ = {t[j] / Rs_shot[j]:.12g}; its own switch is "
            f"{float(delta[np.flatnonzero(off)[0]]) / Rs_shot[j]:.3g} away)"
        )
    t[cols] += delta
    y[:, cols] += f * delta
    if md == TAUT:  # T̂2 = 0 where the band starts: the width is the hoop stretch
        y[eqs.width_row, cols] = y[1, cols]


def _series_rows(model, l0, pt, phi, radii, R0, rows) -> np.ndarray:
    """Fill ``rows[k]`` (the state in trial units at ``radii[k]``) below the series radius ``R0`` by the pole's
    series itself (the pole is its ``R = 0``); returns where that was done (all but the last output radius)."""
    near = radii < R0
    near[-1] = False
    for k in range(radii.shape[0] - 1):
        cols = np.flatnonzero(near[k])
        if cols.size:
            vals = model.series_start(l0[cols], pt[cols], phi[cols], radii[k, cols])[:7]
            rows[k][:, cols] = np.vstack([np.broadcast_to(np.asarray(v, dtype=float), (cols.size,)) for v in vals])
    return near


def _agree(l0, phi, rtol, st, Rs, apex, v_hat) -> None:
    """The re-integrated state is the shooting's (clamp radius, apex height, volume to ``AGREEMENT_FACTOR rtol``),
    or :class:`SolverError` naming the state and the quantity."""
    tol = AGREEMENT_FACTOR * rtol
    for name, mine, theirs in (
        ("clamp radius", Rs, st.clamp_radius),
        ("apex height", apex, st.apex_height),
        ("volume", v_hat, st.v_hat),
    ):
        off = ~(np.abs(mine - theirs) <= tol * np.maximum(np.abs(theirs), 1e-3))
        if off.any():
            j = int(np.flatnonzero(off)[0])
            raise SolverError(
                f"profile at pole stretch {l0[j]:.6g}, Φ̂ = {phi[j]:.6g}: the re-integrated {name} "
                f"{mine[j]:.12g} differs from the shooting's {theirs[j]:.12g}"
            )


def _scaled_points(l0, phi, radii, rows, Rs, ztot) -> list:
    """``(R̂, r̂, ẑ)`` per state from the trial rows at the output radii: ``R̂ = R/R*``, ``r̂ = λ2 R/R*`` (``ρ R/R*``
    in a wrinkled band), ``ẑ = (z(R*) − z(R))/R*``; the pole at ``r̂ = 0``, the clamp at ``ẑ = 0``."""
    out = []
    for j in range(l0.size):
        R = radii[:, j]
        r_hat = rows[:, 1, j] * R / Rs[j]
        z_hat = (ztot[j] - rows[:, 6, j]) / Rs[j]
        r_hat[0], z_hat[-1] = 0.0, 0.0
        if not (np.all(np.isfinite(r_hat)) and np.all(np.isfinite(z_hat))):
            raise SolverError(f"profile at pole stretch {l0[j]:.6g}, Φ̂ = {phi[j]:.6g}: non-finite points")
        out.append((R / Rs[j], r_hat, z_hat))
    return out


def _refuse_huge_profiles(states: int, points: int) -> None:
    """Refuse, before any work, profiles whose output or memory would pass the limits of :mod:`coexist.cost` (as
    ``coexist shape`` is refused): ``profile(..., points=10**8)`` ran for minutes, and a large batch of states with
    many points each ran out of memory."""
    from .cost import (
        MAX_MEMORY_BYTES,
        MAX_OUTPUT_NUMBERS,
        SHAPE_BYTES_PER_NUMBER,
        SHAPE_NUMBERS_PER_POINT,
        SHAPE_NUMBERS_PER_SHAPE,
    )

    numbers = states * (SHAPE_NUMBERS_PER_POINT * points + SHAPE_NUMBERS_PER_SHAPE)
    if numbers > MAX_OUTPUT_NUMBERS or numbers * SHAPE_BYTES_PER_NUMBER > MAX_MEMORY_BYTES:
        per = (SHAPE_NUMBERS_PER_POINT * states) or 1
        fits = int(min(0.9 * MAX_OUTPUT_NUMBERS, 0.9 * MAX_MEMORY_BYTES / SHAPE_BYTES_PER_NUMBER) // per)
        raise SceneError(
            f"{states} profiles × {points} points would give {numbers:,} numbers (about "
            f"{numbers * SHAPE_BYTES_PER_NUMBER / 1e9:.3g} GB); the limits are {MAX_OUTPUT_NUMBERS:,} numbers and "
            f"{MAX_MEMORY_BYTES / 1e9:g} GB: take points {fits} or fewer, or fewer states",
            "points",
        )


def _checked_profile_inputs(model, zone_radius, points, settings):
    """The settings (default :class:`SolverSettings`) and the zone radius ``A`` of a profile request, its model,
    radius and point count checked (:class:`SceneError` naming the input)."""
    settings = validation.settings_or_default(settings)
    validation.membrane_model(model)
    A = validation.real(zone_radius, "zone_radius", lo=0.0, lo_open=True)
    if isinstance(points, bool) or not isinstance(points, (int, np.integer)) or points < MIN_POINTS:
        raise SceneError(f"must be an integer of at least {MIN_POINTS}, got {points!r}", "points")
    return settings, A


def equilibrium_profiles(model: MembraneModel, eq, zone_radius: float, points: int = 201, settings=None) -> list:
    """The profile of every group of identical zones of an equilibrium (:func:`profiles`; a hoop-wrinkled group
    too, its points through the wrinkled band on the relaxed equations; a patterned zone's by
    :func:`patterned_profiles`).

    Parameters
    ----------
    model : MembraneModel
        The zones' model.
    eq : Equilibrium
        A state of the zones (:class:`~coexist.equilibria.Equilibrium`: per group ``pole_stretch``, and
        ``phi_hat``).
    zone_radius : float
        ``A`` in metres.
    points : int
        Points per profile.
    settings : SolverSettings, optional
        Tolerances.

    Returns
    -------
    list of (int, Profile)
        ``(zones in the group, its profile)``, least inflated group first (as ``eq.pole_stretch``).
    """
    lam = np.asarray(eq.pole_stretch, dtype=float)
    pattern = getattr(model, "pattern", None)
    if pattern is not None:  # a patterned zone (PatternedModel): region by region, its edges among the points
        one_layer = getattr(model, "uniform", model)
        profs = patterned_profiles(
            one_layer, pattern, lam, float(eq.phi_hat), zone_radius=zone_radius, points=points, settings=settings
        )
    else:
        profs = profiles(model, lam, float(eq.phi_hat), zone_radius=zone_radius, points=points, settings=settings)
    return list(zip((int(c) for c in eq.configuration.counts), profs))


# --- patterned zones: profiles, and the states of one zone along a voltage path ----------------------------


def _pole_layers(pattern, phi):
    """``(n0, Φ̂0)``: the pole region's layers and per-layer voltage (0 without electrode)."""
    r0 = pattern.regions[0]
    phi = np.asarray(phi, dtype=float)
    return float(r0.layers), (phi / r0.layers if r0.electrode else np.zeros_like(phi))


def patterned_apex_curvature_hat(model: MembraneModel, pattern, pole_stretch, phi_hat, p_hat):
    """``κ0 A = (p̂/n0) λ0 / (2 T̂1(λ0, λ0; Φ̂0))`` of a patterned zone: the Laplace law of the pole's stack.

    The pole region is a stack of ``n0`` layers, the one-layer membrane at ``p̂/n0`` and ``Φ̂0 = Φ̂/n0`` (0 without
    electrode): its true tension is ``t = n0 μH T̂0/λ0`` in every direction, and ``p = 2tκ0`` gives the formula
    (:func:`apex_curvature_hat` on the one-layer membrane; docs/physics.md, sections 11 and 12).

    Parameters
    ----------
    model : MembraneModel
        The one-layer membrane.
    pattern : ZonePattern
        The zone's regions (only the pole region's layers and electrode are used).
    pole_stretch, phi_hat, p_hat : float or array_like
        ``λ0``, the electrode voltage ``Φ̂`` and the stack's pressure ``p̂``, broadcast.

    Returns
    -------
    float or numpy.ndarray
        ``κ0 A``.
    """
    n0, phi0 = _pole_layers(pattern, phi_hat)
    return apex_curvature_hat(model, pole_stretch, phi0, np.asarray(p_hat, dtype=float) / n0)


def _electrode_edges(pattern) -> list:
    """Indices of the interfaces where the electrode begins or ends (an electroded region next to a passive
    one), from the pole out; ``-1`` stands for the clamp when the outermost region carries the electrode."""
    regions = pattern.regions
    edges = [i for i in range(len(regions) - 1) if regions[i].electrode != regions[i + 1].electrode]
    if regions[-1].electrode:
        edges.append(-1)
    return edges


def patterned_profiles(
    model: MembraneModel,
    pattern,
    pole_stretch,
    phi_hat=0.0,
    *,
    zone_radius: float,
    points: int = 201,
    settings: SolverSettings | None = None,
) -> list[Profile]:
    """The profiles of states of a patterned zone (:class:`Profile`), integrated together region by region.

    Each state is first solved by :func:`coexist.patterned.solve_patterned_states` (which checks it: an unreachable
    state raises; a hoop-wrinkled one raises unless the membrane is a tension-field one, whose wrinkled states are
    solved by :func:`coexist.patterned_relaxed.solve_patterned_relaxed` and integrated again by
    :func:`_patterned_relaxed_points`, the same stops on the relaxed equations, ``r`` in a wrinkled band the
    geometric radius, ``wrinkled_radii`` the bands). A taut state's meridian is then integrated again in the
    shooting's trial units (pressure ``p̂t = p̂/R*``, clamp at ``R*``, the state's ``clamp_radius``), from the
    series start of the pole region at ``p̂t/n0`` and ``Φ̂/n0``, stopping at the reference radii
    ``R̂ = k/(points − 1)`` and at every interface ``fi`` (added to the points, so that the profile has its kinks
    where they are); at an interface the meridional stretch jumps so that the stack's meridional force is continuous,
    ``n⁺ T̂1(λ1⁺, λ2; Φ̂⁺) = n⁻ T̂1(λ1⁻, λ2; Φ̂⁻)`` (:func:`coexist.patterned.interface_stretch`), and the region's
    ``p̂t/n``, ``Φ̂/n`` take over. The last point is the clamp ``R = R*``: there ``λ2`` must equal ``λpre`` and
    the height and volume the solver's, to ``10⁴ rtol`` (else :class:`SolverError`). Then ``R̂ = R/R*``,
    ``r̂ = λ2 R/R*`` and ``ẑ = (z(R*) − z(R))/R*``.

    The apex curvature is the Laplace law of the pole's stack (:func:`patterned_apex_curvature_hat`); the
    electrode edges (``electrode_edges_hat``, from the pole out) are the solver's interface points where the
    electrode begins or ends, the clamp when the outermost region carries the electrode: for an inner circle
    one, its disc's rim; for a ring two, its inner and its outer edge. An edge's ``R̂`` is the pattern's
    fraction ``fi`` (the solver puts the interface there to its tolerance), its ``(r̂, ẑ)`` the solver's.
    ``electrode_edge_R_hat`` and ``electrode_edge_hat`` are the first edge (a ring's inner edge).

    Parameters
    ----------
    model : MembraneModel
        The one-layer membrane.
    pattern : ZonePattern
        The zone's regions.
    pole_stretch : float or array_like
        ``λ0 > λpre``.
    phi_hat : float or array_like
        The electrode voltage ``Φ̂ ≥ 0``, broadcast against ``pole_stretch``.
    zone_radius : float
        ``A`` in metres.
    points : int
        Equally spaced reference radii per profile, pole and clamp included (at least 3); the interfaces are
        added to them.
    settings : SolverSettings, optional
        Tolerances (default :class:`SolverSettings`).

    Returns
    -------
    list of Profile
        One per state, in the order given.

    Raises
    ------
    SceneError
        If an input is out of range (names it).
    ModelRangeError
        If a state does not exist (:meth:`coexist.patterned.PatternedStates.require_ok`, with its reason).
    SolverError
        If the re-integration does not land on the clamp or disagrees with the solver.
    """
    from .patterned import ZonePattern, solve_patterned_states

    settings, A = _checked_profile_inputs(model, zone_radius, points, settings)
    validation.instance(pattern, ZonePattern, "pattern", "a ZonePattern (e.g. ZonePattern.inner_circle(0.5))")
    st = solve_patterned_states(model, pattern, pole_stretch, phi_hat, settings)
    from .shooting import WRINKLED

    wrinkled = np.flatnonzero(st.status == WRINKLED) if model.tension_field else np.empty(0, dtype=int)
    if wrinkled.size:  # hoop-wrinkled states of a tension-field membrane: the relaxed states
        from .patterned_relaxed import solve_patterned_relaxed

        relaxed = solve_patterned_relaxed(model, pattern, st.pole_stretch[wrinkled], st.phi_hat[wrinkled], settings)
        relaxed.require_ok()
        _replace_rows(st, wrinkled, relaxed)
    st.require_ok()
    l0 = np.asarray(st.pole_stretch, dtype=float)
    phi = np.asarray(st.phi_hat, dtype=float)
    kappa = np.atleast_1d(patterned_apex_curvature_hat(model, pattern, l0, phi, st.p_hat))
    f = np.array(pattern.interfaces, dtype=float)
    S = unique_sorted(np.concatenate([np.linspace(0.0, 1.0, int(points)), f]))
    pts: list = [None] * l0.size
    taut = np.setdiff1d(np.arange(l0.size), wrinkled)
    for group, points_of in ((taut, _patterned_points), (wrinkled, _patterned_relaxed_points)):
        if group.size:
            for j, pt in zip(group, points_of(model, pattern, _patterned_rows(st, group), S, settings)):
                pts[j] = pt
    rings = st.wrinkled_radii or [[] for _ in range(l0.size)]
    lam = model.prestretch
    out = []
    for j in range(l0.size):
        edges = []
        for i in _electrode_edges(pattern):
            if i < 0:
                edges.append((1.0, lam, 0.0))
            else:
                r_i, z_i = (float(x) for x in st.interfaces[j, i, 0, 1:3])
                edges.append((float(f[i]), r_i, float(st.apex_height[j]) - z_i))
        first = edges[0] if edges else (1.0, lam, 0.0)
        R_hat, r_hat, z_hat = pts[j]
        out.append(
            Profile(
                pole_stretch=float(l0[j]),
                phi_hat=float(phi[j]),
                p_hat=float(st.p_hat[j]),
                v_hat=float(st.v_hat[j]),
                zone_radius=A,
                prestretch=lam,
                R_hat=R_hat,
                r_hat=r_hat,
                z_hat=z_hat,
                apex_height_hat=float(st.apex_height[j]),
                apex_curvature_hat=float(kappa[j]),
                electrode_edge_R_hat=first[0],
                electrode_edge_hat=(first[1], first[2]),
                electrode_edges_hat=tuple(edges) or (first,),
                wrinkled_radii=tuple((float(a), float(b)) for a, b in rings[j]),
            )
        )
    return out


_PATTERNED_FIELDS = ("pole_stretch", "phi_hat", "p_hat", "v_hat", "apex_height", "clamp_radius", "status", "interfaces")


def _replace_rows(st, rows, other) -> None:
    """Put the states ``other`` (one per entry of ``rows``) into the patterned states ``st``, in place: the fields the
    profiles read, and the wrinkled intervals."""
    for name in _PATTERNED_FIELDS + ("q_hat", "psi_hat", "max_field", "min_tension"):
        getattr(st, name)[rows] = getattr(other, name)
    radii = list(st.wrinkled_radii) if st.wrinkled_radii is not None else [[] for _ in range(st.pole_stretch.size)]
    for i, r in zip(rows, other.wrinkled_radii):
        radii[i] = r
    st.wrinkled_radii = radii
    for i, d in zip(rows, other.failure_detail):
        st.failure_detail[i] = d


def _patterned_rows(st, rows):
    """The fields of the patterned states ``st`` the profiles read, at ``rows``."""
    from types import SimpleNamespace

    return SimpleNamespace(**{k: np.asarray(getattr(st, k))[rows] for k in _PATTERNED_FIELDS})


def _patterned_relaxed_points(model, pattern, st, S, settings) -> list:
    """``(R̂, r̂, ẑ)`` at the reference radii ``S`` (interfaces among them) of the hoop-wrinkled patterned states
    ``st`` of a tension-field membrane: their relaxed shooting
    (:func:`coexist.patterned_relaxed.solve_patterned_relaxed`) once more at their interface scale, stopping at
    every ``R̂`` (:func:`coexist.patterned_relaxed.relaxed_profile_rows`; in a wrinkled band ``r`` is the geometric
    radius of the wrinkled surface, as for a uniform zone). The clamp radius, apex height and volume of that pass
    must be the solver's to ``AGREEMENT_FACTOR rtol``."""
    from .patterned_relaxed import relaxed_profile_rows

    l0 = np.asarray(st.pole_stretch, dtype=float)
    phi = np.asarray(st.phi_hat, dtype=float)
    res = relaxed_profile_rows(model, pattern, st, S, settings)
    bad = np.flatnonzero(res["status"] != 0)
    if bad.size:
        j = int(bad[0])
        raise SolverError(
            f"profile at pole stretch {l0[j]:.6g}, Φ̂ = {phi[j]:.6g}: the relaxed re-integration with stops does not "
            "land on the clamp"
        )
    Rs, ztot = res["R"], res["z"]
    _agree(l0, phi, res["rtol"], st, Rs, ztot / Rs, res["V"] / Rs**3)
    # the points' R̂ are the stops themselves (the interfaces at s fk, the clamp at R* = s to the tolerance)
    return [
        (S.copy(), r_hat, z_hat) for _, r_hat, z_hat in _scaled_points(l0, phi, res["radii"], res["rows"], Rs, ztot)
    ]


def _patterned_points(model, pattern, st, S, settings) -> list:
    """``(R̂, r̂, ẑ)`` at the reference radii ``S`` (interfaces among them) of the patterned states ``st``."""
    from .patterned import interface_stretch, pole_series_radius
    from .shooting import start_rows

    l0 = np.asarray(st.pole_stretch, dtype=float)
    m = l0.size
    phi = np.asarray(st.phi_hat, dtype=float)
    regions = pattern.regions
    n = [float(r.layers) for r in regions]
    ph = [phi / r.layers if r.electrode else np.zeros(m) for r in regions]
    iface = {float(r.outer): i for i, r in enumerate(regions[:-1])}
    lam = model.prestretch
    eq = _integrators(model)
    Rs = np.asarray(st.clamp_radius, dtype=float)
    p_t = np.asarray(st.p_hat, dtype=float) / Rs
    R0 = pole_series_radius(model, settings, ph[0], n[0], l0, p_t, f1=regions[0].outer)  # the solver's start
    rtol = np.maximum(settings.rtol, ROUNDOFF_TOLERANCE / (l0 / lam - 1))
    atol7 = start_rows(model, settings, l0, ph[0], False)[2][:7]
    for k in range(1, len(regions)):
        atol7 = np.maximum(atol7, start_rows(model, settings, l0, ph[k], False)[2][:7])
    atol = np.vstack([atol7, np.full((2, m), np.inf)])
    radii = np.outer(S, Rs)
    rows = np.full((S.size, 7, m), np.nan)
    near = radii < R0
    for k in range(S.size - 1):
        cols = np.flatnonzero(near[k])
        if cols.size:
            vals = model.series_start(l0[cols], p_t[cols] / n[0], ph[0][cols], radii[k, cols])[:7]
            rows[k][:, cols] = np.vstack([np.broadcast_to(np.asarray(v, dtype=float), (cols.size,)) for v in vals])
    series = model.series_start(l0, p_t / n[0], ph[0], R0)[:7]
    y = np.vstack([np.broadcast_to(np.asarray(v, dtype=float), (m,)) for v in series] + [p_t / n[0], ph[0]])
    t = R0.copy()
    for k in range(1, S.size):
        cols = np.arange(m) if k == S.size - 1 else np.flatnonzero(~near[k])
        if cols.size:
            res = _int.integrate(
                eq.radius, t[cols], y[:, cols], radii[k, cols], rtol[cols], atol[:, cols], settings.max_steps
            )
            bad = (res.status != _int.REACHED_END) | ~np.all(np.isfinite(res.y), axis=0)
            if bad.any():
                j = cols[np.flatnonzero(bad)[0]]
                raise SolverError(
                    f"profile at pole stretch {l0[j]:.6g}, Φ̂ = {phi[j]:.6g}: the re-integration stopped at "
                    f"R̂ = {S[k]:.4g}, before the clamp"
                )
            t[cols], y[:, cols] = res.t, res.y
            rows[k][:, cols] = res.y[:7]
        i = iface.get(float(S[k]))
        if i is not None:  # the stack's meridional force continuous: λ1 jumps, the next region's p̂t/n, Φ̂/n
            l1p, ok = interface_stretch(model, y[0], y[1], ph[i], n[i], ph[i + 1], n[i + 1])
            if not np.all(ok):
                j = int(np.flatnonzero(~ok)[0])
                raise SolverError(
                    f"profile at pole stretch {l0[j]:.6g}, Φ̂ = {phi[j]:.6g}: no meridional stretch carries the "
                    f"force across the interface R̂ = {S[k]:.4g}"
                )
            y[0] = l1p
            y[7] = p_t / n[i + 1]
            y[8] = ph[i + 1]
    ztot = y[6]
    tol = AGREEMENT_FACTOR * rtol
    for name, mine, theirs in (
        ("clamp stretch", y[1], np.full(m, lam)),
        ("apex height", ztot / Rs, np.asarray(st.apex_height, dtype=float)),
        ("volume", QUADRATURE_FACTORS[0] * y[3] / Rs**3, np.asarray(st.v_hat, dtype=float)),
    ):
        off = ~(np.abs(mine - theirs) <= tol * np.maximum(np.abs(theirs), 1e-3))
        if off.any():
            j = int(np.flatnonzero(off)[0])
            raise SolverError(
                f"profile at pole stretch {l0[j]:.6g}, Φ̂ = {phi[j]:.6g}: the re-integrated {name} "
                f"{mine[j]:.12g} differs from the solver's {theirs[j]:.12g}"
            )
    out = []
    for j in range(m):
        R = radii[:, j]
        r_hat = rows[:, 1, j] * R / Rs[j]
        z_hat = (ztot[j] - rows[:, 6, j]) / Rs[j]
        r_hat[0], r_hat[-1], z_hat[-1] = 0.0, lam, 0.0
        if not (np.all(np.isfinite(r_hat)) and np.all(np.isfinite(z_hat))):
            raise SolverError(f"profile at pole stretch {l0[j]:.6g}, Φ̂ = {phi[j]:.6g}: non-finite points")
        out.append((S.copy(), r_hat, z_hat))
    return out


#: the stencil of pole stretches evaluated together around each voltage's predicted state (its spacing, ``λ``)
PATH_STENCIL = 0.01
#: stencils tried per voltage before the search for the branch's state gives up
MAX_STENCILS = 40
#: the first stencil of a voltage samples at most this many pole stretches between the last state and the guess
BRIDGE_SAMPLES = 40
#: a path's end voltage is bisected until the last voltage with a state and the first without lie this close
#: (``Φ̂``; 1e-6 is about 0.02 V for the paper's membranes)
END_TOLERANCE = 1e-6


@dataclass
class ZonePath:
    """The states of one zone held by a gas (or a controlled pressure) along rising voltages.

    Attributes
    ----------
    phi_hat, pole_stretch, p_hat, v_hat : numpy.ndarray
        Per voltage reached (ascending), the state: ``Φ̂``, ``λ0``, ``p̂`` (the gas's pressure at the zone's
        volume, to the solver's tolerance) and ``V̂``.
    residual : numpy.ndarray
        ``p̂zone − p̂gas(V̂)`` of each state (the balance the root-finder reached).
    end_kind : str or None
        Why the states stop before the last voltage asked for: ``"snap-through"`` (the zone–gas equilibrium
        folds, ``dp̂/dV̂ = −c`` of the gas: the zone would jump to another branch), ``"wrinkled"`` (a tension of
        the membrane turns compressive, e.g. the hoop tension at the electrode's edge), ``"pull-in"`` (the pole's
        tension or the meridian's stiffness is lost: the electromechanical instability), or the state's failure
        tag (``"locked"``, ...); None when every voltage has a state.
    end_reason : str or None
        The sentence saying why, with the solver's detail.
    end_phi_hat : tuple of float or None
        ``(Φ̂ with a state, Φ̂ without)`` bracketing the end, bisected to :data:`END_TOLERANCE`.
    """

    phi_hat: np.ndarray
    pole_stretch: np.ndarray
    p_hat: np.ndarray
    v_hat: np.ndarray
    residual: np.ndarray
    end_kind: str | None = None
    end_reason: str | None = None
    end_phi_hat: tuple | None = None


class _NoState(Exception):
    """No state on the continued branch at a voltage (``kind``, ``reason``)."""

    def __init__(self, kind: str, reason: str):
        super().__init__(reason)
        self.kind, self.reason = kind, reason


def _kind_of(status: int) -> str:
    from .shooting import LOST_ELLIPTICITY, PULL_IN, WRINKLED, WRINKLED_AT_POLE, reason_tag

    if status == WRINKLED:
        return "wrinkled"
    if status in (WRINKLED_AT_POLE, LOST_ELLIPTICITY, PULL_IN):
        return "pull-in"
    return reason_tag(status)


class _Balance:
    """``F(λ0) = p̂(λ0, Φ̂) − p̂gas(V̂(λ0, Φ̂))`` of one patterned zone at one voltage, evaluated in batches.

    A pole stretch whose state fails (wrinkles, loses stiffness, locks, ...) has no ``F``: it is kept apart
    (``failed_x``, with the failure as a :class:`_NoState` in ``failures``) and its ``F`` is NaN in the values
    returned; the valid ones are accumulated in ``x, F, p, v``."""

    def __init__(self, model, pattern, source, phi, settings):
        self.model, self.pattern, self.source, self.phi, self.settings = model, pattern, source, phi, settings
        self.x = np.empty(0)
        self.F = np.empty(0)
        self.p = np.empty(0)
        self.v = np.empty(0)
        self.failed_x: list = []
        self.failures: list = []
        self.sigma = None

    def __call__(self, lam):
        from .patterned import solve_patterned_states
        from .shooting import WRINKLED, reason_text

        lam = np.atleast_1d(np.asarray(lam, dtype=float))
        guess = None if self.sigma is None else np.full(lam.size, self.sigma)
        st = solve_patterned_states(self.model, self.pattern, lam, self.phi, self.settings, scale_guess=guess)
        wrinkled = np.flatnonzero(st.status == WRINKLED) if self.model.tension_field else ()
        if len(wrinkled):  # a tension-field membrane goes on hoop-wrinkled: its relaxed states (as the ramp's)
            from .patterned_relaxed import solve_patterned_relaxed

            relaxed = solve_patterned_relaxed(
                self.model,
                self.pattern,
                lam[wrinkled],
                self.phi,
                self.settings,
                scale_guess=None if guess is None else guess[wrinkled],
            )
            _replace_rows(st, wrinkled, relaxed)
        ok = np.asarray(st.ok, dtype=bool)
        for i in np.flatnonzero(~ok):
            detail = st.failure_detail[i]
            self.failed_x.append(float(lam[i]))
            reason = reason_text(st.status[i])
            if detail and detail.startswith(reason):  # the relaxed solver's detail repeats the reason
                detail = detail[len(reason) :].strip(" ()")
            self.failures.append(
                _NoState(
                    _kind_of(int(st.status[i])),
                    f"at Φ̂ = {self.phi:.6g}, pole stretch {lam[i]:.6g}: {reason}" + (f" ({detail})" if detail else ""),
                )
            )
        F = np.full(lam.size, np.nan)
        if ok.any():
            self.sigma = float(np.log(st.clamp_radius[np.flatnonzero(ok)[-1]]))
            F[ok] = st.p_hat[ok] - np.asarray(self.source.pressure(st.v_hat[ok]), dtype=float)
            self.x = np.concatenate([self.x, lam[ok]])
            self.F = np.concatenate([self.F, F[ok]])
            self.p = np.concatenate([self.p, st.p_hat[ok]])
            self.v = np.concatenate([self.v, st.v_hat[ok]])
        return F

    def samples(self):
        """Every pole stretch evaluated, ascending, with its ``F`` (NaN where the state failed)."""
        X = np.concatenate([self.x, np.asarray(self.failed_x, dtype=float)])
        F = np.concatenate([self.F, np.full(len(self.failed_x), np.nan)])
        order = np.argsort(X, kind="stable")
        return X[order], F[order]

    def failure_at(self, x):
        """The failure recorded at the evaluated pole stretch nearest ``x``."""
        i = int(np.argmin(np.abs(np.asarray(self.failed_x) - x)))
        return self.failures[i]


def _rising_pairs(X, F):
    """Indices ``j`` of consecutive samples with ``F[j] < 0 ≤ F[j+1]``, both valid (NaN compares false)."""
    with np.errstate(invalid="ignore"):
        return np.flatnonzero((F[:-1] < 0) & (F[1:] >= 0))


def _gaps_to_failures(X, F):
    """Intervals ``(valid, failed)`` of neighbouring samples where the root lies towards the failure: a valid
    ``F < 0`` followed by a failed state (the root is at larger ``λ0``: ``F`` rises through 0), or a failed state
    followed by a valid ``F ≥ 0`` (the root is at smaller ``λ0``). Returns ``(a, b, failed_end)`` triples."""
    out = []
    valid = np.isfinite(F)
    for i in range(X.size - 1):
        if valid[i] and not valid[i + 1] and F[i] < 0:
            out.append((X[i], X[i + 1], X[i + 1]))
        elif not valid[i] and valid[i + 1] and F[i + 1] >= 0:
            out.append((X[i], X[i + 1], X[i]))
    return out


def _fold_on_the_way(X, F, start, root):
    """The neighbours ``(a, b)`` of a sampled local maximum of ``F`` below 0 strictly between ``start`` and a rising
    ``root`` of the samples, or None (``F`` rises from ``start`` to the root without falling on the way)."""
    lo, hi = min(start, root), max(start, root)
    valid = np.isfinite(F) & (X >= lo) & (X <= hi)
    Xv, Fv = X[valid], F[valid]
    for k in range(1, Xv.size - 1):
        if Fv[k] < 0 and Fv[k] >= Fv[k - 1] and Fv[k] >= Fv[k + 1]:
            return Xv[k - 1], Xv[k + 1]
    return None


def _fold_or_bracket(bal, a, b, phi, samples: int = 7, rounds: int = 12):
    """Look between ``a`` and ``b``, around a sampled maximum of ``F`` below 0, for a value ``F ≥ 0``: batches of
    ``samples`` points, each round narrowed to the two intervals around the largest. Returns the rising bracket
    ``(lo, hi, F(lo), F(hi))`` if one is found; raises :class:`_NoState` ``"snap-through"`` once the bracket
    is ``1e-9 λ0`` narrow with every value below 0 and the parabola through the three largest below 0 too."""
    a0, b0 = a, b
    for _ in range(rounds):
        xs = np.linspace(a, b, samples + 2)[1:-1]
        F = bal(xs)
        if not np.isfinite(F).any():
            raise bal.failure_at(0.5 * (a + b))
        F = np.where(np.isfinite(F), F, -np.inf)
        x_all = bal.x
        order = np.argsort(x_all)
        order = order[(x_all[order] >= a0) & (x_all[order] <= b0)]  # between a and b only: not a far branch's root
        xa, Fa = x_all[order], bal.F[order]
        up = np.flatnonzero((Fa[:-1] < 0) & (Fa[1:] >= 0))
        if up.size:
            j = int(up[0])
            return xa[j], xa[j + 1], Fa[j], Fa[j + 1]
        k = int(np.argmax(F))
        a = xs[k - 1] if k > 0 else a
        b = xs[k + 1] if k < xs.size - 1 else b
        # the parabola through the largest value and its neighbours: an estimate of F's maximum
        i = int(np.argmax(Fa))
        if 0 < i < Fa.size - 1 and np.all(np.diff(xa[i - 1 : i + 2]) > 0):
            x0, x1, x2 = xa[i - 1 : i + 2]
            f0, f1, f2 = Fa[i - 1 : i + 2]
            d = (x1 - x0) * (x1 - x2) * (x0 - x2)
            A2 = (x2 * (f1 - f0) + x1 * (f0 - f2) + x0 * (f2 - f1)) / d
            B2 = (x2 * x2 * (f0 - f1) + x1 * x1 * (f2 - f0) + x0 * x0 * (f1 - f2)) / d
            C2 = (x1 * x2 * (x1 - x2) * f0 + x2 * x0 * (x2 - x0) * f1 + x0 * x1 * (x0 - x1) * f2) / d
            peak = C2 - B2 * B2 / (4 * A2) if A2 < 0 else f1
            xpeak = -B2 / (2 * A2) if A2 < 0 else x1
        else:
            peak, xpeak = float(Fa[i]), float(xa[i])
        noise = 10 * bal.settings.rtol * float(np.max(np.abs(bal.p)))
        if peak < 0 and (b - a <= 1e-9 * b or peak < -noise):
            raise _NoState(
                "snap-through",
                f"at Φ̂ = {phi:.6g} the zone–gas balance p̂ − p̂gas(V̂) has no root on the branch: its largest "
                f"value is {peak:.3g} at pole stretch {xpeak:.6g} (the equilibrium folds where dp̂/dV̂ = −c, the gas "
                "stiffness: the zone snaps through, to another branch if a stable one exists, as `coexist ramp` "
                "finds)",
            )
    raise _NoState(
        "snap-through",
        f"at Φ̂ = {phi:.6g} the zone–gas balance p̂ − p̂gas(V̂) stays below 0 (largest value {float(np.max(bal.F)):.3g}, "
        "within the solver's tolerance of 0): the equilibrium folds here, the zone snaps through",
    )


#: a gap between a valid state short of the balance and a failed one is narrowed until it is this narrow (relative
#: to ``λ0``) before the failure is taken as the branch's end at that voltage
FAILURE_GAP = 1e-9
#: a root farther than this many stencil steps from the prediction is not taken at once (:func:`_branch_root`)
FAR_ROOT = 5


def _branch_root(model, pattern, source, phi, guess, lam_floor, settings, h=PATH_STENCIL, last=None, final=False):
    """The state at ``Φ̂`` on the branch through ``guess``: the root of ``F`` where it rises through 0 nearest
    ``guess``. Stencils of six pole stretches ``h`` apart are evaluated from ``guess`` until the samples hold a
    rising sign change between two valid states; a maximum of ``F`` below 0 among them is looked at closely
    (:func:`_fold_or_bracket`: the fold, :class:`_NoState` ``"snap-through"``). A pole stretch whose state
    fails does not end the search: when the root lies towards a failed sample (a valid ``F < 0`` below it, or
    a valid ``F ≥ 0`` above it) the gap between them is sampled until it holds the sign change, or until it is
    :data:`FAILURE_GAP` narrow — then the state fails before the balance is met, and that failure is raised.
    The bracket is then polished by safeguarded secant steps (three points a step) until
    ``|F| ≤ rtol (p̂ + c V̂)`` (``c`` the gas stiffness: the accuracy both terms carry) or the bracket is
    ``1e-13 λ0`` wide. With ``last``, the pole stretch of the previous voltage's state, the first stencil also
    samples the pole stretches between it and ``guess`` (at most ``h`` apart, up to :data:`BRIDGE_SAMPLES`): a
    prediction that overshoots a fold then still sees the fold's maximum of ``F`` below 0 instead of walking on
    to the root of another branch. Returns ``(λ0, p̂, V̂, F)``."""
    bal = _Balance(model, pattern, source, phi, settings)
    centre = guess
    for attempt in range(MAX_STENCILS + 60):
        xs = centre + h * np.arange(-2, 4)
        if attempt == 0 and last is not None:
            # the previous state's pole stretch and one beside it too: a fold's maximum of F just past it is then
            # an interior sample (_fold_on_the_way)
            bridge = np.linspace(last, guess, min(BRIDGE_SAMPLES, int(abs(guess - last) / h) + 2))
            side = last - h if guess >= last else last + h
            xs = unique_sorted(np.r_[side, bridge[:-1], xs])
        xs = xs[xs > lam_floor]
        if xs.size < 2:
            raise _NoState("no-state", f"at Φ̂ = {phi:.6g} the branch reaches the flat membrane")
        bal(xs)
        X, F = bal.samples()
        up = _rising_pairs(X, F)
        if up.size:
            j = int(up[np.argmin(np.abs(X[up] - guess))])
            if last is not None and abs(X[j] - guess) > FAR_ROOT * h:
                # a root far from the prediction: the branch moved fast, or it folded and this is another branch's
                # root. One voltage's balance cannot tell on a long step (a dip below 0 on the way is a fold, or a
                # wiggle the root has moved past: review, helper-75): the caller halves the step (zone_path)
                if not final:
                    raise _NoState("far-root", f"at Φ̂ = {phi:.6g} the nearest root lies far from the prediction")
                # the smallest step: the branch folded if the balance has a maximum below 0 from the last state on
                # (it falls past the vanished root before it rises to the far one); if it rises all the way, the
                # root is the branch's own, moving fast (a zone on a large chamber, nearly at its fold: review,
                # helper-75)
                back = last - h if X[j] > last else last + h
                fold = _fold_on_the_way(X, F, back, X[j])
                if fold is not None:
                    lo, hi, Flo, Fhi = _fold_or_bracket(bal, fold[0], fold[1], phi)
                    break
            lo, hi, Flo, Fhi = X[j], X[j + 1], F[j], F[j + 1]
            break
        valid = np.isfinite(F)
        if not valid.any():
            raise bal.failure_at(guess)
        gaps = _gaps_to_failures(X, F)
        if gaps:
            ga, gb, failed = min(gaps, key=lambda g: min(abs(g[0] - guess), abs(g[1] - guess)))
            while True:  # narrow the gap: sign change, or the failure next to a state short of the balance
                if gb - ga <= FAILURE_GAP * gb:
                    raise bal.failure_at(failed)
                bal(np.linspace(ga, gb, 7)[1:-1])
                X, F = bal.samples()
                up = _rising_pairs(X, F)
                inside = (X[up] >= ga) & (X[up + 1] <= gb)
                if inside.any():
                    j = int(up[inside][0])
                    break
                sub = [g for g in _gaps_to_failures(X, F) if g[0] >= ga and g[1] <= gb]
                if not sub:  # the gap holds valid states only, none crossing: look again around them
                    j = -1
                    break
                ga, gb, failed = min(sub, key=lambda g: min(abs(g[0] - guess), abs(g[1] - guess)))
            if j >= 0:
                lo, hi, Flo, Fhi = X[j], X[j + 1], F[j], F[j + 1]
                break
            continue
        Xv, Fv = X[valid], F[valid]
        k = int(np.argmax(Fv))
        if Fv[k] < 0 and 0 < k < Xv.size - 1:
            lo, hi, Flo, Fhi = _fold_or_bracket(bal, Xv[k - 1], Xv[k + 1], phi)
            break
        centre = Xv[0] - 4 * h if Fv[0] >= 0 else Xv[-1] + 3 * h
    else:
        raise _NoState(
            "no-state",
            f"at Φ̂ = {phi:.6g} no rising root within {MAX_STENCILS * 6 * h:g} in pole stretch of {guess:.6g}",
        )
    tol_x = 1e-13 * hi
    for _ in range(60):
        # Illinois-safeguarded secant, three points at once: the estimate and two neighbours
        x = hi - Fhi * (hi - lo) / (Fhi - Flo)
        x = min(max(x, lo + 0.01 * (hi - lo)), hi - 0.01 * (hi - lo))
        eps = max(1e-4 * (hi - lo), tol_x)
        pts = unique_sorted(np.clip([x - eps, x, x + eps], lo + tol_x / 4, hi - tol_x / 4))
        if not np.isfinite(bal(pts)).all():  # a failed state between two valid ones: the branch breaks there
            raise bal.failure_at(float(x))
        order = np.argsort(bal.x)
        X, Fa = bal.x[order], bal.F[order]
        inside = (X >= lo) & (X <= hi)
        X, Fa = X[inside], Fa[inside]
        j = int(np.flatnonzero((Fa[:-1] < 0) & (Fa[1:] >= 0))[0])
        lo, hi, Flo, Fhi = X[j], X[j + 1], Fa[j], Fa[j + 1]
        i = int(np.argmin(np.abs(bal.F)))
        accuracy = settings.rtol * (abs(bal.p[i]) + float(source.stiffness(bal.v[i])) * bal.v[i])
        if hi - lo <= tol_x or abs(bal.F[i]) <= accuracy:
            break
    i = int(np.argmin(np.abs(bal.F)))
    accuracy = settings.rtol * (abs(bal.p[i]) + float(source.stiffness(bal.v[i])) * bal.v[i])
    if not abs(bal.F[i]) <= JUMP_RESIDUAL * accuracy:
        # the bracket closed on a jump of F, not a root: the states are not continuous there (a tension-field ring
        # past its pull-in: relaxed states 5x the volume of the taut ones beside them; F −2e-3 -> 13, and the state
        # 2.3 % off the gas's pressure had been reported; review, helper-83)
        raise _NoState(
            "wrinkling_pull_in" if model.tension_field else "no-state",
            f"at Φ̂ = {phi:.6g} the balance jumps across zero between pole stretches {lo:.10g} and {hi:.10g} "
            f"(F {Flo:.3g} -> {Fhi:.3g}, volume {_volume_near(bal, lo):.4g} -> {_volume_near(bal, hi):.4g}): the "
            "states are not continuous there and none continues the branch",
        )
    return float(bal.x[i]), float(bal.p[i]), float(bal.v[i]), float(bal.F[i])


#: a polished root whose ``|F|`` exceeds this many times the accuracy of ``F`` is a jump of the balance, not a root
JUMP_RESIDUAL = 1e3


def _volume_near(bal, x: float) -> float:
    """The volume of the evaluated state nearest ``x`` (for a message)."""
    return float(bal.v[int(np.argmin(np.abs(bal.x - x)))]) if bal.x.size else float("nan")


def zone_path(
    model: MembraneModel, pattern, source, phi_hat, start_stretch: float, settings=None, start_phi_hat=None
) -> ZonePath:
    """The states of one patterned zone on ``source`` (a gas chamber or a controlled pressure) at rising voltages,
    continued from the state at ``start_stretch``.

    At every voltage the state is the root of the balance ``F(λ0) = p̂(λ0, Φ̂) − p̂gas(V̂(λ0, Φ̂))`` (each
    evaluation a converged :func:`coexist.patterned.solve_patterned_states`; the patterned zones have no
    derivatives yet, so the root is bracketed by a stencil of pole stretches around the previous voltage's
    state, extrapolated, and polished by safeguarded secant steps until ``|F| ≤ rtol p̂`` or the bracket is
    ``1e-13 λ0`` wide). The branch is the one continued from the start: the root where ``F`` rises through 0
    nearest the prediction; a pole stretch near it whose state fails does not end the branch (the search narrows
    the gap to the failure, :func:`_branch_root`). A voltage whose state is not found from the last state is
    approached in halved steps from the last voltage with a state (states in between are not reported), each
    continued from the nearest state below; the states stop where a step of :data:`END_TOLERANCE` still finds
    none on the branch: a fold (``F``'s maximum below 0: snap-through), or a state that fails before the balance
    is met (wrinkling, pull-in, locking).

    Parameters
    ----------
    model : MembraneModel
        The one-layer membrane.
    pattern : ZonePattern
        The zone's regions.
    source : GasChamber or PressureReservoir
        What holds the pressure: ``source.pressure(V̂)`` (one zone).
    phi_hat : array_like
        Voltages ``Φ̂ ≥ 0``, ascending.
    start_stretch : float
        ``λ0`` of the state at the first voltage, or near it; with ``start_phi_hat``, of the converged state at
        that voltage.
    settings : SolverSettings, optional
    start_phi_hat : float, optional
        The voltage of the start state (at most the first of ``phi_hat``): the path then steps up from it
        (halving a step that finds no state) instead of starting at the first voltage asked for.

    Returns
    -------
    ZonePath
        The states reached and, where they stop early, why and where.
    """
    settings = validation.settings_or_default(settings)
    phis = np.asarray(validation.real_array(phi_hat, "phi_hat", lo=0.0), dtype=float).ravel()
    if phis.size == 0 or np.any(np.diff(phis) < 0):
        raise SceneError("must be a non-empty ascending sequence", "phi_hat")
    floor = model.prestretch * (1 + 1e-3)
    rows: list = []
    end: tuple | None = None
    lam_prev = [float(start_stretch)]
    phi_prev: list = []

    def predict(phi):
        if len(phi_prev) >= 2 and phi_prev[-1] != phi_prev[-2]:
            slope = (lam_prev[-1] - lam_prev[-2]) / (phi_prev[-1] - phi_prev[-2])
            return lam_prev[-1] + slope * (phi - phi_prev[-1])
        return lam_prev[-1]

    phi_ok = None  # the last voltage with a state (asked for, or an intermediate step)
    if start_phi_hat is not None:
        phi_ok = validation.real(start_phi_hat, "start_phi_hat", lo=0.0, hi=float(phis[0]))
        phi_prev.append(phi_ok)
    for phi in phis:
        target = float(phi)
        tried: tuple | None = None  # the last voltage that failed, with its failure
        bad: tuple | None = None  # a voltage that failed again from a closer state: no state there, not tried again
        while True:  # from the last state towards ``phi``: a failed step is halved, down to END_TOLERANCE
            if bad is not None and phi_ok is not None and bad[0] - phi_ok <= END_TOLERANCE:
                # the voltage that failed twice from states further down is tried once more from the state next to
                # it: only a step of END_TOLERANCE decides that the branch ends there (a fold seen from far below
                # may be a dip of the balance the branch passes round: a 3000 ml chamber, review of 2026-12-02)
                target, bad = bad[0], None
            guess = predict(target)
            last = None if phi_ok is None else lam_prev[-1]
            try:
                final = phi_ok is not None and target - phi_ok <= END_TOLERANCE
                lam, p, v, F = _branch_root(
                    model, pattern, source, target, guess, floor, settings, last=last, final=final
                )
            except _NoState as failure:
                if phi_ok is None or target - phi_ok <= END_TOLERANCE:
                    end = (target, failure)
                    break
                if failure.kind != "far-root":  # a property of the step, not of the voltage: never "no state there"
                    if tried is not None and tried[0] == target:
                        bad = (target, failure)
                    tried = (target, failure)
                target = 0.5 * (phi_ok + target)
                continue
            step = target - (phi_ok if phi_ok is not None else target)
            lam_prev.append(lam)
            phi_prev.append(target)
            phi_ok = target
            if target == float(phi):
                rows.append((target, lam, p, v, F))
                break
            # grow the step again from the closer state; towards a voltage that failed twice, bisect instead
            target = min(float(phi), target + 2 * step)
            if bad is not None and target >= bad[0]:
                target = 0.5 * (phi_ok + bad[0])
        if end is not None:
            break
    arr = np.array(rows, dtype=float).reshape(-1, 5)
    path = ZonePath(arr[:, 0].copy(), arr[:, 1].copy(), arr[:, 2].copy(), arr[:, 3].copy(), arr[:, 4].copy())
    if end is None:
        return path
    phi_bad, stop = end
    path.end_kind, path.end_reason = stop.kind, stop.reason
    path.end_phi_hat = None if phi_ok is None else (phi_ok, phi_bad)
    return path


def scene_zone_path(scene, phi_hat, settings: SolverSettings | None = None) -> tuple:
    """The states of a one-zone scene (patterned or not) on its gas, or at its controlled pressure, at rising
    voltages: :func:`zone_path` from the state the valves closed in.

    The closing state is the zone at the closing (or controlled) pressure at 0 V on the rising branch of its
    ``p̂–V̂`` curve: a scan of pole stretches up to its first pressure maximum (:func:`coexist.simulation.snap_through`;
    a pressure at or above it is refused, as by :class:`coexist.simulation.Simulation`), or up to
    :func:`coexist.simulation.pole_stretch_max` for a curve without one, the first rising crossing, polished as every
    state of the path. The chamber's gas is closed there
    (:meth:`coexist.effects.GasChamber.closed_at`).

    Parameters
    ----------
    scene : Scene
        One zone (``[zones] count = 1``), a chamber or a controlled pressure.
    phi_hat : array_like
        Ascending voltages ``Φ̂``.
    settings : SolverSettings, optional

    Returns
    -------
    path : ZonePath
    source : GasChamber or PressureReservoir
        What holds the zone's pressure.

    Raises
    ------
    SceneError
        If the scene has more than one zone (``[zones].count``: zones on one gas need the patterned states'
        derivatives), neither a chamber nor a controlled pressure, or a pressure the zone cannot hold at 0 V
        (naming the field).
    """
    from .effects import GasChamber, PressureReservoir
    from .patterned import solve_patterned_states
    from .simulation import closing_pressure, pole_stretch_max, snap_through, zone_model

    settings = validation.settings_or_default(settings)
    validation.scene(scene)
    if scene.zone_count != 1:
        raise SceneError(
            f"the states along the voltage are computed for one zone so far, the scene has {scene.zone_count} (zones "
            "on one gas share its pressure and may split, which needs the patterned states' derivatives)",
            "[zones].count",
        )
    if scene.chamber is None and scene.controlled_pressure is None:
        raise SceneError(
            "this computation needs a [chamber] or a controlled pressure [zones].pressure_mbar", "[chamber]"
        )
    model, pattern = scene.model(), scene.zone_pattern()
    pre, top = model.prestretch, pole_stretch_max(scene, settings)
    # the zone is closed in on the rising branch before its first pressure maximum, and a pressure at or above that
    # maximum is refused, as `coexist ramp` and `coexist check` do: a first rising crossing on the stiffened branch
    # beyond it was taken (review, helper-76: inner fraction 0.7 at 16 mbar, p̂max 2.092)
    snap = snap_through(zone_model(scene), settings, top)
    p_close, field_name = closing_pressure(scene, snap)
    if snap.maximum:
        top = snap.pole_stretch
    grid = pre * (1 + np.linspace(np.sqrt(2e-3), np.sqrt(top / pre - 1), 24) ** 2)
    st = solve_patterned_states(model, pattern, grid, 0.0, settings)
    F = np.where(st.ok, st.p_hat - p_close, np.nan)
    rising = np.flatnonzero((F[:-1] < 0) & (F[1:] >= 0))
    peak = float(np.nanmax(np.where(st.ok, st.p_hat, np.nan)))
    if rising.size == 0 and st.ok.any() and bool(np.all(F[st.ok] > 0)):
        # every state lies above it: not a pressure too high, one below the states computed (as `coexist check` says)
        low = float(np.min(st.p_hat[st.ok]))
        raise SceneError(f"p̂ = {p_close:.6g} is below the smallest computed state (p̂ = {low:.3g})", field_name)
    if rising.size == 0:
        raise SceneError(
            f"the zone cannot hold p̂ = {p_close:.4g} ({scene.pressure(p_close) / 100:.4g} mbar) at 0 V: its largest "
            f"pressure is p̂ = {peak:.4g}",
            field_name,
        )
    a, b = grid[rising[0]], grid[rising[0] + 1]
    guess = a + (b - a) * (-F[rising[0]]) / (F[rising[0] + 1] - F[rising[0]])
    try:
        lam_c = _branch_root(model, pattern, PressureReservoir(p_close), 0.0, guess, pre * (1 + 1e-3), settings)[0]
    except _NoState as exc:
        raise SceneError(f"no state at the closing pressure at 0 V: {exc.reason}", field_name) from None
    if scene.chamber is not None:
        v_c = float(solve_patterned_states(model, pattern, [lam_c], 0.0, settings).v_hat[0])
        source = GasChamber.closed_at(
            float(scene.chamber_volume_hat), float(scene.atmospheric_pressure_hat), p_close, v_c
        )
    else:
        source = PressureReservoir(p_close)
    return zone_path(model, pattern, source, phi_hat, lam_c, settings, start_phi_hat=0.0), source


def lens_ratio(profile: Profile) -> float:
    """How far the centre bulges ahead of the ring: ``κ0 / κring``, the apex curvature over the curvature of the
    sphere (centred on the axis) through the electrode edge and the clamp.

    That sphere's centre is at height ``zc = (re² + ze² − a²)/(2 ze)`` (``(re, ze)`` the electrode edge, ``a = λpre
    A`` the clamp radius), so ``κring = 1/√(a² + zc²)``. A spherical cap has the ratio 1; a centre that bulges
    ahead of the passive ring, more than 1.

    Parameters
    ----------
    profile : Profile
        A state with its electrode edge inside the zone (``electrode_edge_R_hat < 1``).

    Returns
    -------
    float
        ``κ0/κring``.

    Raises
    ------
    SceneError
        If the electrode edge is the clamp or lies in the clamp plane (no ring to compare with).
    """
    re, ze = profile.electrode_edge_hat
    a = profile.prestretch
    if not (profile.electrode_edge_R_hat < 1 and ze > 0):
        raise SceneError("the electrode edge is at the clamp: there is no passive ring to compare with", "profile")
    zc = (re * re + ze * ze - a * a) / (2 * ze)
    return float(profile.apex_curvature_hat * math.sqrt(a * a + zc * zc))
