"""The membrane model: free energy at fixed voltage, tensions, and the shooting equations.

Built once, symbolically with CasADi, from the effects it is given (:mod:`coexist.effects`);
then translated into numpy (:mod:`coexist.numerics.codegen`) for the vectorised integrator.

Equations (docs/physics.md, normalised with ``μ``, ``H`` and the zone radius ``A``; ``' = d/dR̂``):

- ``W*(λ1, λ2; Φ̂) = Ws(λ1, λ2)/μ − Φ̂² λ1² λ2² / 2``
- ``T̂1 = ∂W*/∂λ1``, ``T̂2 = ∂W*/∂λ2`` (nominal tensions over ``μH``)
- ``λ2' = (λ1 cos θ − λ2)/R̂``
- ``(R̂ T̂1)' = T̂2 cos θ``, expanded into
  ``λ1' = (T̂2 cos θ − T̂1 − R̂ ∂T̂1/∂λ2 λ2') / (R̂ ∂T̂1/∂λ1)``
- ``θ' = (p̂ λ1 λ2 R̂ − T̂2 sin θ) / (R̂ T̂1)``
- quadratures ``V̂' = π r̂² λ1 sin θ``, ``Q̂' = 2π Φ̂ λ1² λ2² R̂``, ``Ψ̂' = 2π W* R̂``,
  ``ẑ' = λ1 sin θ`` (height of the pole above the clamp plane).
"""

from __future__ import annotations

import math
import numbers
from dataclasses import dataclass, field

import casadi as ca
import numpy as np

from .effects import (
    Elasticity,
    Electrostatics,
    IdealDielectric,
    NeoHookean,
    NoElectrostatics,
    area_invariant,
    area_invariant_derivatives,
    first_invariant,
    first_invariant_derivatives,
)
from .errors import SceneError
from .numerics import cache
from .numerics.codegen import SCALAR_SUFFIX, numpy_module_source, small_batch

#: constant factors of the quadratures V̂, Q̂, Ψ̂, ẑ: the right-hand side integrates V̂/π, Q̂/2π,
#: Ψ̂/2π and ẑ (one multiplication fewer per stage each), the shooting multiplies them back
QUADRATURE_FACTORS = (math.pi, 2 * math.pi, 2 * math.pi, 1.0)
#: the largest prestretch a model accepts, the bound a scene puts on every number (``scene_format.SI_RANGE``). Once
#: its ``λpre⁻⁶`` terms lie below rounding a neo-Hookean zone's states scale with the prestretch (``p̂ λpre``,
#: ``V̂/λpre³``, ``Ψ̂/λpre²`` at fixed ``λ0/λpre``), and the solver's agree with those at ``λpre = 1e6`` to 2e-13 up to
#: ``λpre = 3e50``; beyond a pole stretch of about 1.5e51 every state fails (the energy's powers ``λ⁶`` overflow near
#: 2.4e51), as "the integration used up its step budget", after seconds per curve, and above 1e103 as non-finite
#: values (helper-98). The library follows pole stretches up to ``stretch_max_factor`` (6) times the prestretch: 1e30
#: leaves twenty decades to the overflow.
MAX_PRESTRETCH = 1e30
#: what a state whose hoop tension would turn negative is (:attr:`MembraneModel.wrinkling`)
WRINKLING_MODES = ("refuse", "tension-field")


