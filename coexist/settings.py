"""Numerical settings, in one place, passed down to every solver.

The command line's ``--rtol`` / ``--accuracy`` options map onto :class:`SolverSettings`.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

from .errors import SceneError

#: Named accuracy levels offered by every command (``--accuracy``); values are relative tolerances.
ACCURACY_LEVELS = {"draft": 1e-6, "default": 1e-10, "high": 1e-12}


@dataclass(frozen=True)
class SolverSettings:
    """Tolerances and limits of the shooting integrator and the solvers built on it.

    Parameters
    ----------
    rtol : float
        Relative tolerance of the adaptive 8th-order Runge-Kutta (DOP853) integration of the
        membrane equations. The shooting result (``p̂``, ``V̂``, ``Q̂``, ``Ψ̂``) carries a relative
        error of about ``rtol`` (see ``coexist accuracy``).
    atol_factor : float
        Absolute tolerance as a multiple of ``rtol`` (states are of order one after scaling).
    pole_radius : float or None
        Radius ``R0/R*`` at which the series start at the pole hands over to the integrator; the
        series is accurate to ``O(R0^4)``. ``None`` (default): ``R0 = min(1e-3, 0.1 rtol^¼)``, so
        the truncation stays below the tolerance while the first steps are not wasted on the pole.
    max_steps : int
        Largest number of integration steps per trajectory before it is declared failed.
    max_radius_factor : float
        A trajectory that has not returned to the clamp stretch by ``R = max_radius_factor``
        (in units of the estimated clamp radius) has no equilibrium at that pole stretch.
    limit_point_xtol : float
        Tolerance on the pole stretch when a pressure or voltage extremum is located.
    sensitivity_error_control : bool
        Whether the variational equations (exact derivatives of a state to ``λ0`` and ``Φ̂``) take part
        in the integrator's step-size control. Off (default): they are integrated on the steps the
        states choose, which makes them the exact derivatives of the discrete solution; measured
        against ``rtol = 1e-13``, they then carry the relative error of the states themselves (see
        ``tests/test_sensitivities.py``) at half the cost.
    error_estimates : bool
        Measure the error of every transition voltage by locating it again at ``rtol/100`` (at least
        1e-13); off, a transition carries only its location bracket.
    """

    rtol: float = 1e-10
    atol_factor: float = 1e-2
    pole_radius: float | None = None
    max_steps: int = 4000
    max_radius_factor: float = 1000.0
    limit_point_xtol: float = 1e-9
    sensitivity_error_control: bool = False
    error_estimates: bool = True

    def __post_init__(self):
        if not (1e-14 <= self.rtol <= 1e-2):
            raise SceneError(f"relative tolerance must lie in [1e-14, 1e-2], got {self.rtol!r}", "rtol")
        if self.max_steps < 10:
            raise SceneError(f"max_steps must be at least 10, got {self.max_steps!r}", "max_steps")

    @property
    def series_radius(self) -> float:
        """The pole radius in use (see ``pole_radius``)."""
        if self.pole_radius is not None:
            return float(self.pole_radius)
        return min(1e-3, 0.1 * self.rtol**0.25)

    @property
    def atol(self) -> float:
        """Absolute tolerance ``atol_factor * rtol``."""
        return self.atol_factor * self.rtol

    def with_rtol(self, rtol: float) -> SolverSettings:
        """A copy with another relative tolerance."""
        return replace(self, rtol=float(rtol))

    @classmethod
    def from_accuracy(cls, accuracy: str | float | None) -> SolverSettings:
        """Settings for a named accuracy level (``draft``, ``default``, ``high``) or a tolerance."""
        if accuracy is None:
            return cls()
        if isinstance(accuracy, str):
            key = accuracy.strip().lower()
            if key in ACCURACY_LEVELS:
                return cls(rtol=ACCURACY_LEVELS[key])
            try:
                return cls(rtol=float(key))
            except ValueError:
                names = ", ".join(ACCURACY_LEVELS)
                raise SceneError(
                    f"unknown accuracy {accuracy!r}; use one of {names} or a tolerance like 1e-8",
                    "accuracy",
                ) from None
        return cls(rtol=float(accuracy))
