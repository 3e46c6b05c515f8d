"""Physical effects a scene is simulated with: one class each, "off" included.

A membrane model is assembled from one elasticity effect and one electrostatics effect, each behind its
Protocol (:class:`Elasticity`, :class:`Electrostatics`); each contributes its own symbolic terms to
the free energy at fixed voltage. What holds the zones' pressure is an effect too, behind
:class:`PressureSource`: the gas of a closed chamber (:class:`GasChamber`) or a pressure reservoir
(:class:`PressureReservoir`); and a breakdown field, when a scene gives one, is the effect
:class:`Breakdown` (an event that ends a path). A scene lists exactly the effects it builds
(:meth:`coexist.scene.Scene.effects`); CasADi is imported only when a model is built from them.

"Off" is an effect too (:class:`NoElectrostatics`): its terms are the constant zero, which CasADi folds
away, so the equations of a model without voltage contain no trace of the field (``tests/test_model.py``
checks it symbolically) and the assembler has no branch.
Elasticity is written as a function of ``I = λ1² + λ2² + λ1⁻²λ2⁻² − 3`` and electrostatics of
``K = λ1²λ2²`` (both models of the project are of this form), which lets the model differentiate
through the invariants. All energies are per unit reference volume and normalised by the shear
modulus ``μ``; the voltage enters as ``Φ̂ = (Φ/H)√(ε/μ)``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Protocol

import numpy as np

from .errors import SceneError


def _symbolic_zero():
    """The constant zero as a CasADi expression (CasADi is imported where a model is built, not before)."""
    import casadi as ca

    return ca.SX(0.0)


def first_invariant(l1, l2):
    """``I1 - 3 = λ1² + λ2² + λ1⁻²λ2⁻² - 3`` of an incompressible membrane (zero when unstretched).

    Evaluated without cancellation: with ``x = λ² − 1 = (λ − 1)(λ + 1)`` (exact for ``λ`` near 1)
    and ``J = (1 + x1)(1 + x2) = λ1²λ2²``,
    ``I1 − 3 = [(x1 + x2)² + x1 x2 (x1 + x2 − 1)] / J``, which is ``x1² + x1x2 + x2²`` to leading
    order: a barely inflated membrane (``I1 − 3 ~ δ²``) keeps its digits, where the textbook form
    loses them to the cancellation of its ``O(δ)`` terms.
    """
    x1 = (l1 - 1) * (l1 + 1)
    x2 = (l2 - 1) * (l2 + 1)
    s = x1 + x2
    return (s * s + x1 * x2 * (s - 1)) / ((1 + x1) * (1 + x2))


def first_invariant_derivatives(l1, l2):
    """Half the derivatives of ``I = λ1² + λ2² + λ1⁻²λ2⁻² − 3``, in closed form:
    ``(∂I/∂λ1, ∂I/∂λ2, ∂²I/∂λ1², ∂²I/∂λ1∂λ2) / 2``.

    With ``a = λ1⁻²λ2⁻²``: ``I_1/2 = λ1 − a/λ1``, ``I_11/2 = 1 + 3a/λ1²``, ``I_12/2 = 2a/(λ1λ2)``.
    Written out (rather than left to automatic differentiation), and halved so that the factor 2
    meets the energy's derivative as a constant, because the generated code is then about a third
    shorter; ``tests/test_model.py`` checks them against CasADi's derivatives.
    """
    a = 1 / (l1 * l1 * l2 * l2)
    return l1 - a / l1, l2 - a / l2, 1 + 3 * a / (l1 * l1), 2 * a / (l1 * l2)


def area_invariant_derivatives(l1, l2):
    """Half the derivatives of ``K = λ1²λ2²``: ``(λ1λ2², λ1²λ2, λ2², 2λ1λ2)``."""
    return l1 * l2 * l2, l1 * l1 * l2, l2 * l2, 2 * l1 * l2


def area_invariant(l1, l2):
    """``K = λ1² λ2²``, the squared areal stretch (the field scales with ``√K``)."""
    return l1**2 * l2**2


class Elasticity(Protocol):
    """What an elasticity effect gives the model: its energy ``Ws/μ`` as a function of ``I = I1 − 3``, and
    how far the chains are from locking (a positive constant if they never lock); ``locking_stretch`` is
    the equibiaxial stretch at which they lock (None if they never do)."""

    name: str

    @property
    def locking_stretch(self) -> float | None: ...

    def energy_of_invariant(self, i1: Any) -> Any: ...

    def locking_margin(self, l1: Any, l2: Any) -> Any: ...

    def describe(self) -> dict: ...


class Electrostatics(Protocol):
    """What an electrostatics effect gives the model: its energy at fixed voltage as a function of
    ``K = λ1²λ2²``, the nominal charge density and the true field (all zero when it is off)."""

    name: str
    enabled: bool

    def energy_of_invariant(self, k: Any, phi: Any) -> Any: ...

    def charge_density(self, l1: Any, l2: Any, phi: Any) -> Any: ...

    def field(self, l1: Any, l2: Any, phi: Any) -> Any: ...


@dataclass(frozen=True)
class NeoHookean:
    """Neo-Hookean elasticity, ``Ws/μ = (λ1² + λ2² + λ1⁻²λ2⁻² − 3)/2`` (seed eq. 2, PHYSICS.md)."""

    name = "neo-hookean"

    def energy_of_invariant(self, i1):
        """``Ws/μ`` as a function of ``I = I1 − 3``."""
        return 0.5 * i1

    def locking_margin(self, l1, l2):
        """Always positive: a neo-Hookean membrane never locks."""
        import casadi as ca

        return ca.SX(1.0)

    @property
    def locking_stretch(self) -> float | None:
        """None: a neo-Hookean membrane never locks."""
        return None

    def describe(self) -> dict:
        return {"material": self.name}


@dataclass(frozen=True)
class Gent:
    """Gent elasticity, ``Ws/μ = −(Jlim/2) ln(1 − (λ1² + λ2² + λ1⁻²λ2⁻² − 3)/Jlim)``.

    Parameters
    ----------
    jlim : float
        Limiting value of ``I1 − 3``; VHB is often given ``Jlim ≈ 97–120``. ``Jlim → ∞`` recovers
        :class:`NeoHookean`.
    """

    jlim: float
    name = "gent"

    def __post_init__(self):
        if not (isinstance(self.jlim, (int, float)) and math.isfinite(self.jlim) and self.jlim > 0):
            raise SceneError(f"Jlim must be a positive number, got {self.jlim!r}", "jlim")

    def energy_of_invariant(self, i1):
        """``Ws/μ`` as a function of ``I = I1 − 3``."""
        import casadi as ca

        return -0.5 * self.jlim * ca.log1p(-i1 / self.jlim)  # log1p: exact as Jlim → ∞

    def locking_margin(self, l1, l2):
        """``1 − (I1 − 3)/Jlim``: the chains lock where it reaches zero."""
        return 1 - first_invariant(l1, l2) / self.jlim

    @property
    def locking_stretch(self) -> float:
        """``√((Jlim + 3)/2)``: the equibiaxial stretch at which the chains lock, ``2λ² + λ⁻⁴ − 3 = Jlim``
        without its ``λ⁻⁴`` (relative difference below ``1/(2λ⁶)``, 1.5e-6 at ``Jlim = 97``)."""
        return math.sqrt((self.jlim + 3) / 2)

    def describe(self) -> dict:
        return {"material": self.name, "jlim": self.jlim}


@dataclass(frozen=True)
class IdealDielectric:
    """An ideal dielectric between compliant electrodes at fixed voltage.

    Free energy at fixed voltage per reference volume, normalised by ``μ``:
    ``−(ε/2)(Φ λ1 λ2 / H)²/μ = −Φ̂² λ1² λ2² / 2``; nominal charge per reference area
    ``D λ1 λ2 / ... → q̂ = Φ̂ λ1² λ2²`` (so ``Q̂ = ∫ q̂ 2π R̂ dR̂``); true field ``Ê = Φ̂ λ1 λ2``.
    """

    name = "ideal-dielectric"
    enabled = True

    def energy_of_invariant(self, k, phi):
        """``−Φ̂² K / 2`` with ``K = λ1² λ2²``."""
        return -0.5 * phi**2 * k

    def charge_density(self, l1, l2, phi):
        return phi * l1**2 * l2**2

    def field(self, l1, l2, phi):
        return phi * l1 * l2


@dataclass(frozen=True)
class NoElectrostatics:
    """Electrostatics switched off: its energy, charge and field are the constant zero (folded away)."""

    name = "none"
    enabled = False

    def energy_of_invariant(self, k, phi):
        return _symbolic_zero()

    def charge_density(self, l1, l2, phi):
        return _symbolic_zero()

    def field(self, l1, l2, phi):
        return _symbolic_zero()


# --- what holds the pressure -----------------------------------------------------------------------
class PressureSource(Protocol):
    """What holds the zones' gauge pressure ``p̂`` as a function of their total volume ``ΣV̂``."""

    name: str

    def pressure(self, total_volume: Any) -> Any: ...

    def stiffness(self, total_volume: Any) -> Any: ...

    def free_energy(self, total_volume: Any) -> Any: ...