@dataclass(frozen=True)
class MembraneModel:
    """A clamped circular dielectric elastomer membrane, built from its effects.

    Parameters
    ----------
    elasticity : NeoHookean or Gent
        Strain energy of the elastomer.
    electrostatics : IdealDielectric or NoElectrostatics
        Whether the membrane carries a voltage at all.
    prestretch : float
        Equibiaxial prestretch ``1 ≤ λpre ≤`` :data:`MAX_PRESTRETCH` of the clamped membrane; the rim condition is
        ``λ2(1) = λpre``, lengths stay normalised by the unstretched radius ``A``.
    wrinkling : {"refuse", "tension-field"}
        What a state whose hoop tension would turn negative is: ``"refuse"`` (no state, status
        ``wrinkling``) or ``"tension-field"`` (the membrane wrinkles across the hoop direction and carries
        the relaxed energy there, docs/physics.md section 10; :mod:`coexist.wrinkling`). The wrinkled
        segments' functions are generated only for ``"tension-field"``.

    Raises
    ------
    SceneError
        If ``prestretch`` is not a finite number in ``[1, MAX_PRESTRETCH]`` or ``wrinkling`` is not one of the two.

    Notes
    -----
    The numeric methods are numpy code generated from the CasADi expressions: they take floats or
    arrays (broadcast against each other) and return one value per output, a float for float inputs
    and an array of the broadcast shape otherwise (a constant output, such as an effect switched off,
    is broadcast too). An argument that is not a real number or a numpy array of them (None, text, a list), shapes
    that do not broadcast, or an ``out`` too small raise a SceneError naming it; the values themselves are not
    checked (they are the integrator's inner functions: a NaN gives NaN where it enters).
    """

    elasticity: Elasticity = field(default_factory=NeoHookean)
    electrostatics: Electrostatics = field(default_factory=IdealDielectric)
    prestretch: float = 1.0
    wrinkling: str = "refuse"
    _built: dict = field(init=False, repr=False, compare=False, default_factory=dict)

    def __post_init__(self):
        from . import validation

        validation.has_methods(
            self.elasticity,
            ("energy_of_invariant", "locking_margin"),
            "elasticity",
            "an elasticity effect (NeoHookean(), Gent(97))",
        )
        validation.has_methods(
            self.electrostatics,
            ("energy_of_invariant", "charge_density", "field"),
            "electrostatics",
            "an electrostatics effect (IdealDielectric(), NoElectrostatics())",
        )
        try:
            object.__setattr__(self, "prestretch", validation.real(self.prestretch, "prestretch", lo=1.0))
        except SceneError as exc:
            raise SceneError(f"prestretch {exc.message}", "prestretch") from None
        if self.prestretch > MAX_PRESTRETCH:
            raise SceneError(
                f"prestretch must be at most {MAX_PRESTRETCH:g} (far beyond any elastomer's; the model's numbers "
                f"overflow near 1e51), got {self.prestretch:g}",
                "prestretch",
            )
        if self.wrinkling not in WRINKLING_MODES:
            raise SceneError(
                f"wrinkling must be one of {', '.join(map(repr, WRINKLING_MODES))}, not {self.wrinkling!r}", "wrinkling"
            )
        object.__setattr__(self, "_built", _numeric(self))

    # --- description -------------------------------------------------------------------------
    @property
    def effects(self) -> list[str]:
        """Names of the effects this model simulates."""
        names = [f"elasticity:{self.elasticity.name}"]
        if self.electrostatics.enabled:
            names.append(f"electrostatics:{self.electrostatics.name}")
        if self.prestretch != 1.0:
            names.append("prestretch")
        if self.tension_field:
            names.append("wrinkling:tension-field")
        return names

    @property
    def tension_field(self) -> bool:
        """Whether wrinkled states are relaxed by tension-field theory (``wrinkling="tension-field"``)."""
        return self.wrinkling == "tension-field"

    @property
    def has_voltage(self) -> bool:
        """Whether the electrostatics effect is on (a model without it accepts only ``Φ̂ = 0``)."""
        return bool(self.electrostatics.enabled)

    def describe(self) -> dict:
        """Plain-dict description (material, Jlim, prestretch, effects).

        Returns
        -------
        dict
            The elasticity's :meth:`~coexist.effects.Elasticity.describe` with ``prestretch`` and
            ``effects`` (:attr:`effects`) added.
        """
        out = dict(self.elasticity.describe())
        out["prestretch"] = self.prestretch
        out["wrinkling"] = self.wrinkling
        out["effects"] = self.effects
        return out

    # --- symbolic access (tests and the coexistence solver use these) --------------------------
    def _symbolic(self) -> dict:
        """The CasADi symbols and functions, built on first use (the numeric methods do not need them
        when their generated code comes from the cache)."""
        if "symbolic" not in self._built:
            self._built["symbolic"] = _build(self)
        return self._built["symbolic"]

    @property
    def symbols(self) -> dict:
        """CasADi symbols and expressions: ``l1, l2, phi, W, T1, T2, T11, T12`` and the RHS."""
        return self._symbolic()["symbols"]

    # --- numeric functions (numpy, vectorised) -------------------------------------------------
    def free_energy(self, l1, l2, phi=0.0):
        """``W*(λ1, λ2; Φ̂) = Ws/μ − Φ̂² λ1² λ2² / 2``, the free energy density at fixed voltage over ``μ``.

        Parameters
        ----------
        l1, l2 : float or ndarray
            Meridional and hoop stretches ``λ1``, ``λ2``.
        phi : float or ndarray
            Normalised voltage ``Φ̂``.

        Returns
        -------
        float or ndarray
            ``W*`` per unit reference volume over ``μ``, broadcast shape of the inputs.
        """
        try:
            return self._built["energy"](l1, l2, phi)[0]
        except _RAW_ERRORS as exc:
            raise _argument_error(exc, ("l1", "l2", "phi"), (l1, l2, phi)) from None

    def tensions(self, l1, l2, phi=0.0):
        """``(T̂1, T̂2, ∂T̂1/∂λ1, ∂T̂1/∂λ2, locking margin, Ê, ∂T̂2/∂λ2)`` at given stretches and voltage.

        ``T̂1 = ∂W*/∂λ1``, ``T̂2 = ∂W*/∂λ2`` are the nominal tensions over ``μH``.

        Parameters
        ----------
        l1, l2 : float or ndarray
            Meridional and hoop stretches ``λ1``, ``λ2``.
        phi : float or ndarray
            Normalised voltage ``Φ̂``.

        Returns
        -------
        tuple of 7 float or ndarray
            The quantities above, each of the broadcast shape of the inputs; the locking margin is
            ``1 − (I1 − 3)/Jlim`` (Gent) or 1, the true field ``Ê = Φ̂ λ1 λ2``.
        """
        try:
            return self._built["aux"](l1, l2, phi)
        except _RAW_ERRORS as exc:
            raise _argument_error(exc, ("l1", "l2", "phi"), (l1, l2, phi)) from None

    def rhs(self, R, l1, l2, theta, p, phi):
        """Right-hand side ``(λ1', λ2', θ', V̂'/π, Q̂'/2π, Ψ̂'/2π, ẑ')`` of the membrane equations
        (the quadratures without their constant factors, :data:`QUADRATURE_FACTORS`).

        ``λ1' = (T̂2 cos θ − T̂1 − R̂ ∂T̂1/∂λ2 λ2') / (R̂ ∂T̂1/∂λ1)``, ``λ2' = (λ1 cos θ − λ2)/R̂``,
        ``θ' = (p̂ λ1 λ2 R̂ − T̂2 sin θ) / (R̂ T̂1)``, with ``' = d/dR̂``.

        Parameters
        ----------
        R : float or ndarray
            Reference radius ``R̂ = R/A`` (``> 0``: the equations are singular at the pole).
        l1, l2 : float or ndarray
            Meridional and hoop stretches ``λ1``, ``λ2``.
        theta : float or ndarray
            Angle ``θ`` of the meridian from the horizontal.
        p : float or ndarray
            Normalised pressure ``p̂`` (the trial pressure ``p̂t`` when shooting).
        phi : float or ndarray
            Normalised voltage ``Φ̂``.

        Returns
        -------
        tuple of 7 float or ndarray
            The derivatives above, each of the broadcast shape of the inputs.
        """
        try:
            return self._built["rhs"](R, l1, l2, theta, p, phi)
        except _RAW_ERRORS as exc:
            raise _argument_error(exc, _RHS_ARGUMENTS, (R, l1, l2, theta, p, phi)) from None

    def rhs_into(self, R, l1, l2, theta, p, phi, out):
        """:meth:`rhs` written into the first seven rows of ``out`` (the integrator's hot path).

        Parameters
        ----------
        R, l1, l2, theta, p, phi : float or ndarray
            As for :meth:`rhs`.
        out : ndarray
            At least 7 rows, each broadcastable from the inputs; rows 0–6 are overwritten, the others
            left alone.

        Returns
        -------
        ndarray
            ``out`` itself.
        """
        try:
            return self._built["rhs_into"](R, l1, l2, theta, p, phi, out)
        except _RAW_ERRORS as exc:
            raise _argument_error(exc, (*_RHS_ARGUMENTS, "out"), (R, l1, l2, theta, p, phi, out), 7) from None

    def rhs_sensitivities_into(self, R, l1, l2, theta, p, phi, s_l0, s_phi, out):
        """:meth:`rhs` and the variational equations, written into the first 17 rows of ``out``.

        ``s_l0`` and ``s_phi`` are the sensitivities ``∂(λ1, λ2, θ)/∂λ0`` and ``∂(λ1, λ2, θ)/∂Φ̂`` of the
        trajectory (three rows each); rows 7–11 of ``out`` receive ``d/dR̂ ∂(λ1, λ2, θ, V̂/π, Q̂/2π)/∂λ0``
        and rows 12–16 the same for ``Φ̂``: ``S' = (∂f/∂y) S`` and ``S' = (∂f/∂y) S + ∂f/∂Φ̂``.

        Parameters
        ----------
        R, l1, l2, theta, p, phi : float or ndarray
            As for :meth:`rhs`.
        s_l0 : sequence of 3 ndarray
            ``∂(λ1, λ2, θ)/∂λ0`` at fixed ``R̂``.
        s_phi : sequence of 3 ndarray
            ``∂(λ1, λ2, θ)/∂Φ̂`` at fixed ``R̂``.
        out : ndarray
            At least 17 rows; rows 0–16 are overwritten, the others left alone.

        Returns
        -------
        ndarray
            ``out`` itself.
        """
        try:
            return self._built["rhs_sens_into"](R, l1, l2, theta, p, phi, *s_l0, *s_phi, out)
        except _RAW_ERRORS as exc:
            names, args = (*_RHS_ARGUMENTS, "s_l0", "s_phi", "out"), (R, l1, l2, theta, p, phi, s_l0, s_phi, out)
            raise _argument_error(exc, names, args, 17) from None

    def series_start(self, l0, p_trial, phi, R0):
        """The series start at the pole and its derivatives (docs/physics.md).

        Returns 17 arrays: the seven integrated rows at ``R̂0`` for trial pressure ``p̂t``
        (``λ1, λ2, θ, V̂/π, Q̂/2π, Ψ̂/2π, ẑ``), then ``∂/∂λ0`` and ``∂/∂Φ̂`` of the first five.

        The series: ``θ = cR̂``, ``λ1 = λ0 + aR̂²``, ``λ2 = λ0 + bR̂²`` with ``c = p̂t λ0² / (2 T̂0)``,
        ``b = −c² (T̂0 + (3α − β) λ0) / (16 α)``, ``a = λ0 c²/2 + 3b`` (:meth:`pole` gives ``T̂0, α, β``).

        Parameters
        ----------
        l0 : float or ndarray
            Pole stretch ``λ0``.
        p_trial : float or ndarray
            Trial pressure ``p̂t``.
        phi : float or ndarray
            Normalised voltage ``Φ̂``.
        R0 : float or ndarray
            Radius ``R̂0`` at which the series hands over to the integrator.

        Returns
        -------
        tuple of 17 float or ndarray
            The rows above, each of the broadcast shape of the inputs.
        """
        try:
            return self._built["series"](l0, p_trial, phi, R0)
        except _RAW_ERRORS as exc:
            raise _argument_error(exc, ("l0", "p_trial", "phi", "R0"), (l0, p_trial, phi, R0)) from None

    # --- hoop-wrinkled segments (tension-field models only) --------------------------------------
    def _wrinkled(self, name: str):
        if name not in self._built:
            raise SceneError(
                f"this model refuses wrinkled states (wrinkling={self.wrinkling!r}); {name} needs 'tension-field'",
                "wrinkling",
            )
        return self._built[name]

    def wrinkled_rhs(self, R, l1, rho, theta, p, phi, width):
        """Right-hand side of a hoop-wrinkled segment, ``(λ1', ρ', θ', V̂'/π, Q̂'/2π, Ψ̂'/2π, ẑ', w')``.

        ``λ1' = −T̂1/(R̂K)``, ``ρ' = (λ1 cos θ − ρ)/R̂``, ``θ' = p̂λ1ρ/T̂1`` with the tensions and
        ``K = T̂11 − T̂12²/T̂22`` at the natural width ``w`` (``T̂2(λ1, w) = 0``); the quadratures use the
        geometric hoop stretch ``ρ`` (volume, height) and the material one ``w`` (charge, energy).
        ``w' = −(T̂12/T̂22) λ1'``. Only for a tension-field model.

        Parameters
        ----------
        R, l1, theta, p, phi : float or ndarray
            As for :meth:`rhs`.
        rho : float or ndarray
            Geometric hoop stretch ``ρ = r̂/R̂``.
        width : float or ndarray
            The natural width ``w = λ2*(λ1; Φ̂)`` (:func:`coexist.wrinkling.natural_width`).

        Returns
        -------
        tuple of 8 float or ndarray
        """
        function = self._wrinkled("wrinkled_rhs")
        try:
            return function(R, l1, rho, theta, p, phi, width)
        except _RAW_ERRORS as exc:
            raise _argument_error(exc, _WRINKLED_ARGUMENTS, (R, l1, rho, theta, p, phi, width)) from None

    def wrinkled_rhs_sensitivities(self, R, l1, rho, theta, p, phi, width, s_l0, s_phi):
        """:meth:`wrinkled_rhs` with the variational equations (total derivatives through ``w``).

        Returns 18 rows: the seven of :meth:`wrinkled_rhs`, then ``d/dR̂ ∂(λ1, ρ, θ, V̂/π, Q̂/2π)/∂λ0``,
        the same for ``Φ̂`` (``S' = J S`` and ``S' = J S + ∂f/∂Φ̂`` with ``J = ∂f/∂(λ1, ρ, θ)`` at
        ``w = w(λ1, Φ̂)``), then ``w'``.

        Parameters
        ----------
        R, l1, rho, theta, p, phi, width : float or ndarray
            As for :meth:`wrinkled_rhs`.
        s_l0, s_phi : sequence of 3 ndarray
            ``∂(λ1, ρ, θ)/∂λ0`` and ``∂(λ1, ρ, θ)/∂Φ̂`` at fixed ``R̂``.

        Returns
        -------
        tuple of 18 float or ndarray
        """
        function = self._wrinkled("wrinkled_rhs_sens")
        try:
            return function(R, l1, rho, theta, p, phi, width, *s_l0, *s_phi)
        except _RAW_ERRORS as exc:
            names, args = (*_WRINKLED_ARGUMENTS, "s_l0", "s_phi"), (R, l1, rho, theta, p, phi, width, s_l0, s_phi)
            raise _argument_error(exc, names, args) from None

    def wrinkle_aux(self, l1, l2, phi=0.0):
        """``(∂T̂2/∂Φ̂, K, dw/dλ1, dw/dΦ̂)`` at ``(λ1, λ2)``; the last three mean something at ``λ2 = w``.

        ``K = T̂11 − T̂12²/T̂22`` (``dT̂1/dλ1`` along the natural width: ``K > 0`` or the wrinkled membrane
        pulls in), ``dw/dλ1 = −T̂12/T̂22``, ``dw/dΦ̂ = −(∂T̂2/∂Φ̂)/T̂22``. Only for a tension-field model.

        Parameters
        ----------
        l1, l2, phi : float or ndarray

        Returns
        -------
        tuple of 4 float or ndarray
        """
        function = self._wrinkled("wrinkle_aux")
        try:
            return function(l1, l2, phi)
        except _RAW_ERRORS as exc:
            raise _argument_error(exc, ("l1", "l2", "phi"), (l1, l2, phi)) from None

    @property
    def casadi_functions(self) -> dict:
        """The CasADi functions the numpy code is generated from (``rhs``, ``rhs_sens``, ``aux``, ...)."""
        return self._symbolic()["casadi"]

    def pole(self, l0, phi=0.0):
        """Pole quantities ``(T0, α, β, W0, q0)``: tension, its stretch derivatives, energy, charge density.

        All at the equibiaxial pole state ``λ1 = λ2 = λ0``: ``T̂0 = T̂1``, ``α = ∂T̂1/∂λ1``,
        ``β = ∂T̂1/∂λ2``, ``W*`` and ``q̂``.

        Parameters
        ----------
        l0 : float or ndarray
            Pole stretch ``λ0``.
        phi : float or ndarray
            Normalised voltage ``Φ̂``.

        Returns
        -------
        tuple of 5 float or ndarray
            ``(T̂0, α, β, W0*, q̂0)``, each of the broadcast shape of the inputs.
        """
        try:
            return self._built["pole"](l0, phi)
        except _RAW_ERRORS as exc:
            raise _argument_error(exc, ("l0", "phi"), (l0, phi)) from None


