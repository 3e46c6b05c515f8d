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
from .validation import real


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

    Parameters
    ----------
    l1, l2 : float, ndarray or casadi.SX
        Meridional and hoop stretches ``λ1``, ``λ2`` (arrays broadcast).

    Returns
    -------
    float, ndarray or casadi.SX
        ``I = I1 − 3``, of the type of the inputs.

    Examples
    --------
    A membrane stretched by ``δ = 1e-9``: ``I ≈ 3 (2δ)²``, which the textbook form loses entirely.

    >>> l = 1 + 1e-9
    >>> f"{first_invariant(l, l):.6e}", 2 * l**2 + l**-4 - 3
    ('1.200000e-17', 0.0)
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

    Parameters
    ----------
    l1, l2 : float, ndarray or casadi.SX
        Meridional and hoop stretches ``λ1``, ``λ2``.

    Returns
    -------
    tuple of 4
        ``(I_1/2, I_2/2, I_11/2, I_12/2)``, each of the type of the inputs.
    """
    a = 1 / (l1 * l1 * l2 * l2)
    return l1 - a / l1, l2 - a / l2, 1 + 3 * a / (l1 * l1), 2 * a / (l1 * l2)


def area_invariant_derivatives(l1, l2):
    """Half the derivatives of ``K = λ1²λ2²``: ``(λ1λ2², λ1²λ2, λ2², 2λ1λ2)``.

    Parameters
    ----------
    l1, l2 : float, ndarray or casadi.SX
        Meridional and hoop stretches ``λ1``, ``λ2``.

    Returns
    -------
    tuple of 4
        ``(∂K/∂λ1, ∂K/∂λ2, ∂²K/∂λ1², ∂²K/∂λ1∂λ2) / 2``, each of the type of the inputs.
    """
    return l1 * l2 * l2, l1 * l1 * l2, l2 * l2, 2 * l1 * l2


def area_invariant(l1, l2):
    """``K = λ1² λ2²``, the squared areal stretch (the field scales with ``√K``).

    Parameters
    ----------
    l1, l2 : float, ndarray or casadi.SX
        Meridional and hoop stretches ``λ1``, ``λ2``.

    Returns
    -------
    float, ndarray or casadi.SX
        ``K``, of the type of the inputs.
    """
    return l1**2 * l2**2


class Elasticity(Protocol):
    """What an elasticity effect gives the model: its energy ``Ws/μ`` as a function of ``I = I1 − 3``, and
    how far the chains are from locking (a positive constant if they never lock); ``locking_stretch`` is
    the equibiaxial stretch at which they lock (None if they never do)."""

    name: str

    @property
    def locking_stretch(self) -> float | None:
        """Equibiaxial stretch at which the chains lock, or None if they never do."""
        ...

    def energy_of_invariant(self, i1: Any) -> Any:
        """Strain energy ``Ws/μ`` per reference volume as a function of ``I = I1 − 3``.

        Parameters
        ----------
        i1 : casadi.SX
            The first invariant less 3, ``I = λ1² + λ2² + λ1⁻²λ2⁻² − 3``.

        Returns
        -------
        casadi.SX
            ``Ws/μ``.
        """
        ...

    def locking_margin(self, l1: Any, l2: Any) -> Any:
        """Distance from locking: positive while the chains are extensible, zero where they lock.

        Parameters
        ----------
        l1, l2 : casadi.SX or ndarray
            Meridional and hoop stretches ``λ1``, ``λ2``.

        Returns
        -------
        casadi.SX or ndarray
            The margin (a positive constant for a material that never locks).
        """
        ...

    def describe(self) -> dict:
        """Plain-dict description of the material.

        Returns
        -------
        dict
            ``material`` (its name) and its parameters.
        """
        ...


class Electrostatics(Protocol):
    """What an electrostatics effect gives the model: its energy at fixed voltage as a function of
    ``K = λ1²λ2²``, the nominal charge density and the true field (all zero when it is off)."""

    name: str
    enabled: bool

    def energy_of_invariant(self, k: Any, phi: Any) -> Any:
        """Electrostatic part of ``W*`` (at fixed voltage, over ``μ``) as a function of ``K = λ1²λ2²``.

        Parameters
        ----------
        k : casadi.SX
            ``K = λ1² λ2²``.
        phi : casadi.SX or float
            Normalised voltage ``Φ̂ = (Φ/H)√(ε/μ)``.

        Returns
        -------
        casadi.SX
            The energy density over ``μ``.
        """
        ...

    def charge_density(self, l1: Any, l2: Any, phi: Any) -> Any:
        """Nominal charge per reference area, normalised (``Q̂ = ∫ q̂ 2π R̂ dR̂``).

        Parameters
        ----------
        l1, l2 : casadi.SX
            Meridional and hoop stretches ``λ1``, ``λ2``.
        phi : casadi.SX or float
            Normalised voltage ``Φ̂``.

        Returns
        -------
        casadi.SX
            ``q̂``.
        """
        ...

    def field(self, l1: Any, l2: Any, phi: Any) -> Any:
        """True electric field normalised as ``Ê = E √(ε/μ)``.

        Parameters
        ----------
        l1, l2 : casadi.SX
            Meridional and hoop stretches ``λ1``, ``λ2``.
        phi : casadi.SX or float
            Normalised voltage ``Φ̂``.

        Returns
        -------
        casadi.SX
            ``Ê``.
        """
        ...


@dataclass(frozen=True)
class NeoHookean:
    """Neo-Hookean elasticity, ``Ws/μ = (λ1² + λ2² + λ1⁻²λ2⁻² − 3)/2`` (seed eq. 2, docs/physics.md)."""

    name = "neo-hookean"

    def energy_of_invariant(self, i1):
        """``Ws/μ`` as a function of ``I = I1 − 3``: ``Ws/μ = I/2``.

        Parameters
        ----------
        i1 : casadi.SX or float
            ``I = I1 − 3``.

        Returns
        -------
        casadi.SX or float
            ``I/2``.
        """
        return 0.5 * i1

    def locking_margin(self, l1, l2):
        """Always positive: a neo-Hookean membrane never locks.

        Parameters
        ----------
        l1, l2 : casadi.SX
            Meridional and hoop stretches (unused).

        Returns
        -------
        casadi.SX
            The constant 1.
        """
        import casadi as ca

        return ca.SX(1.0)

    @property
    def locking_stretch(self) -> float | None:
        """None: a neo-Hookean membrane never locks."""
        return None

    def describe(self) -> dict:
        """Plain-dict description.

        Returns
        -------
        dict
            ``{"material": "neo-hookean"}``.
        """
        return {"material": self.name}


def equibiaxial_locking_stretch(jlim: float) -> float:
    """The root ``λ > 1`` of ``2λ² + λ⁻⁴ − 3 = Jlim``: where a Gent membrane stretched equibiaxially locks.

    Newton's method on the convex ``g(λ) = 2λ² + λ⁻⁴ − 3 − Jlim`` from ``√((Jlim + 3)/2)``, where ``g > 0``: the
    iterates fall monotonically onto the root (quadratically; a few steps down to ``Jlim`` of 1e-12).

    Parameters
    ----------
    jlim : float
        ``Jlim > 0``.

    Returns
    -------
    float
        The locking stretch, to rounding.

    Examples
    --------
    >>> round(equibiaxial_locking_stretch(0.05), 6), round(equibiaxial_locking_stretch(97.0), 6)
    (1.06809, 7.071054)
    """
    lam = math.sqrt((jlim + 3.0) / 2.0)
    for _ in range(100):
        g = 2.0 * lam * lam + lam**-4 - 3.0 - jlim
        step = g / (4.0 * lam - 4.0 * lam**-5)
        lam -= step
        if not step > 4e-16 * lam:
            break
    return lam


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
        object.__setattr__(self, "jlim", real(self.jlim, "jlim", lo=0.0, lo_open=True))

    def energy_of_invariant(self, i1):
        """``Ws/μ`` as a function of ``I = I1 − 3``: ``Ws/μ = −(Jlim/2) ln(1 − I/Jlim)``.

        Evaluated with ``log1p``, so it tends to ``I/2`` exactly as ``Jlim → ∞``.

        Parameters
        ----------
        i1 : casadi.SX or float
            ``I = I1 − 3``; below ``Jlim``.

        Returns
        -------
        casadi.SX or float
            ``Ws/μ``.
        """
        import casadi as ca

        return -0.5 * self.jlim * ca.log1p(-i1 / self.jlim)  # log1p: exact as Jlim → ∞

    def locking_margin(self, l1, l2):
        """``1 − (I1 − 3)/Jlim``: the chains lock where it reaches zero.

        Parameters
        ----------
        l1, l2 : float, ndarray or casadi.SX
            Meridional and hoop stretches ``λ1``, ``λ2``.

        Returns
        -------
        float, ndarray or casadi.SX
            The margin, of the type of the inputs.
        """
        return 1 - first_invariant(l1, l2) / self.jlim

    @property
    def locking_stretch(self) -> float:
        """``√((Jlim + 3)/2)``: the equibiaxial stretch at which the chains lock, ``2λ² + λ⁻⁴ − 3 = Jlim``
        without its ``λ⁻⁴`` (relative difference below ``1/(2λ⁶)``, 1.5e-6 at ``Jlim = 97``)."""
        return math.sqrt((self.jlim + 3) / 2)

    @property
    def exact_locking_stretch(self) -> float:
        """The equibiaxial stretch at which the chains lock, the root ``λ > 1`` of ``2λ² + λ⁻⁴ − 3 = Jlim`` itself
        (:attr:`locking_stretch` drops the ``λ⁻⁴``, an upper bound that is 16 % high at ``Jlim = 0.05``: 1.235 against
        1.068). Newton's method from that bound, which it approaches from above (the function is convex)."""
        return equibiaxial_locking_stretch(self.jlim)

    def describe(self) -> dict:
        """Plain-dict description.

        Returns
        -------
        dict
            ``{"material": "gent", "jlim": Jlim}``.
        """
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
        """``−Φ̂² K / 2`` with ``K = λ1² λ2²``.

        Parameters
        ----------
        k : casadi.SX or float
            ``K = λ1² λ2²``.
        phi : casadi.SX or float
            Normalised voltage ``Φ̂``.

        Returns
        -------
        casadi.SX or float
            ``−Φ̂² K / 2``.
        """
        return -0.5 * phi**2 * k

    def charge_density(self, l1, l2, phi):
        """Nominal charge density ``q̂ = Φ̂ λ1² λ2²``.

        Parameters
        ----------
        l1, l2 : casadi.SX or float
            Meridional and hoop stretches ``λ1``, ``λ2``.
        phi : casadi.SX or float
            Normalised voltage ``Φ̂``.

        Returns
        -------
        casadi.SX or float
            ``q̂``.
        """
        return phi * l1**2 * l2**2

    def field(self, l1, l2, phi):
        """True field ``Ê = Φ̂ λ1 λ2`` (the thickness is ``H/(λ1λ2)``).

        Parameters
        ----------
        l1, l2 : casadi.SX or float
            Meridional and hoop stretches ``λ1``, ``λ2``.
        phi : casadi.SX or float
            Normalised voltage ``Φ̂``.

        Returns
        -------
        casadi.SX or float
            ``Ê``.
        """
        return phi * l1 * l2