@dataclass(frozen=True)
class GasChamber:
    """Isothermal ideal gas, fixed amount, rigid chamber: ``(V̂c + ΣV̂)(p̂atm + p̂) = n̂``.

    Parameters
    ----------
    chamber_volume : float
        ``V̂c = Vc/A³``.
    atmospheric_pressure : float
        ``p̂atm = Patm A/(μH)``.
    gas_amount : float
        ``n̂ = NkT/(μHA²)``, fixed when the valves close.
    """

    chamber_volume: float
    atmospheric_pressure: float
    gas_amount: float
    name = "isothermal-ideal-gas"

    def __post_init__(self):
        for key in ("chamber_volume", "atmospheric_pressure", "gas_amount"):
            v = getattr(self, key)
            if not (isinstance(v, (int, float)) and math.isfinite(v) and v > 0):
                raise SceneError(f"must be a positive number, got {v!r}", key)

    @classmethod
    def closed_at(cls, chamber_volume, atmospheric_pressure, closing_pressure, zone_volumes_total):
        """The gas that fills chamber and zones at gauge pressure ``p̂`` when the valves close."""
        n = (chamber_volume + zone_volumes_total) * (atmospheric_pressure + closing_pressure)
        return cls(float(chamber_volume), float(atmospheric_pressure), float(n))

    def pressure(self, total_volume):
        """Gauge pressure ``p̂ = n̂/(V̂c + ΣV̂) − p̂atm``."""
        return self.gas_amount / (self.chamber_volume + total_volume) - self.atmospheric_pressure

    def stiffness(self, total_volume):
        """``c = −dp̂/dΣV̂ = n̂/(V̂c + ΣV̂)²`` (the gas resists a change of the total volume)."""
        return self.gas_amount / (self.chamber_volume + total_volume) ** 2

    def free_energy(self, total_volume):
        """``−n̂ ln(V̂c + ΣV̂) + p̂atm ΣV̂``."""
        return -self.gas_amount * np.log(self.chamber_volume + total_volume) + self.atmospheric_pressure * total_volume