_RHS_ARGUMENTS = ("R", "l1", "l2", "theta", "p", "phi")
_WRINKLED_ARGUMENTS = ("R", "l1", "rho", "theta", "p", "phi", "width")
#: what numpy and Python raise for a bad argument of a generated function (None, text, a list, shapes that do not
#: broadcast, an ``out`` too small)
_RAW_ERRORS = (TypeError, ValueError, IndexError)


def _argument_error(error: Exception, names: tuple, args: tuple, rows: int = 0) -> Exception:
    """The SceneError naming the argument of a numeric method that caused ``error`` (raised by its generated function),
    or ``error`` itself where every argument is right. Looked for only once the call has failed: the integrator's hot
    path pays nothing for it.

    Parameters
    ----------
    error : Exception
        What the call raised.
    names, args : tuple
        The arguments' names and values; ``s_l0`` and ``s_phi`` are sequences of three arrays.
    rows : int
        The rows an ``out`` argument needs.

    Returns
    -------
    Exception
        A :class:`~coexist.errors.SceneError` for the first argument that is not a real number or a numpy array of
        them (a sequence of three such for ``s_l0``, ``s_phi``), for shapes that do not broadcast, or for an ``out``
        that is not a float array of at least ``rows`` rows of the broadcast shape; else ``error``.
    """
    from .validation import _describe

    shapes = {}
    for name, value in zip(names, args):
        if name == "out":
            continue
        if name in ("s_l0", "s_phi"):
            if isinstance(value, (str, bytes)) or not hasattr(value, "__len__") or len(value) != 3:
                return SceneError(f"must be a sequence of 3 numpy arrays, got {_describe(value)}", name)
            items = {f"{name}[{i}]": v for i, v in enumerate(value)}
        else:
            items = {name: value}
        for key, v in items.items():
            if not (v.dtype.kind in "iuf" if isinstance(v, np.ndarray) else isinstance(v, numbers.Real)):
                hint = " (pass np.asarray(...))" if isinstance(v, (list, tuple)) else ""
                return SceneError(
                    f"must be a real number or a numpy array of them, got {type(v).__name__} {_describe(v)}{hint}", key
                )
            shapes[key] = np.shape(v)
    try:
        shape = np.broadcast_shapes(*shapes.values())
    except ValueError:
        return SceneError(
            f"shapes {', '.join(map(str, shapes.values()))} do not broadcast (give one value or arrays of one shape)",
            ", ".join(shapes),
        )
    if "out" in names:
        out = args[names.index("out")]
        fits = isinstance(out, np.ndarray) and out.dtype.kind == "f" and out.ndim >= 1 and out.shape[0] >= rows
        try:
            fits = fits and np.broadcast_shapes(shape, out.shape[1:]) == out.shape[1:]
        except ValueError:
            fits = False
        if not fits:
            got = f"shape {out.shape}" if isinstance(out, np.ndarray) else f"{type(out).__name__} {_describe(out)}"
            return SceneError(f"must be a float array of at least {rows} rows of shape {shape}, got {got}", "out")
    return error