@dataclass(frozen=True)
class NoElectrostatics:
    """Electrostatics switched off: its energy, charge and field are the constant zero (folded away)."""

    name = "none"
    enabled = False

    def energy_of_invariant(self, k, phi):
        """The constant zero: no electrostatic energy.

        Parameters
        ----------
        k : casadi.SX
            ``K = λ1² λ2²`` (unused).
        phi : casadi.SX or float
            Normalised voltage (unused).

        Returns
        -------
        casadi.SX
            ``0``.
        """
        return _symbolic_zero()

    def charge_density(self, l1, l2, phi):
        """The constant zero: no charge.

        Parameters
        ----------
        l1, l2 : casadi.SX
            Stretches (unused).
        phi : casadi.SX or float
            Normalised voltage (unused).

        Returns
        -------
        casadi.SX
            ``0``.
        """
        return _symbolic_zero()

    def field(self, l1, l2, phi):
        """The constant zero: no field.

        Parameters
        ----------
        l1, l2 : casadi.SX
            Stretches (unused).
        phi : casadi.SX or float
            Normalised voltage (unused).

        Returns
        -------
        casadi.SX
            ``0``.
        """
        return _symbolic_zero()


# --- what holds the pressure -----------------------------------------------------------------------
class PressureSource(Protocol):
    """What holds the zones' gauge pressure ``p̂`` as a function of their total volume ``ΣV̂``."""

    name: str

    def pressure(self, total_volume: Any) -> Any:
        """Gauge pressure ``p̂`` the zones are held at.

        Parameters
        ----------
        total_volume : float or ndarray
            ``ΣV̂``, the zones' total volume over ``A³``.

        Returns
        -------
        float or ndarray
            ``p̂ = pA/(μH)``, shaped like ``total_volume``.
        """
        ...

    def stiffness(self, total_volume: Any) -> Any:
        """``c = −dp̂/dΣV̂``, the coupling term of the Hessian ``diag(ai) + c 1 1ᵀ`` of ``G``.

        Parameters
        ----------
        total_volume : float or ndarray
            ``ΣV̂``.

        Returns
        -------
        float or ndarray
            ``c``, shaped like ``total_volume``.
        """
        ...

    def free_energy(self, total_volume: Any) -> Any:
        """The source's part of the potential ``G = ΣΨ̂ + (this)``, normalised by ``μHA²``.

        Parameters
        ----------
        total_volume : float or ndarray
            ``ΣV̂``.

        Returns
        -------
        float or ndarray
            Its free energy, up to a constant.
        """
        ...