@dataclass(frozen=True)
class PressureReservoir:
    """Pressure control (no chamber in the scene): the gauge pressure is ``p̂`` whatever the volume."""

    pressure_hat: float
    name = "pressure-control"

    def __post_init__(self):
        if not (isinstance(self.pressure_hat, (int, float)) and math.isfinite(self.pressure_hat)):
            raise SceneError(f"must be a finite number, got {self.pressure_hat!r}", "pressure_hat")

    def pressure(self, total_volume):
        return self.pressure_hat + 0.0 * np.asarray(total_volume)

    def stiffness(self, total_volume):
        return 0.0 * np.asarray(total_volume)

    def free_energy(self, total_volume):
        return -self.pressure_hat * total_volume


@dataclass(frozen=True)
class Breakdown:
    """Electrical breakdown: a path ends where the largest true field in a zone reaches ``field_hat``.

    Parameters
    ----------
    field_hat : float
        Normalised breakdown field ``Êb = Eb √(ε/μ)``.
    """

    field_hat: float
    name = "breakdown-check"

    def __post_init__(self):
        if not (isinstance(self.field_hat, (int, float)) and math.isfinite(self.field_hat) and self.field_hat > 0):
            raise SceneError(f"must be a positive number, got {self.field_hat!r}", "breakdown_field")

    def margin(self, max_field: float) -> float:
        """``Ê_max − Êb``: the event function (the path ends where it reaches zero from below)."""
        return float(max_field) - self.field_hat


def material_from_name(name: str, jlim: float | None = None):
    """The elasticity effect for a material name (``neo-hookean`` or ``gent``)."""
    key = name.strip().lower().replace("_", "-")
    if key in ("neo-hookean", "neohookean", "nh"):
        return NeoHookean()
    if key == "gent":
        if jlim is None:
            raise SceneError("the Gent material needs jlim (e.g. 97 for VHB)", "jlim")
        return Gent(float(jlim))
    raise SceneError(f"unknown material {name!r}; use 'neo-hookean' or 'gent'", "material")