def _build(model: MembraneModel) -> dict:
    l1, l2, th, R, p, phi = (ca.SX.sym(n) for n in ("l1", "l2", "theta", "R", "p", "phi"))
    # W*(I, K): elasticity as a function of I = I1 − 3, electrostatics of K = λ1²λ2²; tensions by
    # the chain rule through the invariants, every derivative taken symbolically by CasADi
    I_s, K_s = ca.SX.sym("I"), ca.SX.sym("K")
    I_expr, K_expr = first_invariant(l1, l2), area_invariant(l1, l2)
    w = model.elasticity.energy_of_invariant(I_s)
    e = model.electrostatics.energy_of_invariant(K_s, phi)
    # half-derivatives of the invariants (closed form); the factors 2 and 4 go onto the energy's
    # derivatives, where they fold with its constants (a neo-Hookean 2·∂w/∂I is exactly 1)
    w_I2 = 2 * ca.gradient(w, I_s)
    w_II4 = 2 * ca.gradient(w_I2, I_s)
    g1, g2, h11, h12 = first_invariant_derivatives(l1, l2)
    W_inv = w
    T1_inv = w_I2 * g1
    T2_inv = w_I2 * g2
    T11_inv = w_II4 * g1 * g1 + w_I2 * h11
    T12_inv = w_II4 * g1 * g2 + w_I2 * h12
    # the electrostatic terms (constant zero when the effect is off: CasADi folds them away)
    e_K2 = 2 * ca.gradient(e, K_s)
    e_KK4 = 2 * ca.gradient(e_K2, K_s)
    k1, k2, k11, k12 = area_invariant_derivatives(l1, l2)
    W_inv = W_inv + e
    T1_inv = T1_inv + e_K2 * k1
    T2_inv = T2_inv + e_K2 * k2
    T11_inv = T11_inv + e_KK4 * k1 * k1 + e_K2 * k11
    T12_inv = T12_inv + e_KK4 * k1 * k2 + e_K2 * k12
    W, T1, T2, T11, T12 = (
        ca.substitute(x, ca.vertcat(I_s, K_s), ca.vertcat(I_expr, K_expr))
        for x in (W_inv, T1_inv, T2_inv, T11_inv, T12_inv)
    )
    margin = ca.SX(model.elasticity.locking_margin(l1, l2))
    q = ca.SX(model.electrostatics.charge_density(l1, l2, phi))
    E = ca.SX(model.electrostatics.field(l1, l2, phi))
    c, s = ca.cos(th), ca.sin(th)
    R_dl2 = l1 * c - l2  # R λ2'
    dl2 = R_dl2 / R
    dl1 = (T2 * c - T1 - T12 * R_dl2) / (R * T11)
    dth = (p * l1 * l2 * R - T2 * s) / (R * T1)
    # quadratures without their constant factors (QUADRATURE_FACTORS restores them after integration)
    dV = (l2 * R) ** 2 * l1 * s
    dQ = q * R
    dPsi = W * R
    dz = l1 * s
    l0 = ca.SX.sym("l0")

    def sub(expr):
        return ca.substitute(expr, ca.vertcat(l1, l2), ca.vertcat(l0, l0))

    rhs = ca.Function("membrane_rhs", [R, l1, l2, th, p, phi], [dl1, dl2, dth, dV, dQ, dPsi, dz])
    # variational equations: S' = (∂f/∂x) S (+ ∂f/∂Φ̂) for the sensitivities S = ∂(λ1, λ2, θ, V̂, Q̂)/∂a of
    # the trajectory to the pole stretch (a = λ0, through the start only) and to the voltage (a = Φ̂);
    # V̂ and Q̂ are quadratures and do not feed back, so only (λ1, λ2, θ) enter the products
    x = ca.vertcat(l1, l2, th)
    sens_rows = ca.vertcat(dl1, dl2, dth, dV, dQ)
    s_l0 = [ca.SX.sym(f"s_l0_{n}") for n in ("l1", "l2", "theta")]
    s_phi = [ca.SX.sym(f"s_phi_{n}") for n in ("l1", "l2", "theta")]
    ds_l0 = ca.jtimes(sens_rows, x, ca.vertcat(*s_l0))
    ds_phi = ca.jtimes(sens_rows, x, ca.vertcat(*s_phi)) + ca.jacobian(sens_rows, phi)
    # (densified: without electrostatics the voltage derivatives are structural zeros)
    rhs_sens = ca.Function(
        "membrane_rhs_sensitivities",
        [R, l1, l2, th, p, phi, *s_l0, *s_phi],
        [dl1, dl2, dth, dV, dQ, dPsi, dz, *ca.vertsplit(ca.densify(ds_l0)), *ca.vertsplit(ca.densify(ds_phi))],
    )
    # the series start at the pole (derived in docs/physics.md): θ = cR, λ1 = λ0 + aR², λ2 = λ0 + bR²,
    # with its derivatives to λ0 and Φ̂ (the sensitivities' initial values)
    pt, R0 = ca.SX.sym("p_trial"), ca.SX.sym("R0")
    T0, al, be, W0, q0 = sub(T1), sub(T11), sub(T12), sub(W), sub(q)
    c_ = pt * l0**2 / (2 * T0)
    b_ = -(c_**2) * (T0 + (3 * al - be) * l0) / (16 * al)
    a_ = l0 * c_**2 / 2 + 3 * b_
    y0 = ca.vertcat(
        l0 + a_ * R0**2,
        l0 + b_ * R0**2,
        c_ * R0,
        l0**3 * c_ * R0**4 / 4,
        q0 * R0**2 / 2,
        W0 * R0**2 / 2,
        l0 * c_ * R0**2 / 2,
    )
    y0_s = y0[:5]
    series = ca.Function(
        "membrane_series",
        [l0, pt, phi, R0],
        [
            *ca.vertsplit(ca.densify(y0)),
            *ca.vertsplit(ca.densify(ca.jacobian(y0_s, l0))),
            *ca.vertsplit(ca.densify(ca.jacobian(y0_s, phi))),
        ],
    )
    T22 = ca.gradient(T2, l2)  # for the slope of the hoop tension along the meridian (dT2/dR)
    aux = ca.Function("membrane_aux", [l1, l2, phi], [T1, T2, T11, T12, margin, E, T22])
    energy = ca.Function("membrane_energy", [l1, l2, phi], [W])
    pole = ca.Function("membrane_pole", [l0, phi], [sub(T1), sub(T11), sub(T12), sub(W), sub(q)])
    casadi_fns = {"rhs": rhs, "aux": aux, "energy": energy, "pole": pole, "rhs_sens": rhs_sens, "series": series}
    if model.tension_field:
        casadi_fns.update(_wrinkled_functions(R, l1, l2, th, p, phi, W, T1, T2, T11, T12, T22, q))
    return {
        "symbols": {
            "l1": l1,
            "l2": l2,
            "theta": th,
            "R": R,
            "p": p,
            "phi": phi,
            "W": W,
            "T1": T1,
            "T2": T2,
            "T11": T11,
            "T12": T12,
            "q": q,
            "E": E,
            "rhs": ca.vertcat(dl1, dl2, dth, dV, dQ, dPsi, dz),
        },
        "casadi": casadi_fns,
    }