def x_minus_log1p(y):
    """``y − ln(1 + y)`` for ``y > −1``, to a few ulps (no cancellation for small ``|y|``).

    Below ``|y|`` = 0.25 the series in ``s = y/(2 + y)`` (``ln(1 + y) = 2 atanh s``, ``y = 2s/(1 − s)``):
    ``2s Σ bm s^m`` with ``bm = 1`` for odd ``m`` and ``m/(m + 1)`` for even ``m``, all terms of one sign for
    ``s > 0``; above, the direct difference, which then loses at most a few digits' fraction.

    Parameters
    ----------
    y : float or ndarray
        Above −1.

    Returns
    -------
    float or ndarray
        ``y − log1p(y) ≥ 0``, shaped like ``y``.

    Examples
    --------
    >>> round(x_minus_log1p(1e-9) * 1e18, 9)  # y²/2 − y³/3; 1e-9 − log1p(1e-9) keeps no digit of it
    0.5
    """
    y = np.asarray(y, dtype=float)
    small = np.abs(y) < 0.25
    ys = np.where(small, y, 0.0)
    s = ys / (2.0 + ys)
    acc = np.zeros_like(s)
    for m in range(24, 0, -1):  # Horner: |s| < 1/7, s^24 < 1e-20
        acc = (acc + (1.0 if m % 2 else m / (m + 1))) * s
    series = 2.0 * s * acc
    with np.errstate(invalid="ignore", divide="ignore"):
        direct = y - np.log1p(np.where(small, 0.0, y))
    out = np.where(small, series, direct)
    return out if out.ndim else float(out)


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
            object.__setattr__(self, key, real(getattr(self, key), key, lo=0.0, lo_open=True))

    @classmethod
    def closed_at(cls, chamber_volume, atmospheric_pressure, closing_pressure, zone_volumes_total):
        """The gas that fills chamber and zones at gauge pressure ``p̂`` when the valves close:
        ``n̂ = (V̂c + ΣV̂)(p̂atm + p̂)``.

        Parameters
        ----------
        chamber_volume : float
            ``V̂c = Vc/A³``.
        atmospheric_pressure : float
            ``p̂atm = Patm A/(μH)``.
        closing_pressure : float
            Gauge pressure ``p̂`` of chamber and zones when the valves close.
        zone_volumes_total : float
            ``ΣV̂`` of the zones at that moment.

        Returns
        -------
        GasChamber
            The chamber with its fixed gas amount ``n̂``.

        Raises
        ------
        SceneError
            If ``V̂c``, ``p̂atm`` or the resulting ``n̂`` is not a positive finite number, ``p̂`` is not finite, or
            ``ΣV̂`` is negative or not finite.

        Examples
        --------
        >>> gas = GasChamber.closed_at(1.0, 1.0, closing_pressure=0.5, zone_volumes_total=0.2)
        >>> float(gas.pressure(0.2)), float(gas.stiffness(0.2))
        (0.5, 1.25)
        """
        chamber_volume = real(chamber_volume, "chamber_volume", lo=0.0, lo_open=True)
        atmospheric_pressure = real(atmospheric_pressure, "atmospheric_pressure", lo=0.0, lo_open=True)
        closing_pressure = real(closing_pressure, "closing_pressure")
        zone_volumes_total = real(zone_volumes_total, "zone_volumes_total", lo=0.0)
        if (
            not atmospheric_pressure + closing_pressure > 0
        ):  # the absolute pressure, and with it n̂, would not be positive
            raise SceneError(
                f"the absolute pressure p̂atm + p̂ = {atmospheric_pressure + closing_pressure:.6g} at closing must be "
                "positive (a gauge pressure below minus one atmosphere)",
                "closing_pressure",
            )
        n = (chamber_volume + zone_volumes_total) * (atmospheric_pressure + closing_pressure)
        return cls(chamber_volume, atmospheric_pressure, float(n))

    def pressure(self, total_volume):
        """Gauge pressure ``p̂ = n̂/(V̂c + ΣV̂) − p̂atm``.

        Parameters
        ----------
        total_volume : float or ndarray
            ``ΣV̂``, the zones' total volume over ``A³``.

        Returns
        -------
        float or ndarray
            ``p̂``, shaped like ``total_volume``.
        """
        return self.gas_amount / (self.chamber_volume + total_volume) - self.atmospheric_pressure

    def stiffness(self, total_volume):
        """``c = −dp̂/dΣV̂ = n̂/(V̂c + ΣV̂)²`` (the gas resists a change of the total volume).

        Parameters
        ----------
        total_volume : float or ndarray
            ``ΣV̂``.

        Returns
        -------
        float or ndarray
            ``c > 0``, shaped like ``total_volume``.
        """
        return self.gas_amount / (self.chamber_volume + total_volume) ** 2

    def free_energy(self, total_volume):
        """``n̂ (y − ln(1 + y))`` with ``y = (V̂c + ΣV̂)/T̂0 − 1`` and ``T̂0 = n̂/p̂atm`` (the volume at which the gauge
        pressure vanishes): ``−n̂ ln(V̂c + ΣV̂) + p̂atm ΣV̂`` up to a constant, which no difference of ``G`` sees.

        ``y = −p̂/(p̂atm + p̂)``, so the value is about ``(V̂c + ΣV̂) p̂²/(2(p̂atm + p̂))``, no larger than the zones'
        ``p̂ ΣV̂`` and small where the gas is stiff; ``y − ln(1 + y)`` is evaluated without cancellation
        (:func:`x_minus_log1p`). The terms ``−n̂ ln(1 + ΣV̂/V̂c) + p̂atm ΣV̂`` each are of the size of ``(p̂atm + p̂)
        ΣV̂`` and nearly cancel: at ``p̂atm`` = 1e8 (a soft, thin membrane under one atmosphere) their rounding, ~1e-6,
        put a noise of ~1e-7 in ``Φ̂`` into the tricircle's equal free energy and its error floor ``4 ε |Ĝ| /
        |ΔQ̂|`` to 1e-6 relative; at 1e9 it did not converge at rtol 1e-12. (Before, ``−n̂ ln(V̂c + ΣV̂)`` itself:
        about 1e9 for a 1e7 ml chamber, review, helper-81.)

        Parameters
        ----------
        total_volume : float or ndarray
            ``ΣV̂``.

        Returns
        -------
        float or ndarray
            The gas's part of ``G``, shaped like ``total_volume``.
        """
        t0 = self.gas_amount / self.atmospheric_pressure
        y = (np.asarray(total_volume, dtype=float) - (t0 - self.chamber_volume)) / t0
        out = self.gas_amount * x_minus_log1p(y)
        return float(out) if np.ndim(out) == 0 else out


