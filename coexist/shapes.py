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
  does. The points are equally spaced in the reference radius ``R̂`` (material points).
- the **apex height** ``h``: :attr:`MembraneStates.apex_height` of the converged state;
- the **apex curvature** ``κ0``, exact at the pole from the Laplace law of the equibiaxial pole
  (docs/physics.md, section 11): ``κ0 A = p̂ λ0 / (2 T̂0)``, ``T̂0 = T̂1(λ0, λ0; Φ̂)`` — never fitted to points;
- the **electrode edge**: where the electrode ends on the deformed membrane. A uniform electrode covers
  the whole zone, so its edge is the clamp, ``R̂ = 1``: ``(r, z) = (λpre A, 0)``. The field is there so
  that patterned electrodes can fill it with an interior point later.

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
from .settings import SolverSettings
from .shooting import ROUNDOFF_TOLERANCE, _integrators, solve_states, trial_pressure

#: the re-integrated state must agree with the shooting's (clamp radius, apex height, volume) to this many
#: of its relative tolerances; beyond it something is wrong and the profile is refused
AGREEMENT_FACTOR = 1e4
#: fewest points of a profile (the pole, one interior point, the clamp)
MIN_POINTS = 3


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
        Reference radius of the electrode's edge (1: a uniform electrode, whose edge is the clamp).
    electrode_edge_hat : tuple of float
        ``(r/A, z/A)`` of the electrode's edge on the deformed membrane.
    wrinkled_radii : tuple of (float, float)
        Hoop-wrinkled intervals ``(R̂start, R̂end)`` of a tension-field state (empty when taut). The points of
        a wrinkled state are not computed yet (``R_hat``, ``r_hat``, ``z_hat`` are then empty): only its apex
        numbers, which hold as they are (the pole is always taut, docs/physics.md section 10).
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
            (None for the flat membrane), ``electrode_edge_mm`` (``[r, z]``), ``wrinkled_radii`` (the
            hoop-wrinkled ``[R̂start, R̂end]`` intervals, empty when taut) and, with ``points``, ``profile``
            (None for a wrinkled state, whose points are not computed yet).
        """
        roc = self.radius_of_curvature
        out: dict = {
            "pole_stretch": float(self.pole_stretch),
            "apex_height_mm": float(self.apex_height * 1e3),
            "apex_curvature_per_m": float(self.apex_curvature),
            "radius_of_curvature_mm": None if math.isinf(roc) else float(roc * 1e3),
            "electrode_edge_mm": [float(x * 1e3) for x in self.electrode_edge],
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
    wrinkled: str = "raise",
) -> list[Profile]:
    """The profiles of many states of one zone (:class:`Profile`), integrated together.

    Each state is first shot (:func:`~coexist.shooting.solve_states`, which checks it: a wrinkled,
    locked or unreachable state raises); then its meridian is integrated again from the pole with the
    same trial pressure ``p̂t``, series start and tolerances, stopping at the radii ``R̂ = k/(points − 1)``
    of the unit membrane (``R = R̂ R*`` of the trial integration; below the series radius the series
    itself), the last step onto the clamp ``λ2 = λpre`` with ``λ2`` as the independent variable. With the
    clamp radius ``R*`` so found: ``R̂ = R/R*``, ``r̂ = λ2 R/R*``, ``ẑ = (z(R*) − z(R))/R*``.

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
    wrinkled : {"raise", "numbers"}
        What a hoop-wrinkled state of a tension-field model gives: :class:`ModelRangeError` (its profile
        through the wrinkled ring is not computed yet), or a :class:`Profile` with its apex numbers, its
        wrinkled intervals and no points.

    Returns
    -------
    list of Profile
        One per state, in the order given.

    Raises
    ------
    SceneError
        If an input is out of range (names it).
    ModelRangeError
        If a state does not exist (wrinkling, locking, no clamp; :meth:`MembraneStates.require_ok`), the
        flat membrane is not taut at that voltage, or (``wrinkled="raise"``) a state is hoop-wrinkled.
    SolverError
        If the re-integration does not reach the clamp or disagrees with the shooting.
    """
    settings = validation.settings_or_default(settings)
    validation.membrane_model(model)
    A = validation.real(zone_radius, "zone_radius", lo=0.0, lo_open=True)
    if isinstance(points, bool) or not isinstance(points, (int, np.integer)) or points < MIN_POINTS:
        raise SceneError(f"must be an integer of at least {MIN_POINTS}, got {points!r}", "points")
    if wrinkled not in ("raise", "numbers"):
        raise SceneError(f"must be 'raise' or 'numbers', got {wrinkled!r}", "wrinkled")
    l0, phi = validation.broadcastable(
        "pole_stretch, phi_hat",
        validation.real_array(pole_stretch, "pole_stretch"),
        validation.real_array(phi_hat, "phi_hat", lo=0.0),
    )
    l0 = np.array(l0, dtype=float).ravel()
    phi = np.array(phi, dtype=float).ravel()
    n = l0.size
    s = np.linspace(0.0, 1.0, int(points))
    out: list[Profile | None] = [None] * n
    flat = l0 == model.prestretch
    for i in np.flatnonzero(flat):
        out[i] = _flat(model, float(phi[i]), A, s)
    live = np.flatnonzero(~flat)
    if live.size:
        for i, prof in zip(live, _integrate(model, l0[live], phi[live], A, s, settings, wrinkled == "raise")):
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


def _integrate(model, l0, phi, A, s, settings, refuse_wrinkled: bool) -> list[Profile]:
    """The profiles of the inflated states ``(l0, phi)`` (module docstring, :func:`profiles`)."""
    st = solve_states(model, l0, phi, settings).require_ok()
    kappa = np.atleast_1d(apex_curvature_hat(model, l0, phi, st.p_hat))
    # a tension-field model's hoop-wrinkled states (coexist.wrinkling): their apex numbers hold (the pole is
    # taut), their meridian through the wrinkled ring is not integrated here yet
    rings = getattr(st, "wrinkled_radii", None) or [[] for _ in range(l0.size)]
    wrinkled = np.array([len(w) > 0 for w in rings], dtype=bool)
    if refuse_wrinkled and wrinkled.any():
        j = int(np.flatnonzero(wrinkled)[0])
        raise ModelRangeError(
            f"the state at pole stretch {l0[j]:.6g}, Φ̂ = {phi[j]:.6g} is hoop-wrinkled (R̂ in "
            f"{', '.join(f'[{a:.4g}, {b:.4g}]' for a, b in rings[j])}): its profile is not computed yet; "
            "profiles(..., wrinkled='numbers') gives its apex numbers",
            "wrinkling",
        )
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
    taut = np.flatnonzero(~wrinkled)
    if taut.size:
        sub = st if taut.size == l0.size else _take(st, taut)
        for jj, pts in zip(taut, _points(model, l0[taut], phi[taut], s, settings, sub)):
            result[jj].R_hat, result[jj].r_hat, result[jj].z_hat = pts
    return result


def _take(st, idx):
    """The fields of ``st`` this module reads, at the states ``idx``."""
    from types import SimpleNamespace

    return SimpleNamespace(**{k: getattr(st, k)[idx] for k in ("clamp_radius", "apex_height", "v_hat")})


def _points(model, l0, phi, s, settings, st) -> list:
    """``(R̂, r̂, ẑ)`` at the output radii ``s`` of the taut states ``(l0, phi)`` shot as ``st``."""
    m = l0.size
    lam = model.prestretch
    eq = _integrators(model)
    pt = np.asarray(trial_pressure(model, l0, phi), dtype=float) * np.ones(m)
    R0 = settings.series_radius
    # the shooting's start and tolerances: series at R0 (and at R̂ = 1 for the size of every row)
    series = np.broadcast_arrays(
        *model.series_start(np.tile(l0, 2), np.tile(pt, 2), np.tile(phi, 2), np.repeat([R0, 1.0], m)),
        np.empty(2 * m),
    )[:-1]
    start = np.vstack([x[:m] for x in series[:7]])
    unit = [x[m:] for x in series[:7]]
    ones = np.ones(m)
    size = np.vstack([ones, ones] + [np.abs(unit[i]) for i in range(2, 7)] + [ones, ones])
    atol = settings.atol * np.maximum(size, 1e-30)
    rtol = np.maximum(settings.rtol, ROUNDOFF_TOLERANCE / (l0 / lam - 1))
    Rs_shot = st.clamp_radius
    k_last = s.size - 1
    rows = np.full((s.size, 7, m), np.nan)  # the state at every output radius (trial units)
    radii = np.outer(s, Rs_shot)
    # below the series radius: the series itself (the pole is its R = 0)
    near = radii < R0
    for k in range(k_last):
        cols = np.flatnonzero(near[k])
        if cols.size:
            vals = model.series_start(l0[cols], pt[cols], phi[cols], radii[k, cols])[:7]
            rows[k][:, cols] = np.vstack([np.broadcast_to(np.asarray(v, dtype=float), (cols.size,)) for v in vals])
    t = np.full(m, R0)
    y = np.vstack([start, pt, phi])
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
    # the same state as the shooting's, to its tolerance, or nothing
    tol = AGREEMENT_FACTOR * rtol
    for name, mine, theirs in (
        ("clamp radius", Rs, Rs_shot),
        ("apex height", apex, st.apex_height),
        ("volume", v_hat, st.v_hat),
    ):
        off = np.abs(mine - theirs) > tol * np.maximum(np.abs(theirs), 1e-3)
        if off.any():
            j = int(np.flatnonzero(off)[0])
            raise SolverError(
                f"profile at pole stretch {l0[j]:.6g}, Φ̂ = {phi[j]:.6g}: the re-integrated {name} "
                f"{mine[j]:.12g} differs from the shooting's {theirs[j]:.12g}"
            )
    out = []
    for j in range(m):
        R = radii[:, j]
        r_hat = rows[:, 1, j] * R / Rs[j]
        z_hat = (ztot[j] - rows[:, 6, j]) / Rs[j]
        r_hat[0], z_hat[-1] = 0.0, 0.0
        if not (np.all(np.isfinite(r_hat)) and np.all(np.isfinite(z_hat))):
            raise SolverError(f"profile at pole stretch {l0[j]:.6g}, Φ̂ = {phi[j]:.6g}: non-finite points")
        out.append((R / Rs[j], r_hat, z_hat))
    return out


def equilibrium_profiles(model: MembraneModel, eq, zone_radius: float, points: int = 201, settings=None) -> list:
    """The profile of every group of identical zones of an equilibrium (a hoop-wrinkled group: its apex numbers,
    no points; :func:`profiles` with ``wrinkled="numbers"``).

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
    profs = profiles(
        model, lam, float(eq.phi_hat), zone_radius=zone_radius, points=points, settings=settings, wrinkled="numbers"
    )
    return list(zip((int(c) for c in eq.configuration.counts), profs))