def _wrinkled_functions(R, l1, l2, th, p, phi, W, T1, T2, T11, T12, T22, q) -> dict:
    """The CasADi functions of a hoop-wrinkled segment (docs/physics.md section 10).

    The material hoop stretch is the natural width ``w = λ2*(λ1; Φ̂)`` (``T̂2(λ1, w) = 0``), an input
    here (:mod:`coexist.wrinkling` solves for it); ``ρ = r̂/R̂`` is the geometric hoop stretch. With
    ``K = T̂11 − T̂12²/T̂22`` at ``(λ1, w)``:

    ``λ1' = −T̂1/(R̂K)``, ``ρ' = (λ1 cos θ − ρ)/R̂``, ``θ' = p̂ λ1 ρ / T̂1``, ``V̂'/π = (ρR̂)² λ1 sin θ``,
    ``Q̂'/2π = q̂(λ1, w) R̂``, ``Ψ̂'/2π = W*(λ1, w) R̂``, ``ẑ' = λ1 sin θ``, and ``w' = (dw/dλ1) λ1'``
    (the width's own row, a starting guess for its Newton polish) with ``dw/dλ1 = −T̂12/T̂22``,
    ``dw/dΦ̂ = −(∂T̂2/∂Φ̂)/T̂22``. The variational equations use total derivatives through ``w``.
    """
    w, rho = ca.SX.sym("w"), ca.SX.sym("rho")

    def at_w(expr):
        return ca.substitute(expr, l2, w)

    T1w, T2w, T11w, T12w, T22w, Ww, qw = (at_w(x) for x in (T1, T2, T11, T12, T22, W, q))
    T2_phi = ca.jacobian(T2, phi)
    K = T11w - T12w * T12w / T22w
    c, s = ca.cos(th), ca.sin(th)
    dl1 = -T1w / (R * K)
    drho = (l1 * c - rho) / R
    dth = p * l1 * rho / T1w
    dV = (rho * R) ** 2 * l1 * s
    dQ = qw * R
    dPsi = Ww * R
    dz = l1 * s
    dw_dl1 = -T12w / T22w
    dw_dphi = -at_w(T2_phi) / T22w
    dw = dw_dl1 * dl1
    rows = ca.vertcat(dl1, drho, dth, dV, dQ)
    x = ca.vertcat(l1, rho, th)
    J_w = ca.jacobian(rows, w)
    J_x = ca.jacobian(rows, x) + ca.horzcat(J_w * dw_dl1, ca.SX.zeros(5, 2))
    J_phi = ca.jacobian(rows, phi) + J_w * dw_dphi
    s_l0 = [ca.SX.sym(f"s_l0_{n}") for n in ("l1", "rho", "theta")]
    s_phi = [ca.SX.sym(f"s_phi_{n}") for n in ("l1", "rho", "theta")]
    ds_l0 = ca.mtimes(J_x, ca.vertcat(*s_l0))
    ds_phi = ca.mtimes(J_x, ca.vertcat(*s_phi)) + J_phi
    args = [R, l1, rho, th, p, phi, w]
    state = [dl1, drho, dth, dV, dQ, dPsi, dz]
    return {
        "wrinkled_rhs": ca.Function("wrinkled_rhs", args, [ca.densify(x) for x in (*state, dw)]),
        "wrinkled_rhs_sens": ca.Function(
            "wrinkled_rhs_sensitivities",
            [*args, *s_l0, *s_phi],
            [
                *(ca.densify(x) for x in state),
                *ca.vertsplit(ca.densify(ds_l0)),
                *ca.vertsplit(ca.densify(ds_phi)),
                ca.densify(dw),
            ],
        ),
        # at any (λ1, λ2): ∂T̂2/∂Φ̂ (the hoop tension's voltage slope, for the switch's saltation), and at
        # λ2 = w: K = dT̂1/dλ1 along the natural width, dw/dλ1, dw/dΦ̂
        "wrinkle_aux": ca.Function(
            "wrinkle_aux",
            [l1, l2, phi],
            [ca.densify(x) for x in (T2_phi, *(ca.substitute(x, w, l2) for x in (K, dw_dl1, dw_dphi)))],
        ),
    }