@dataclass(frozen=True)
class PressureReservoir:
    """Pressure control (no chamber in the scene): the gauge pressure is ``p̂`` whatever the volume."""

    pressure_hat: float
    name = "pressure-control"

    def __post_init__(self):
        # a gauge pressure the zones hold inflated: positive (below the atmosphere they would invert)
        object.__setattr__(self, "pressure_hat", real(self.pressure_hat, "pressure_hat", lo=0.0, lo_open=True))

    def pressure(self, total_volume):
        """``p̂``, whatever the volume.

        Parameters
        ----------
        total_volume : float or ndarray
            ``ΣV̂`` (only its shape is used).

        Returns
        -------
        ndarray
            ``p̂``, broadcast to the shape of ``total_volume``.
        """
        return self.pressure_hat + 0.0 * np.asarray(total_volume)

    def stiffness(self, total_volume):
        """``c = −dp̂/dΣV̂ = 0``: a reservoir does not resist a change of volume.

        Parameters
        ----------
        total_volume : float or ndarray
            ``ΣV̂`` (only its shape is used).

        Returns
        -------
        ndarray
            Zeros shaped like ``total_volume``.
        """
        return 0.0 * np.asarray(total_volume)

    def free_energy(self, total_volume):
        """``−p̂ ΣV̂`` (so that ``G = ΣΨ̂ − p̂ΣV̂``).

        Parameters
        ----------
        total_volume : float or ndarray
            ``ΣV̂``.

        Returns
        -------
        float or ndarray
            ``−p̂ ΣV̂``.
        """
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
        object.__setattr__(self, "field_hat", real(self.field_hat, "breakdown_field", lo=0.0, lo_open=True))

    def margin(self, max_field: float) -> float:
        """``Ê_max − Êb``: the event function (the path ends where it reaches zero from below).

        Parameters
        ----------
        max_field : float
            Largest true field ``Ê_max`` in a zone.

        Returns
        -------
        float
            ``Ê_max − Êb``; negative below breakdown.
        """
        return float(max_field) - self.field_hat


#: the material names the library knows, canonical spelling first
MATERIALS = ("neo-hookean", "gent")
_MATERIAL_ALIASES = {"neohookean": "neo-hookean", "nh": "neo-hookean"}


def canonical_material(name: str) -> str | None:
    """The canonical name of a material (:data:`MATERIALS`), or None if it is not one.

    Parameters
    ----------
    name : str
        A material name; case, spaces, ``_`` and ``-`` do not matter, and ``neohookean``/``nh`` are aliases.

    Returns
    -------
    str or None
    """
    key = str(name).strip().lower().replace("_", "-").replace(" ", "-")
    key = _MATERIAL_ALIASES.get(key, key)
    return key if key in MATERIALS else None


def material_from_name(name: str, jlim: float | None = None):
    """The elasticity effect for a material name (``neo-hookean`` or ``gent``).

    Parameters
    ----------
    name : str
        ``neo-hookean`` (also ``neohookean``, ``nh``) or ``gent``; case and ``_``/``-`` do not matter.
    jlim : float, optional
        ``Jlim`` of the Gent material (required for it, refused for the neo-Hookean material).

    Returns
    -------
    NeoHookean or Gent

    Raises
    ------
    SceneError
        For an unknown name, for ``gent`` without a positive finite ``jlim``, or a ``jlim`` for ``neo-hookean``.
    """
    key = canonical_material(name)
    if key == "neo-hookean":
        if jlim is not None:
            raise SceneError("only the gent material takes jlim (the neo-Hookean material has no limit)", "jlim")
        return NeoHookean()
    if key == "gent":
        if jlim is None:
            raise SceneError("the Gent material needs jlim (e.g. 97 for VHB)", "jlim")
        return Gent(jlim)  # Gent checks it (a positive number, not a bool or text)
    raise SceneError(f"unknown material {name!r}; use 'neo-hookean' or 'gent'", "material")