#: the model's numpy functions: (name, CasADi function it translates, writes into ``out``)
_NUMPY_FUNCTIONS = (
    ("rhs", "rhs", False),
    ("rhs_into", "rhs", True),
    ("rhs_sens_into", "rhs_sens", True),
    ("series", "series", False),
    ("aux", "aux", False),
    ("energy", "energy", False),
    ("pole", "pole", False),
)
#: generated only for a tension-field model (:func:`_wrinkled_functions`)
_WRINKLED_NUMPY_FUNCTIONS = (
    ("wrinkled_rhs", "wrinkled_rhs", False),
    ("wrinkled_rhs_sens", "wrinkled_rhs_sens", False),
    ("wrinkle_aux", "wrinkle_aux", False),
)
#: the library's source files that determine the generated numpy code (part of its cache key)
_GENERATOR_SOURCES = ("model.py", "effects.py", "numerics/codegen.py")


def model_cache_key(model: MembraneModel) -> str | None:
    """The key of a model's generated code in the disk cache (:mod:`coexist.numerics.cache`).

    Parameters
    ----------
    model : MembraneModel
        The model.

    Returns
    -------
    str or None
        A key standing for the effects (their classes and parameters), the prestretch and the
        library's generating source files; None when an effect is not one of :mod:`coexist.effects`
        (a user's class may change without a change of key, so its code is never cached).
    """
    effects = (model.elasticity, model.electrostatics)
    if any(type(e).__module__ != "coexist.effects" for e in effects):
        return None
    return cache.key(
        "membrane_model",
        tuple(f"{type(e).__qualname__}:{e!r}" for e in effects),
        repr(float(model.prestretch)),
        model.wrinkling,
        cache.source_digest(_GENERATOR_SOURCES),
    )


def _numeric(model: MembraneModel) -> dict:
    """The numpy functions of ``model``, generated from its CasADi functions, or loaded from the disk
    cache when an earlier process generated them."""

    functions = _NUMPY_FUNCTIONS + (_WRINKLED_NUMPY_FUNCTIONS if model.tension_field else ())

    def source() -> str:
        fns = model._symbolic()["casadi"]
        return numpy_module_source((name, fns[c], into) for name, c, into in functions)

    key = model_cache_key(model)
    if key is None:
        namespace: dict = {}
        exec(compile(source(), "<coexist generated membrane model>", "exec"), namespace)
    else:
        namespace = cache.python_module("membrane_model", key, source)
    # a few states at a time go through the float variants (numpy's per-operation cost dominates there)
    return {name: small_batch(namespace[name], namespace[name + SCALAR_SUFFIX], into) for name, _, into in functions}


def build_model(
    material: str = "neo-hookean",
    jlim: float | None = None,
    voltage: bool = True,
    prestretch: float = 1.0,
    wrinkling: str = "refuse",
) -> MembraneModel:
    """Convenience constructor from plain values (what the command line uses).

    Parameters
    ----------
    material : str
        ``neo-hookean`` or ``gent`` (:func:`~coexist.effects.material_from_name`).
    jlim : float, optional
        ``Jlim`` of the Gent material (required for ``gent``).
    voltage : bool
        With electrostatics (:class:`~coexist.effects.IdealDielectric`) or without
        (:class:`~coexist.effects.NoElectrostatics`).
    prestretch : float
        Equibiaxial prestretch ``1 ≤ λpre ≤`` :data:`MAX_PRESTRETCH`.
    wrinkling : {"refuse", "tension-field"}
        See :class:`MembraneModel`.

    Returns
    -------
    MembraneModel

    Raises
    ------
    SceneError
        For an unknown material, a Gent material without a positive ``jlim``, a ``prestretch`` below 1 or above
        :data:`MAX_PRESTRETCH`, or a ``voltage`` that is not a bool.
    """
    from .effects import material_from_name

    if type(voltage).__name__ not in ("bool", "bool_"):  # Python's bool, numpy's (np.bool_, np.bool)
        # "no" is truthy: it had given a model with electrostatics (helper-97)
        raise SceneError(f"voltage must be True or False, got {voltage!r}", "voltage")
    return MembraneModel(
        elasticity=material_from_name(material, jlim),
        electrostatics=IdealDielectric() if voltage else NoElectrostatics(),
        prestretch=prestretch,  # MembraneModel checks it (a number ≥ 1, not a bool or text)
        wrinkling=wrinkling,
    )
