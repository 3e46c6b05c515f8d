"""Patterned and layered zones: a clamped disc of concentric regions, each with its own electrode and layers.

A zone is made, from the pole out, of regions ``0 ≤ R̂ < f1 < f2 < … < fK = 1`` (radius fractions in the
reference state). Region ``k`` is a stack of ``nk`` identical layers (a thickness multiple of the one-layer
membrane) and carries an electrode on the outer faces of its stack or none. A region of ``n`` layers is the
one-layer membrane with ``p̂ → p̂/n`` and ``Φ̂ → Φ̂/n`` (``Φ̂ → 0`` without electrode); its charge per reference
area is ``q̂(λ1, λ2; Φ̂/n)`` and its free energy ``n W*(λ1, λ2; Φ̂/n)`` (docs/physics.md, section 12).

At an interface ``R̂i`` the radius, the height and the slope are continuous, so ``λ2 = r̂/R̂`` and ``θ`` are;
the meridional force per reference hoop length is continuous, ``n⁻ T̂1(λ1⁻, λ2; Φ̂⁻) = n⁺ T̂1(λ1⁺, λ2; Φ̂⁺)``,
which fixes ``λ1⁺`` (:func:`interface_stretch`, a safeguarded vectorised Newton iteration).

**Shooting.** The ``R → cR, p → p/c`` invariance of the equations holds region by region, but it moves the
interfaces with the clamp: one integration at a trial pressure ``p̂t`` gives a clamped membrane whose interfaces
sit where they were put, not at their fractions of the clamp radius ``R*``. So the interfaces are put at
``R̂i = s fi`` and ``s`` is solved for, per state, until ``R*(s) = s`` (then the interface lands at ``fi R*``,
and the unit membrane carries ``p̂ = p̂t R*`` as for a uniform zone). By the scaling this is the same as a
Newton iteration on the trial pressure with the interfaces held at ``fi``; solving for ``s`` at fixed ``p̂t``
keeps the pole region's series start fixed. The residual ``G(σ) = ln R*(e^σ) − σ`` has the slope ``−1`` for a
uniform zone; its exact slope ``(s/R*) dR*/ds − 1`` comes from the sensitivity ``S = ∂(λ1, λ2, θ)/∂s`` of the
trajectory, which is zero in the pole region, gets ``S⁺ = D(S⁻ + f⁻ fi) − f⁺ fi`` at every interface (``D`` the
Jacobian of the jump, ``f∓`` the right-hand sides on the two sides) and is carried by the variational equations
``S' = (∂f/∂y) S`` in between; at the clamp ``dR*/ds = −S_λ2/λ2'``. All states of a call are iterated together
(vectorised DOP853, :func:`coexist.numerics.dop853.integrate`); a state whose iterate fails (a trajectory that
turns back, a jump without a stable root, no clamp) backtracks towards its last good iterate; no iterate goes below
the scale at which the zone is flat (:data:`SCALE_FLOOR`: a state still too large there is below the flat zone's pole
stretch, ``BELOW_FLAT``). The passes of one iteration share what does not depend on ``s`` (:class:`_Warm`): the
pole region is integrated once to just below its interface and taken up from there by the later passes (a step or
two), each jump starts from the last pass's ``λ1⁺``, and a pass integrates the variational equations (the slope)
only where the last residual exceeded :data:`SLOPE_AGAIN` (elsewhere the last slope serves: off by ``O(|Δσ|)``,
the step's error is ``O(|Δσ| |G|)``). A region's first step is given, not estimated (Hairer's estimate costs two
numpy evaluations of the right-hand side per call): the series radius from the pole (as the uniform shooting),
:data:`OUTER_FIRST_STEP` ``R̂i`` after an interface; the step control corrects it within an attempt or two. A
landing step onto the clamp that is rejected is taken in two halves by the compiled step function
(:func:`_in_halves`). The stopping rule is unchanged: a state is returned from a pass whose own residual is
``|G| ≤ rtol``.

A pattern with one region is a uniform zone: it is :func:`coexist.shooting.solve_states` with the scaled
pressure and voltage (``p̂ = n p̂1``, ``Ψ̂ = n Ψ̂1``).

Validity is checked on the converged state only (its iterates may pass through compressed states). The smallest
stack tension is taken over the nodes, both sides of every interface and the steps between nodes: the cubic
Hermite estimate from the exact slopes ``dT/dR̂``, and where that comes below
:data:`~coexist.shooting.REFINE_MINIMUM_BELOW` the minimum located exactly (the root of ``dT/dR̂`` inside the step,
each iterate one step of the integrator, :func:`_exact_minimum`), as :func:`coexist.shooting.solve_states` does:
so a formally continued state's smallest tension is a smooth function of ``(λ0, Φ̂)`` to the integration's
accuracy and the onset of wrinkling is located like a uniform zone's. A tension
that is not positive anywhere — notably the hoop tension on the electrode side of an electrode edge, where
the passive membrane holds back the active one at low inflation — gives status ``WRINKLED`` and a sentence
saying which tension, where and how negative (:attr:`PatternedStates.failure_detail`); a patterned zone
refuses wrinkled states (a tension-field :class:`PatternedModel` shoots them again relaxed,
:mod:`coexist.patterned_relaxed`).
"""

from __future__ import annotations

import math
import numbers
import threading
from dataclasses import dataclass, field

import numpy as np

from . import validation
from .curves import Curve, _slopes_along, _trace
from .errors import SceneError
from .model import QUADRATURE_FACTORS, MembraneModel
from .numerics import dop853 as _int
from .settings import SolverSettings, error_reference
from .shooting import (
    BELOW_FLAT,
    BELOW_RESOLUTION,
    BEYOND_RUN,
    FLAT_LIMIT,
    FOLDED_BACK,
    LOCKED,
    LOCKING_LIMIT,
    LOST_ELLIPTICITY,
    NO_CLAMP,
    NOT_FINITE,
    OK,
    ROUNDOFF_TOLERANCE,
    STEP_LIMIT,
    WRINKLED,
    WRINKLED_AT_POLE,
    MembraneStates,
    StateDerivatives,
    _integrators,
    checked_state_inputs,
    clamped_derivatives,
    first_valid_run,
    reason_tag,
    reason_text,
    solve_states,
    trial_pressure,
)

__all__ = [
    "PatternedModel",
    "PatternedStates",
    "Region",
    "ScaleStarts",
    "ZonePattern",
    "interface_stretch",
    "patterned_pressure_volume_curve",
    "solve_patterned_states",
]

#: most layers a region may have (a stack of more is no longer a membrane of this model's kind)
MAX_LAYERS = 100
#: Newton iterations on the interface scale ``σ = ln s`` per state at most (failed iterates included)
MAX_SCALE_ITERATIONS = 30
#: largest change of ``σ`` in one Newton step (a factor e^0.5 of the interface scale)
MAX_SCALE_STEP = 1.0
#: the last region is integrated to at most this many times the interface scale ``s`` (the converged clamp is
#: at ``R* = s``; a trajectory that has not reached the clamp there tells the iteration to grow ``s``)
LAST_REGION_REACH = 8.0
#: internal codes of an iterate (never a state's status): the clamp stretch reached before the last region
#: (``s`` too large), the clamp not reached within LAST_REGION_REACH·s (``s`` too small)
_EARLY_CLAMP = 90
_FAR_CLAMP = 91
#: a slope ``dG/dσ`` above this is not trusted as a hint (an interpolated slope, :func:`_join`), nor is an exact slope
#: that is not negative (the step then uses ``−1``, the uniform zone's slope). An exact slope between this and 0 is
#: used: near the flat end of a curve ``G ≈ a − b s²`` (``a ∝ λ0 − λflat``), the slope at the root is ``≈ −2a``,
#: and steps of ``−G`` instead of ``−G/slope`` crawled (30 passes of ~1e-2 where a step of ~1 was needed: the states
#: within ~3e-3 of the flat pole stretch were lost as NO_CLAMP)
SLOPE_CEILING = -0.05
#: a Newton pass computes the slope ``dG/dσ`` only where the last residual ``|G|`` exceeded this (or there is no
#: slope yet); elsewhere the last pass's slope serves (it is off by ``O(|Δσ|)``, so the step's error is
#: ``O(|Δσ| |G|)``, far below the tolerance after one more pass) and the pass integrates no variational equations
SLOPE_AGAIN = 1e-3
#: a slope interpolated from converged neighbours (a curve's hint, :func:`_newton`) serves the Newton steps of a
#: state while its residual stays at or below this; above, its error (relative ``~1e-3`` or worse where the scale
#: bends) would cost passes, and the pass integrates the variational equations
HINTED_SLOPE_AGAIN = 1e-6
#: a state started from a kept neighbour (:class:`ScaleStarts`) is accepted on its first pass only where its residual
#: is at most this fraction of the tolerance (:func:`_newton`); elsewhere one more Newton step
WARM_FIRST_RESIDUAL = 1e-2
#: iterates of one state that may fail (a trajectory that stops: no meridional tension, loss of ellipticity, ...)
#: before the state is given up with that failure
MAX_FAILED_TRIALS = 6
#: Newton iterations of the interface jump ``λ1⁺`` at most
JUMP_ITERATIONS = 60


# --- the pattern ----------------------------------------------------------------------------------------


@dataclass(frozen=True)
class Region:
    """One annulus of a patterned zone (or its central disc).

    Parameters
    ----------
    outer : float
        Outer radius as a fraction of the zone radius ``A`` in the reference state, in ``(0, 1]``.
    layers : int
        Number of identical layers of the stack (its thickness is ``layers · H``), 1 to :data:`MAX_LAYERS`.
    electrode : bool
        Whether the region carries the electrode (on the outer faces of its stack) and so the voltage.
    """

    outer: float
    layers: int = 1
    electrode: bool = True

    def describe(self) -> str:
        """A few words about the region.

        Returns
        -------
        str
            ``"electrode, 1 layer"``, ``"passive, 2 layers"``, ...
        """
        kind = "electrode" if self.electrode else "passive"
        return f"{kind}, {self.layers} layer{'s' if self.layers != 1 else ''}"


def _region(value, i: int) -> Region:
    name = f"pattern.regions[{i}]"
    if isinstance(value, Region):
        outer, layers, electrode = value.outer, value.layers, value.electrode
    elif isinstance(value, (tuple, list)) and len(value) == 3:
        outer, layers, electrode = value
    else:
        raise SceneError(f"must be a Region or a tuple (outer, layers, electrode), got {value!r}", name)
    outer = validation.real(outer, f"{name}.outer", lo=0.0, lo_open=True, hi=1.0)
    if isinstance(layers, (bool, np.bool_)) or not isinstance(layers, numbers.Integral):
        raise SceneError(f"must be a whole number of layers, got {layers!r}", f"{name}.layers")
    if not 1 <= int(layers) <= MAX_LAYERS:
        raise SceneError(f"must lie in 1..{MAX_LAYERS}, got {layers!r}", f"{name}.layers")
    if not isinstance(electrode, (bool, np.bool_)):
        raise SceneError(f"must be True or False, got {electrode!r}", f"{name}.electrode")
    return Region(outer, int(layers), bool(electrode))


@dataclass(frozen=True)
class ZonePattern:
    """Concentric regions of a zone, from the pole out, each with its layers and electrode.

    Parameters
    ----------
    regions : sequence of Region or of (outer, layers, electrode)
        Outer radius fractions strictly increasing, the last exactly 1 (the clamp).

    Raises
    ------
    SceneError
        Naming the field (``pattern.regions[i].outer`` etc.) when a fraction is not in ``(0, 1]``, the
        fractions do not increase or do not end at 1, a layer count is not a whole number in
        ``1..MAX_LAYERS``, or an electrode flag is not a bool.

    Examples
    --------
    >>> ZonePattern.inner_circle(0.5, passive_layers=2).regions
    (Region(outer=0.5, layers=1, electrode=True), Region(outer=1.0, layers=2, electrode=False))
    """

    regions: tuple

    def __post_init__(self):
        raw = self.regions
        if isinstance(raw, (str, bytes)) or not hasattr(raw, "__len__") or len(raw) == 0:
            raise SceneError(f"must be a non-empty sequence of regions, got {raw!r}", "pattern.regions")
        regions = tuple(_region(r, i) for i, r in enumerate(raw))
        for i in range(1, len(regions)):
            if regions[i].outer <= regions[i - 1].outer:
                raise SceneError(
                    f"outer radius fractions must increase from the pole out: {regions[i].outer:g} follows "
                    f"{regions[i - 1].outer:g}",
                    f"pattern.regions[{i}].outer",
                )
        if regions[-1].outer != 1.0:
            raise SceneError(
                f"the last region must reach the clamp (outer = 1), got {regions[-1].outer:g}",
                f"pattern.regions[{len(regions) - 1}].outer",
            )
        object.__setattr__(self, "regions", regions)

    # --- constructors ------------------------------------------------------------------------------
    @classmethod
    def full(cls, layers: int = 1) -> ZonePattern:
        """The electrode over the whole zone, ``layers`` layers everywhere (today's uniform zone for 1).

        Parameters
        ----------
        layers : int
            Layers of the stack.

        Returns
        -------
        ZonePattern
        """
        return cls(((1.0, layers, True),))

    @classmethod
    def no_electrode(cls, layers: int = 1) -> ZonePattern:
        """No electrode anywhere: the passive membrane of ``layers`` layers.

        Parameters
        ----------
        layers : int
            Layers of the stack.

        Returns
        -------
        ZonePattern
        """
        return cls(((1.0, layers, False),))

    @classmethod
    def inner_circle(cls, fraction: float, passive_layers: int = 1) -> ZonePattern:
        """An electrode disc of radius ``fraction · A`` at the centre (one layer), passive around it.

        Parameters
        ----------
        fraction : float
            Electrode radius over the zone radius, in ``(0, 1]`` (1: the full electrode).
        passive_layers : int
            Layers of the passive annulus (2: the paper's two-layer design, the top layer cut through
            at the active zone).

        Returns
        -------
        ZonePattern
            One region for ``fraction = 1``, else two.
        """
        fraction = validation.real(fraction, "pattern.inner_fraction", lo=0.0, lo_open=True, hi=1.0)
        if fraction == 1.0:
            return cls(((1.0, 1, True),))
        return cls(((fraction, 1, True), (1.0, passive_layers, False)))

    @classmethod
    def ring(cls, inner: float, outer: float, passive_layers: int = 1) -> ZonePattern:
        """An electrode annulus ``inner · A < R < outer · A`` (one layer), passive inside and outside.

        Parameters
        ----------
        inner, outer : float
            Radius fractions with ``0 < inner < outer ≤ 1``.
        passive_layers : int
            Layers of the passive regions.

        Returns
        -------
        ZonePattern
            Three regions, or two when the ring reaches the clamp.

        Raises
        ------
        SceneError
            Unless ``0 < inner < outer ≤ 1`` (naming ``pattern.ring_inner`` or ``pattern.ring_outer``).
        """
        inner = validation.real(inner, "pattern.ring_inner", lo=0.0, lo_open=True, hi=1.0)
        outer = validation.real(outer, "pattern.ring_outer", lo=0.0, lo_open=True, hi=1.0)
        if outer <= inner:
            raise SceneError(f"must exceed the ring's inner fraction {inner:g}, got {outer:g}", "pattern.ring_outer")
        regions = [(inner, passive_layers, False), (outer, 1, True)]
        if outer < 1.0:
            regions.append((1.0, passive_layers, False))
        return cls(tuple(regions))

    def with_layers(self, layers) -> ZonePattern:
        """The same regions with every region's layers given, from the pole out (``[layers] regions``).

        Parameters
        ----------
        layers : sequence of int
            One whole number ``1..MAX_LAYERS`` per region.

        Returns
        -------
        ZonePattern
            The regions' radii and electrodes unchanged, their layers ``layers``.

        Raises
        ------
        SceneError
            Naming ``layers.regions`` when the count differs from the regions', or ``pattern.regions[i].layers``
            for a layer count that is not a whole number in ``1..MAX_LAYERS``.

        Examples
        --------
        >>> ZonePattern.inner_circle(0.5).with_layers([2, 3]).describe()
        '0..0.5: electrode, 2 layers; 0.5..1: passive, 3 layers'
        """
        if isinstance(layers, (str, bytes)) or not hasattr(layers, "__len__") or len(layers) != len(self.regions):
            raise SceneError(
                f"must give one layer count per region ({len(self.regions)}, from the pole out), got {layers!r}",
                "layers.regions",
            )
        return ZonePattern(tuple((r.outer, n, r.electrode) for r, n in zip(self.regions, layers)))

    # --- description -------------------------------------------------------------------------------
    @property
    def interfaces(self) -> tuple:
        """The interface radius fractions ``f1 … f(K−1)`` (empty for one region)."""
        return tuple(r.outer for r in self.regions[:-1])

    @property
    def electrode_area_fraction(self) -> float:
        """Reference area of the electrode over the zone's, ``Σ (fk² − f(k−1)²)`` over electroded regions."""
        inner = 0.0
        total = 0.0
        for r in self.regions:
            if r.electrode:
                total += r.outer**2 - inner**2
            inner = r.outer
        return total

    def describe(self) -> str:
        """One line: every region with its radii, electrode and layers.

        Returns
        -------
        str
            E.g. ``"0..0.5: electrode, 1 layer; 0.5..1: passive, 2 layers"``.
        """
        parts, inner = [], 0.0
        for r in self.regions:
            parts.append(f"{inner:g}..{r.outer:g}: {r.describe()}")
            inner = r.outer
        return "; ".join(parts)


# --- the zone's model ------------------------------------------------------------------------------------


@dataclass(frozen=True)
class PatternedModel(MembraneModel):
    """The model of a patterned zone: the membrane's effects and the zone's :class:`ZonePattern`.

    Wherever a zone is shot through :func:`coexist.shooting.solve_states` (the zone curves, the N-zone
    equilibria, their continuation and the ramp), a model carrying a pattern is shot region by region
    (:func:`solve_patterned_states`, with its exact derivatives): the pattern travels with the model every
    stage already receives, so no stage needs to know of it. The numeric methods it inherits
    (:meth:`~coexist.model.MembraneModel.tensions`, ``pole``, ``rhs`` …) are those of one layer of the
    membrane (:attr:`uniform`), not of the zone.

    Parameters
    ----------
    elasticity, electrostatics, prestretch, wrinkling
        As for :class:`~coexist.model.MembraneModel`; with ``wrinkling="tension-field"`` the states the taut
        patterned shooting finds wrinkled are shot again relaxed (:mod:`coexist.patterned_relaxed`; without
        derivatives: with ``derivatives=True`` they stay ``WRINKLED``, with the reason).
    pattern : ZonePattern
        The regions of every zone.

    Raises
    ------
    SceneError
        If ``pattern`` is not a :class:`ZonePattern` (field ``pattern``).

    Examples
    --------
    >>> from coexist import MembraneModel, solve_states
    >>> zone = PatternedModel.of(MembraneModel(), ZonePattern.full(layers=2))
    >>> round(float(solve_states(zone, [2.0]).p_hat[0]) / 2, 6)  # shot as the two-layer zone it is
    1.869555
    """

    pattern: ZonePattern = field(default_factory=ZonePattern.full)

    def __post_init__(self):
        validation.instance(self.pattern, ZonePattern, "pattern", "a ZonePattern (e.g. ZonePattern.inner_circle(0.5))")
        # wrinkling = "tension-field": solve_states relaxes its WRINKLED states (coexist.patterned_relaxed)
        super().__post_init__()

    @classmethod
    def of(cls, model: MembraneModel, pattern: ZonePattern) -> PatternedModel:
        """``model``'s effects with ``pattern``.

        Parameters
        ----------
        model : MembraneModel
        pattern : ZonePattern

        Returns
        -------
        PatternedModel
        """
        validation.membrane_model(model)
        return cls(model.elasticity, model.electrostatics, model.prestretch, model.wrinkling, pattern)

    @property
    def uniform(self) -> MembraneModel:
        """One layer of the membrane (the same effects, no pattern), built once."""
        plain = self._built.get("uniform membrane")
        if plain is None:
            plain = self._built["uniform membrane"] = MembraneModel(
                self.elasticity, self.electrostatics, self.prestretch, self.wrinkling
            )
        return plain

    def describe(self) -> dict:
        """:meth:`MembraneModel.describe` with ``pattern``: its regions (``outer``, ``layers``, ``electrode``).

        Returns
        -------
        dict
        """
        out = super().describe()
        out["pattern"] = {
            "regions": [{"outer": r.outer, "layers": r.layers, "electrode": r.electrode} for r in self.pattern.regions]
        }
        return out


def shoot_zone(
    model: MembraneModel, pole_stretch, phi_hat, settings, shape=False, derivatives=False, formal=False, starts=None
):
    """:func:`coexist.shooting.solve_states` of a :class:`PatternedModel`: :func:`solve_patterned_states` of its
    membrane and pattern (the dispatch :func:`~coexist.shooting.solve_states` makes for a model with a pattern).

    Parameters
    ----------
    model : PatternedModel
        The zone (any other model is refused: field ``model``).
    pole_stretch, phi_hat, settings, derivatives, formal
        As for :func:`~coexist.shooting.solve_states`.
    shape : bool
        Must be False: the meridian of a patterned zone is not returned.
    starts : ScaleStarts, optional
        A continuation's store of converged states: the states near a kept one start from it (and are kept).

    Returns
    -------
    PatternedStates

    Raises
    ------
    SceneError
        For ``shape=True`` (field ``[electrodes].pattern``), and as :func:`solve_patterned_states`.
    """
    zone: PatternedModel = validation.instance(
        model, PatternedModel, "model", "a PatternedModel (PatternedModel.of(model, pattern))"
    )
    if shape:
        raise SceneError(
            "the meridian of a patterned zone is not computed (solve_states(..., shape=True))", "[electrodes].pattern"
        )
    if starts is None:
        return solve_patterned_states(
            zone.uniform, zone.pattern, pole_stretch, phi_hat, settings, derivatives=derivatives, formal=formal
        )
    validation.instance(starts, ScaleStarts, "starts", "a ScaleStarts")
    st, kept = _solve(
        zone.uniform, zone.pattern, pole_stretch, phi_hat, settings, None, derivatives, formal, starts=starts
    )
    # a warm-started state that failed is solved once more from the cold start: a start must never lose a state
    # the cold iteration finds (measured: 3 warm NO_CLAMP states of a tension-field ring were WRINKLED, relaxed
    # next). Not a converged wrinkled state, nor one below the flat zone's pole stretch (decided at the scale
    # floor, whatever the start; measured: 46 of 46 the same cold)
    again = kept.get("warm", np.zeros(st.status.size, dtype=bool)) & ~st.ok
    again &= (st.status != WRINKLED) & (st.status != BELOW_FLAT)
    if again.any():
        x = st.pole_stretch
        retry = _solve(zone.uniform, zone.pattern, x[again], st.phi_hat[again], settings, None, derivatives, formal)[0]
        st = _merge(x, ~again, _take_patterned(st, ~again), retry)
    return st


# --- warm starts of a continuation -------------------------------------------------------------------------

#: converged states a :class:`ScaleStarts` keeps per zone at most (the oldest are dropped first)
STARTS_KEPT = 512
#: a kept state starts a new one only within this distance ``|Δλ0|/max(λ0, 1) + |ΔΦ̂|``
STARTS_REACH = 0.05


class ScaleStarts:
    """Converged states of patterned zones kept to start the interface-scale iteration of later ones.

    A continuation (:class:`coexist.equilibria.GroupSystem`) shoots its zones at points that move a little from
    one call to the next; without a start each state's Newton iteration on ``σ = ln s`` (:func:`_newton`) begins
    from the pole region's uniform zone (:func:`_pole_region_scale`, ``|σ − σ*|`` up to ~0.3). A store kept by
    the continuation and passed down (``solve_states(..., starts=...)``) keeps, per zone (material and pattern),
    the last :data:`STARTS_KEPT` converged states: ``(λ0, Φ̂)``, ``σ``, the exact slope ``dG/dσ``, the interface
    stretches ``λ1⁺`` and, where the states were shot with derivatives, ``dσ/dλ0`` and ``dσ/dΦ̂`` (the implicit
    function theorem, :func:`_derivative_pass`). A new state within :data:`STARTS_REACH` of a kept one starts
    from the nearest: ``σ`` extrapolated to first order, its slope and ``λ1⁺`` as the hint of :func:`_solve`.

    A start is never a result: every returned state comes from a pass with its own residual ``|G| ≤ rtol`` (the
    starts change the passes, not the states beyond that tolerance); a warm-started state is accepted on its first
    pass only at ``|G| ≤`` :data:`WARM_FIRST_RESIDUAL` ``rtol`` (as near its root as a cold state after its last
    Newton step), and one that fails is solved again from the cold start (:func:`shoot_zone`). A store belongs to
    one equilibrium map (:class:`coexist.continuation.EquilibriumMap`, shared by the systems of its configurations;
    a :class:`~coexist.equilibria.GroupSystem` made alone has its own): its results depend on that map's own
    earlier calls only, never on unrelated ones. It is bounded (:data:`STARTS_KEPT` states per zone and kind) and
    guarded by a lock (threads may share a map). A copy or a pickle of it starts empty.
    """

    def __init__(self, kept: int = STARTS_KEPT, reach: float = STARTS_REACH):
        self.kept = int(kept)
        self.reach = float(reach)
        self._lock = threading.Lock()
        self._zones: dict = {}  # (id(material), id(pattern), kind) -> (material, pattern, {name: array})

    def __getstate__(self):
        return {"kept": self.kept, "reach": self.reach}

    def __setstate__(self, state):
        self.kept, self.reach = int(state["kept"]), float(state["reach"])
        self._lock = threading.Lock()
        self._zones = {}

    def __len__(self) -> int:
        with self._lock:
            return sum(z[2]["l0"].size for z in self._zones.values())

    def _zone(self, model, pattern, kind):
        z = self._zones.get((id(model), id(pattern), kind))
        return None if z is None or z[0] is not model or z[1] is not pattern else z[2]

    def start(self, model, pattern, l0, phi, kind: str = "taut"):
        """The starts of the states at ``(l0, phi)`` from the nearest kept ones.

        Parameters
        ----------
        model : MembraneModel
            One layer of the zone's membrane (the store keeps each material and pattern apart).
        pattern : ZonePattern
        l0, phi : ndarray
            Pole stretches and voltages of the states, one each.
        kind : str
            ``"taut"`` (:func:`_solve`) or ``"relaxed"``
            (:func:`coexist.patterned_relaxed.solve_patterned_relaxed`), kept apart.

        Returns
        -------
        tuple or None
            ``(σ guess, hint)`` as :func:`_solve` takes them: NaN (and a NaN slope and jumps) where no kept state
            lies within reach; None where none lies within reach of any state.
        """
        with self._lock:
            kept = self._zone(model, pattern, kind)
            if kept is None:
                return None
            kept = dict(kept)  # the arrays are replaced, never changed in place: a consistent snapshot
        dl = l0[:, None] - kept["l0"][None, :]
        dp = phi[:, None] - kept["phi"][None, :]
        dist = np.abs(dl) / np.maximum(l0, 1.0)[:, None] + np.abs(dp)
        j = np.argmin(dist, axis=1)
        rows = np.arange(l0.size)
        near = dist[rows, j] <= self.reach
        if not near.any():
            return None
        dl, dp = dl[rows, j], dp[rows, j]
        step = np.nan_to_num(kept["dsig_dl0"][j] * dl) + np.nan_to_num(kept["dsig_dphi"][j] * dp)
        guess = np.where(near, kept["sigma"][j] + step, np.nan)
        hint = {
            "slope": np.where(near, kept["slope"][j], np.nan),
            "jump": {k: np.where(near, v[j], np.nan) for k, v in kept["jump"].items()},
        }
        return guess, hint

    def keep(self, model, pattern, values: dict, kind: str = "taut") -> None:
        """Keep converged states (the oldest beyond :attr:`kept` are dropped).

        Parameters
        ----------
        model : MembraneModel
            One layer of the zone's membrane.
        pattern : ZonePattern
        values : dict
            ``l0, phi, sigma, slope, dsig_dl0, dsig_dphi`` (arrays, one entry per state; NaN where unknown) and
            ``jump`` (``{k: λ1⁺ across interface k}``).
        kind : str
            ``"taut"`` or ``"relaxed"`` (:meth:`start`).
        """
        if not values["l0"].size:
            return
        with self._lock:
            old = self._zone(model, pattern, kind)
            new: dict
            if old is None:
                new = {k: (dict(v) if k == "jump" else v) for k, v in values.items()}
            else:
                new = {k: np.concatenate([old[k], v])[-self.kept :] for k, v in values.items() if k != "jump"}
                new["jump"] = {k: np.concatenate([old["jump"][k], v])[-self.kept :] for k, v in values["jump"].items()}
            if np.size(new["l0"]) > self.kept:
                new = {k: v[-self.kept :] for k, v in new.items() if k != "jump"} | {
                    "jump": {k: v[-self.kept :] for k, v in new["jump"].items()}
                }
            self._zones[(id(model), id(pattern), kind)] = (model, pattern, new)


# --- states -----------------------------------------------------------------------------------------------


class PatternedStates(MembraneStates):
    """:class:`~coexist.shooting.MembraneStates` of a patterned zone, with a sentence per failed state.

    The fields are those of :class:`~coexist.shooting.MembraneStates`, with these meanings for a stack:
    ``q_hat`` is the charge on the electrode only, ``max_field`` the largest true field ``Ê = (Φ̂/n) λ1 λ2``
    in an electroded region, ``min_tension`` the smallest nominal tension of a stack ``n T̂`` (over ``μH``),
    one-sided values at the interfaces included. ``derivatives``, ``shapes`` and ``wrinkled_radii`` are None.

    ``failure_detail`` (one entry per state, None where OK) says for a failed state which tension, where
    (``R/A``, which region, which side of an edge) and how negative, or why the iteration failed.
    ``interfaces``, an array of shape ``(states, K − 1, 2, 5)``, holds at every interface its two sides (pole
    side first) as ``(R̂, r̂, ẑ, θ, n T̂1)`` of the unit membrane: reference radius, radius, height above the
    pole (``ẑ`` grows from the pole towards the clamp here), slope angle and meridional force per reference
    hoop length over ``μH`` (NaN for failed states). Both are kept outside the dataclass fields, so the curve
    helpers that copy states treat these as plain :class:`~coexist.shooting.MembraneStates`.
    """

    __slots__ = ("failure_detail", "interfaces")
    failure_detail: list
    interfaces: np.ndarray

    def require_ok(self) -> PatternedStates:
        """Raise :class:`~coexist.errors.ModelRangeError` naming the first failed input and the failure detail.

        Returns
        -------
        PatternedStates
            ``self``, when every state is OK.

        Raises
        ------
        ModelRangeError
        """
        from .errors import ModelRangeError

        bad = np.flatnonzero(~self.ok)
        if bad.size:
            i = bad[0]
            detail = self.failure_detail[i]
            raise ModelRangeError(
                f"no valid state at pole stretch {self.pole_stretch[i]:.6g}, Φ̂ = {self.phi_hat[i]:.6g}: "
                f"{reason_text(self.status[i])}" + (f" ({detail})" if detail else ""),
                reason_tag(self.status[i]),
            )
        return self


def _patterned(states: MembraneStates, detail: list, edges: np.ndarray | None = None) -> PatternedStates:
    out = PatternedStates(**{k: v for k, v in states.__dict__.items()})
    out.failure_detail = detail
    out.interfaces = np.full((states.status.size, 0, 2, 5), np.nan) if edges is None else edges
    return out


# --- the interface jump ------------------------------------------------------------------------------------


def interface_stretch(model: MembraneModel, l1_in, l2, phi_in, n_in, phi_out, n_out):
    """The meridional stretch ``λ1⁺`` across an interface: ``n⁺ T̂1(λ1⁺, λ2; Φ̂⁺) = n⁻ T̂1(λ1⁻, λ2; Φ̂⁻)``.

    The root on the stable branch (``∂T̂1/∂λ1 > 0``), by Newton's method safeguarded by a bracket: from
    ``λ1⁻`` the bracket ``[lo, hi]`` is widened (halving ``lo``, doubling ``hi`` while ``∂T̂1/∂λ1 > 0``) until
    ``T̂1(lo) < target < T̂1(hi)``; a Newton step that leaves it is replaced by bisection. Equal sides return
    ``λ1⁻`` exactly.

    Parameters
    ----------
    model : MembraneModel
    l1_in, l2 : ndarray
        ``λ1⁻`` and the (continuous) hoop stretch.
    phi_in, phi_out : ndarray
        The per-layer voltages ``Φ̂/n`` on the two sides (0 without electrode).
    n_in, n_out : ndarray
        Layer counts on the two sides.

    Returns
    -------
    l1_out : ndarray
        ``λ1⁺``; NaN where no root with ``∂T̂1/∂λ1 > 0`` exists (the outer side would be beyond its
        electromechanical instability).
    ok : ndarray of bool
    """
    l1_in, l2, phi_in, n_in, phi_out, n_out = np.broadcast_arrays(
        *(np.asarray(a, dtype=float) for a in (l1_in, l2, phi_in, n_in, phi_out, n_out))
    )
    target = n_in * np.asarray(model.tensions(l1_in, l2, phi_in)[0]) / n_out

    def t1(x):
        T1, T11 = _meridional_tension(model, x, l2, phi_out)
        return T1 - target, T11

    x = l1_in.copy()
    g, d = t1(x)
    lo, hi, ok = _stable_bracket(model, x, g, l2, phi_out, target)
    if not ok.any():  # no root on any stable branch: NaN, without bisecting every column to roundoff first
        return np.full(x.shape, np.nan), ok
    exact = g == 0
    x = np.where(exact, x, np.where((x > lo) & (x < hi), x, 0.5 * (lo + hi)))
    for _ in range(JUMP_ITERATIONS):
        g, d = t1(x)
        lo = np.where(g < 0, x, lo)
        hi = np.where(g > 0, x, hi)
        with np.errstate(all="ignore"):
            step = g / d
        nxt = x - step
        # a Newton step below rounding: x is the root (a bisection there would only walk away from it)
        settled = (g == 0) | (np.abs(step) <= 4e-16 * np.abs(x))
        bad = ~np.isfinite(nxt) | (nxt <= lo) | (nxt >= hi) | (d <= 0)
        nxt = np.where(bad & ~settled, 0.5 * (lo + hi), nxt)
        nxt = np.where(settled, x, nxt)
        done = np.abs(nxt - x) <= 4e-16 * np.abs(x)
        x = nxt
        if done.all():
            break
    g, d = t1(x)
    ok &= np.isfinite(x) & (d > 0) & (np.abs(g) <= 1e-13 * np.maximum(1.0, np.abs(target)))
    return np.where(ok, x, np.nan), ok


def _stable_bracket(model: MembraneModel, x, g, l2, phi_out, target):
    """The bracket of :func:`interface_stretch`'s root from ``x`` (where ``T̂1 − target = g``): ``[lo, hi]`` widened
    (halving ``lo``, doubling ``hi`` while ``∂T̂1/∂λ1 > 0`` at ``hi``) until ``T̂1(lo) < target < T̂1(hi)``; ``ok`` False
    where the widening meets ``∂T̂1/∂λ1 ≤ 0`` first (no root on the stable branch: the outer side would be beyond its
    electromechanical instability). Returns ``(lo, hi, ok)``."""
    lo = np.where(g < 0, x, 0.5 * x)
    hi = np.where(g > 0, x, 2.0 * x)
    n = x.size
    both_l2, both_phi = np.concatenate([l2.ravel(), l2.ravel()]), np.concatenate([phi_out.ravel(), phi_out.ravel()])
    both_target = np.concatenate([target.ravel(), target.ravel()])

    def ends(a, b):  # T̂1 − target at both ends of the brackets in one evaluation, and ∂T̂1/∂λ1 at the upper
        T1, T11 = _meridional_tension(model, np.concatenate([a.ravel(), b.ravel()]), both_l2, both_phi)
        gg = T1 - both_target
        return gg[:n].reshape(x.shape), gg[n:].reshape(x.shape), T11[n:].reshape(x.shape)

    lo, hi, g_lo, g_hi, d_hi = _widen_bracket(ends, lo, hi)
    # NaN fails every comparison; an infinite end is a locked one (:func:`_meridional_tension`), a valid bracket end
    ok = (g_lo < 0) & (g_hi > 0) & (d_hi > 0)
    hi, ok = _below_first_maximum(model, x, hi, l2, phi_out, target, ok)
    return lo, hi, ok


#: pole stretches sampled (geometrically) between ``λ1⁻`` and a bracket's upper end to find a maximum of ``T̂1``
#: inside it (:func:`_below_first_maximum`; the falling stretch past the outer side's electromechanical instability
#: spans tens of per cent of ``λ1`` on the membranes of this project — a resolution chosen, not derived)
MAXIMUM_SAMPLES = 16


def _below_first_maximum(model: MembraneModel, x, hi, l2, phi_out, target, ok):
    """Cut brackets ``[·, hi]`` whose upper end was widened above ``x`` (``λ1⁻``) at the first sampled maximum of
    ``T̂1(λ1)`` inside them: a side with voltage loses stiffness at its electromechanical instability
    (``∂T̂1/∂λ1 = 0``), and beyond it ``T̂1`` falls, then rises again towards the Gent locking stretch. A bracket that
    reaches over that fall holds the root of the far, stiffening branch too; the stable root is the one on the
    branch rising from ``λ1⁻``, below the maximum, and there is none when ``T̂1`` at the maximum stays below the
    target. Only columns with voltage (``Φ̂⁺ ≠ 0``) are sampled: without it ``T̂1`` rises monotonically up to
    locking. Returns ``(hi, ok)``: ``hi`` cut at the first sample with ``∂T̂1/∂λ1 ≤ 0`` where ``T̂1`` there still
    exceeds the target, ``ok`` False where it does not."""
    x, hi, l2, phi_out, target = np.broadcast_arrays(
        *(np.asarray(a, dtype=float) for a in (x, hi, l2, phi_out, target))
    )
    hi, ok = hi.copy(), np.array(ok, dtype=bool, copy=True)
    cols = np.flatnonzero(ok.ravel() & (phi_out.ravel() != 0) & (hi.ravel() > x.ravel()))
    if cols.size == 0:
        return hi, ok
    a, b = x.ravel()[cols], hi.ravel()[cols]
    frac = np.arange(1, MAXIMUM_SAMPLES + 1) / MAXIMUM_SAMPLES
    pts = a[None, :] * (b / a)[None, :] ** frac[:, None]  # (samples, cols), the last at hi
    T1, T11 = _meridional_tension(
        model, pts.ravel(), np.tile(l2.ravel()[cols], frac.size), np.tile(phi_out.ravel()[cols], frac.size)
    )
    T1, T11 = T1.reshape(pts.shape), T11.reshape(pts.shape)
    falling = ~(T11 > 0)
    has = falling.any(axis=0)
    first = np.argmax(falling, axis=0)
    j = np.flatnonzero(has)
    k = first[j]
    above = T1[k, j] - target.ravel()[cols[j]] > 0
    hi_flat, ok_flat = hi.reshape(-1), ok.reshape(-1)
    hi_flat[cols[j[above]]] = pts[k[above], j[above]]
    ok_flat[cols[j[~above]]] = False
    return hi, ok


def _meridional_tension(model: MembraneModel, l1, l2, phi):
    """``(T̂1, ∂T̂1/∂λ1)`` at ``(λ1, λ2; φ)``, with their limits where the Gent chains are locked (margin
    ``1 − (I1 − 3)/Jlim ≤ 0``): there the formulas hold no state (``T̂1 = (λ1 − λ1⁻³λ2⁻²)/margin − φ²λ1λ2²`` has
    changed sign through a pole), and ``T̂1 → ±∞`` as the margin falls to zero, with the sign of
    ``∂I1/∂λ1 = 2(λ1 − λ1⁻³λ2⁻²)`` (the electrical term stays finite): a locked point reached by stretching is beyond
    every root of ``T̂1 = target`` (``+∞``, slope ``+∞``), one reached by compressing below every root (``−∞``).
    The root searches of the interface jump thus stay between the locking stretches (a bracket doubled into
    the locked region had ``T̂1 < 0`` there and was refused: at zero voltage with equal sides, the identity
    jump failed beyond a pole stretch of about 5 on a Gent membrane with ``Jlim = 97``)."""
    l1, l2, phi = np.broadcast_arrays(*(np.asarray(a, dtype=float) for a in (l1, l2, phi)))
    T = model.tensions(l1, l2, phi)
    T1 = np.asarray(T[0], dtype=float) * np.ones(l1.shape)
    T11 = np.asarray(T[2], dtype=float) * np.ones(l1.shape)
    locked = ~(np.asarray(T[4], dtype=float) * np.ones(l1.shape) > 0)
    if locked.any():
        with np.errstate(all="ignore"):
            up = l1**4 * l2**2 >= 1.0  # ∂I1/∂λ1 ≥ 0: locked by stretching
        T1 = np.where(locked, np.where(up, np.inf, -np.inf), T1)
        T11 = np.where(locked, np.inf, T11)
    return T1, T11


def _widen_bracket(ends, lo, hi):
    """Widen brackets ``[lo, hi]`` of an increasing function's root: halve ``lo`` while the function is not below
    the target there, double ``hi`` while it is not above it and still rising (``ends(lo, hi)`` returns the
    function minus the target at both ends and its slope at ``hi``); at most 80 rounds. Returns ``(lo, hi, g_lo,
    g_hi, d_hi)``: the caller judges what a bracket that stopped on a falling slope means."""
    g_lo, g_hi, d_hi = ends(lo, hi)
    for _ in range(80):
        low_bad = g_lo >= 0
        high_bad = (g_hi <= 0) & (d_hi > 0)
        if not (low_bad.any() or high_bad.any()):
            break
        lo = np.where(low_bad, 0.5 * lo, lo)
        hi = np.where(high_bad, 2.0 * hi, hi)
        g_lo, g_hi, d_hi = ends(lo, hi)
    return lo, hi, g_lo, g_hi, d_hi


# --- one pass over the regions ------------------------------------------------------------------------------


@dataclass
class _Layout:
    """Per-state region parameters: layers ``n[k]``, per-layer voltage ``phi[k]`` and fraction ``f[k]``."""

    n: np.ndarray  # (K, m)
    phi: np.ndarray  # (K, m)
    f: np.ndarray  # (K,)
    electrode: tuple


class _Tracker:
    """The smallest stack tension ``n T̂`` (nodes, and the cubic Hermite estimate between two nodes from the
    exact slopes ``dT/dR``, as in :mod:`coexist.shooting`), where it is, and the largest true field.

    As in :func:`coexist.shooting.solve_states`, a step whose Hermite estimate of a tension's minimum falls below
    :data:`~coexist.shooting.REFINE_MINIMUM_BELOW` (per layer) has its minimum located exactly
    (:func:`_exact_minimum`: the root of ``dT/dR̂`` inside the step, each iterate one step of the integrator from
    the step's start), so the smallest tension of a state carries the integration's own accuracy where the onset
    of wrinkling is decided (the estimate's ``O(h⁴)`` error would make it jump between neighbouring states as
    their steps change); the step onto the clamp keeps its estimate (as the uniform shooting's)."""

    def __init__(self, m):
        self.min_T = np.full(m, np.inf)
        self.where_R = np.full(m, np.nan)
        self.kind = np.zeros(m, dtype=int)
        self.region = np.zeros(m, dtype=int)
        self.side = np.zeros(m, dtype=int)  # −1 clamp side of an edge (region start), +1 pole side (end)
        self.max_E = np.zeros(m)
        self.node = np.full((5, m), np.nan)  # R, T1, T2, dT1/dR, dT2/dR of the last node
        self.edges = np.empty(0)  # both sides of the interfaces (set by the pass)
        # False where the smallest tension came from the attempt function (value exact, place not recorded)
        self.exact = np.ones(m, dtype=bool)
        # the state at the last node (the step-by-step path: where a step's minimum is located exactly)
        self.node_y: np.ndarray | None = None

    def values(self, model, R, y, f, n, phi):
        T1, T2, T11, T12, _, E, T22 = (np.asarray(a) * np.ones_like(R) for a in model.tensions(y[0], y[1], phi))
        d1 = T11 * f[0] + T12 * f[1]
        d2 = T12 * f[0] + T22 * f[1]
        return np.vstack([R, n * T1, n * T2, n * d1, n * d2]), np.abs(E)

    def start(self, cols, node, E, region):
        """A region's first node (its interface, clamp side)."""
        self.node[:, cols] = node
        self._record(cols, node, region, -1)
        self.max_E[cols] = np.maximum(self.max_E[cols], E)

    def set_states(self, cols, y) -> None:
        """The state at the last node of the columns ``cols`` (a region's start; rows as integrated)."""
        if self.node_y is None or self.node_y.shape[0] != y.shape[0]:
            self.node_y = np.full((y.shape[0], self.min_T.size), np.nan)
        self.node_y[:, cols] = y

    def add(self, cols, node, E, region, side=0, y=None, refine=None):
        """An accepted node: the step's minimum (Hermite; located exactly where it falls below
        :data:`~coexist.shooting.REFINE_MINIMUM_BELOW` per layer, given the node's state ``y`` and ``refine =
        (fns, model, kind, n)``, :func:`_exact_minimum`) and the node itself."""
        from .shooting import REFINE_MINIMUM_BELOW, hermite_minimum

        a = self.node[:, cols]
        for k in (1, 2):
            interior = (a[2 + k] < 0) & (node[2 + k] > 0)
            if interior.any():
                est = np.full(cols.size, np.inf)
                with np.errstate(all="ignore"):
                    est[interior] = hermite_minimum(
                        a[0][interior],
                        a[k][interior],
                        a[2 + k][interior],
                        node[0][interior],
                        node[k][interior],
                        node[2 + k][interior],
                    )
                where = 0.5 * (a[0] + node[0])
                if refine is not None and self.node_y is not None:
                    fns, model, kind, n = refine
                    near = np.flatnonzero(interior & (est < REFINE_MINIMUM_BELOW * n) & np.isfinite(est))
                    if near.size:
                        c = cols[near]
                        T, R = _exact_minimum(
                            fns,
                            model,
                            kind,
                            k,
                            a[0][near],
                            self.node_y[:, c],
                            node[0][near] - a[0][near],
                            a[2 + k][near] / n[near],
                            node[2 + k][near] / n[near],
                        )
                        ok = np.isfinite(T)
                        est[near[ok]], where[near[ok]] = n[near][ok] * T[ok], R[ok]
                lower = est < self.min_T[cols]
                if lower.any():
                    c = cols[lower]
                    self.min_T[c] = est[lower]
                    self.where_R[c] = where[lower]
                    self.kind[c] = k
                    self.region[c] = region
                    self.side[c] = 0
                    self.exact[c] = True
        self._record(cols, node, region, side)
        self.node[:, cols] = node
        self.max_E[cols] = np.maximum(self.max_E[cols], E)
        if y is not None and self.node_y is not None:
            self.node_y[:, cols] = y

    def _record(self, cols, node, region, side):
        for k in (1, 2):
            lower = node[k] < self.min_T[cols]
            if lower.any():
                c = cols[lower]
                self.min_T[c] = node[k][lower]
                self.where_R[c] = node[0][lower]
                self.kind[c] = k
                self.region[c] = region
                self.side[c] = side if np.ndim(side) == 0 else side[lower]
                self.exact[c] = True


def _exact_minimum(fns, model, kind, k, Ra, ya, h, da, db):
    """The minimum of the per-layer tension ``T̂k`` (``k = 1`` meridional, 2 hoop) inside the steps ``(Ra, Ra + h)``
    from the states ``ya`` (rows of ``kind``, the per-layer voltage last), where ``dT̂k/dR̂`` goes from ``da < 0``
    to ``db > 0``: the root of

        dT̂1/dR̂ = T̂11 λ1' + T̂12 λ2',    dT̂2/dR̂ = T̂12 λ1' + T̂22 λ2'

    (:func:`~coexist.numerics.roots.bracketed_root`, to ``1e-9 h``), each iterate one DOP853 step of the integrator
    from ``Ra`` (as :func:`coexist.shooting.solve_states` locates its minima); the smallest tension met on the way
    is the minimum.

    Returns
    -------
    T, R : ndarray
        The minimum per layer and the radius at which it was met, per step.
    """
    from .numerics.roots import bracketed_root

    stepper = _stepper(fns, kind, Ra.size)
    fa = None if isinstance(stepper, _int.CasadiStepper) else stepper.rhs(Ra, ya)
    best = np.full(Ra.size, np.inf)
    at = np.full(Ra.size, np.nan)

    def slope_at(x, idx):
        y, f, _, _ = stepper.step(Ra[idx], ya[:, idx], None if fa is None else fa[:, idx], x)
        T1, T2, T11, T12, _, _, T22 = (np.asarray(v) * np.ones(idx.size) for v in model.tensions(y[0], y[1], y[-1]))
        T, g = (T1, T11 * f[0] + T12 * f[1]) if k == 1 else (T2, T12 * f[0] + T22 * f[1])
        lower = T < best[idx]
        best[idx[lower]] = T[lower]
        at[idx[lower]] = Ra[idx][lower] + x[lower]
        return g

    with np.errstate(all="ignore"):
        bracketed_root(slope_at, np.zeros(Ra.size), h, da, db, xtol=1e-9 * np.maximum(h, 1e-300), max_iter=10)
    return best, at


_ROWS = {"radius": 9, "radius_sens": 19, "hoop": 9}


def _attempts_serve(fns, m: int) -> bool:
    """Whether ``m`` trajectories are integrated by the shooting's attempt functions (a few compiled DOP853
    attempts per call, :func:`coexist.shooting.run_attempts`) rather than step by step from Python: the batch
    sizes :meth:`~coexist.shooting._Integrators.small_batch_limit` gives them (compiled: any, in chunks).

    Every batch counts as a use of a function not compiled yet (the compiled functions take any size, in chunks;
    compiled from the :data:`~coexist.shooting.COMPILE_AFTER`-th use on, and looked for in the cache while it
    compiles in the background, :meth:`~coexist.shooting._Integrators.attempts`): without it a process whose
    batches exceed the uncompiled limit would never use, so never compile, the function (its curves then took twice
    the time on a machine whose cache lacked the ``radius_sens`` library), and one whose batches had grown past
    :data:`~coexist.shooting.COMPILED_BATCH_LIMIT` never looked for it again (a single patterned zone's first
    ``coexist coexistence``: 100 s of derivative passes in numpy, against 6 s once the library was loaded)."""
    for kind in ("radius", "radius_sens"):
        entry = fns._casadi.get(("attempts", kind))
        if entry is not None and not entry.get("compiled"):
            _attempts(fns, kind)
    return m <= min(fns.small_batch_limit("radius", m), fns.small_batch_limit("radius_sens", m))


@dataclass
class _AttemptResult:
    """One region integrated by the attempt function: :class:`~coexist.numerics.dop853.IntegrationResult`'s
    ``t, y, status, steps`` (``status`` in :func:`~coexist.numerics.dop853.integrate`'s codes, a failure as
    ``FAILED + code`` at the failing node's radius ``t``) and the packed states ``X`` (tracked tensions)."""

    t: np.ndarray
    y: np.ndarray
    status: np.ndarray
    steps: np.ndarray
    X: np.ndarray


def _attempt_region(fns, kind, t0, y0, t_end, rtol, atol, max_steps, start, last: bool, h0=None) -> _AttemptResult:
    """Integrate one region of every column by the attempt function of ``kind`` (``"radius"``/``"radius_sens"``):
    the same DOP853 steps as :func:`coexist.numerics.dop853.integrate` from the same first step (the same step
    control) with the checks of the region's event in ``_pass``: the meridional
    tension (the attempt function's ``formal`` mode: the hoop tension is judged on the converged state only),
    locking, ellipticity, a meridian folding back, and the clamp stretch (the landing in the last region; in another
    region a crossing means the interfaces lie too far out, ``_EARLY_CLAMP``). ``start = (T̂1, T̂2, dT̂1/dR̂,
    dT̂2/dR̂, |Ê|)`` per layer at the first node (for the cubic Hermite estimate of a minimum within the first
    step). ``h0``: the first step size per column; default Hairer's estimate (:func:`~coexist.numerics.dop853.
    initial_step`, from the plain equations' rows: two numpy evaluations of the right-hand side, a tenth of a
    millisecond per call); :func:`_pass` gives the series radius from the pole (as the uniform shooting) and
    :data:`OUTER_FIRST_STEP` ``R̂i`` after an interface."""
    from .shooting import _H, _HEAD

    R, m = y0.shape
    rtol = np.broadcast_to(np.asarray(rtol, dtype=float), (m,))
    atol = np.broadcast_to(np.asarray(atol, dtype=float), y0.shape)
    if h0 is None:
        # Hairer's starting step from the plain equations' rows (the sensitivities follow the same trajectory)
        y9, a9 = (y0, atol) if R == 9 else (y0[_PLAIN_ROWS], atol[_PLAIN_ROWS])
        h0 = _int.initial_step(fns.radius, t0, y9, fns.radius(t0, y9), np.ones(m), rtol[None, :], a9)
    o = len(_HEAD)
    X = np.zeros((o + 4 * R, m))
    H = _H
    T1, T2, d1, d2, E = start
    X[H["t"]], X[H["h"]], X[H["t_end"]], X[H["rtol"]] = t0, h0, t_end, rtol
    X[H["max_steps"]], X[H["formal"]] = max_steps, 1.0
    X[H["Ra"]], X[H["T1a"]], X[H["T2a"]], X[H["d1a"]], X[H["d2a"]] = t0, T1, T2, d1, d2
    X[H["minT"]], X[H["maxE"]], X[H["failR"]], X[H["cand_est"]] = np.inf, E, np.nan, np.inf
    X[o : o + R], X[o + 2 * R : o + 3 * R] = y0, np.where(np.isfinite(atol), atol, 1e300)
    return _attempt_run(fns, kind, X, last)


def _attempt_run(fns, kind, X, last: bool, steps_before=None) -> _AttemptResult:
    """Run the attempt function of ``kind`` on the packed states ``X`` (:func:`_attempt_region`'s, or such states
    taken up again with a further ``t_end``, :func:`_pole_region`) until every column stops; ``steps`` counts the
    steps after ``steps_before`` (per column; default none)."""
    from .shooting import _H, _HEAD, run_attempts

    R = (X.shape[0] - len(_HEAD)) // 4
    o = len(_HEAD)
    H = _H
    run_attempts(_attempts(fns, kind), X, H["status"], H["steps"], H["max_steps"])
    st = X[H["status"]].astype(int)
    failed = st >= _int.FAILED
    status = np.where(failed, _int.FAILED + st, st)
    if not last:
        status[st == _int.CROSSED] = _int.FAILED + _EARLY_CLAMP
    steps = X[H["steps"]].astype(int)
    return _AttemptResult(
        t=np.where(failed, X[H["failR"]], X[H["t"]]),
        y=X[o : o + R].copy(),
        status=status,
        steps=steps if steps_before is None else steps - steps_before,
        X=X,
    )


def _track_attempts(tracker: _Tracker, res: _AttemptResult, cols, n, region: int, track: bool, refine=None) -> None:
    """Fold a region's attempt-function tracking into ``tracker`` (stack tensions ``n T̂``): the smallest tension
    (nodes, exact values, their place not recorded: ``tracker.exact`` False; and the step whose Hermite estimate
    of a minimum came below :data:`~coexist.shooting.REFINE_MINIMUM_BELOW`, the attempt function's candidate,
    located exactly by :func:`_exact_minimum` given ``refine = (fns, model)``, its place recorded), the largest
    field and the last node (from which the landing's step is judged)."""
    if not track:
        return
    from .shooting import _H, _HEAD

    X = res.X
    low = X[_H["minT"]] * n
    has = np.flatnonzero(np.isfinite(X[_H["cand_est"]]))
    if has.size == 0:  # the common case: no step came near zero, the smallest tension is a node's
        lower = low < tracker.min_T[cols]
        if lower.any():
            c = cols[lower]
            tracker.min_T[c] = low[lower]
            tracker.where_R[c] = np.nan
            tracker.kind[c] = 0
            tracker.region[c] = region
            tracker.side[c] = 0
            tracker.exact[c] = False
        _track_last(tracker, X, cols, n)
        return
    cand = X[_H["cand_est"]] * n
    kind_c = X[_H["cand_k"]].astype(int)
    where = np.full(cols.size, np.nan)
    refined = np.zeros(cols.size, dtype=bool)
    if refine is not None:
        fns, model = refine
        R = (X.shape[0] - len(_HEAD)) // 4
        o = len(_HEAD)
        kind = "radius" if R == 9 else "radius_sens"
        for k in (1, 2):
            j = has[kind_c[has] == k]
            if j.size:
                T, at = _exact_minimum(
                    fns,
                    model,
                    kind,
                    k,
                    X[_H["cand_Ra"], j],
                    X[o + 3 * R : o + 4 * R, j],
                    X[_H["cand_h"], j],
                    X[_H["cand_da"], j],
                    X[_H["cand_db"], j],
                )
                ok = np.isfinite(T)
                cand[j[ok]] = np.broadcast_to(n, cols.shape)[j[ok]] * T[ok]
                where[j[ok]] = at[ok]
                refined[j[ok]] = True
    from_cand = cand < low
    low = np.minimum(low, cand)
    lower = low < tracker.min_T[cols]
    if lower.any():
        c = cols[lower]
        exact = from_cand[lower] & refined[lower]
        tracker.min_T[c] = low[lower]
        tracker.where_R[c] = np.where(exact, where[lower], np.nan)
        tracker.kind[c] = np.where(exact, kind_c[lower], 0)
        tracker.region[c] = region
        tracker.side[c] = 0
        tracker.exact[c] = exact
    _track_last(tracker, X, cols, n)


def _track_last(tracker: _Tracker, X, cols, n) -> None:
    """The largest field and the last node of an attempt-function run (packed states ``X``) into ``tracker``."""
    from .shooting import _H

    tracker.max_E[cols] = np.maximum(tracker.max_E[cols], X[_H["maxE"]])
    tracker.node[:, cols] = np.vstack(
        [X[_H["Ra"]], n * X[_H["T1a"]], n * X[_H["T2a"]], n * X[_H["d1a"]], n * X[_H["d2a"]]]
    )


def _stepper(fns, kind: str, n: int):
    """The shooting's DOP853 stepper for ``n`` trajectories of ``kind``; once compiled (cached per machine) the
    whole-step function serves batches up to a few hundred, where it beats numpy (that stepper is then kept here:
    asking the shooting for it again computes its cache key every time)."""
    from .shooting import COMPILED_BATCH_LIMIT

    kept = fns.__dict__.setdefault("_patterned_kept", {})
    st = kept.get(("stepper", kind))
    if st is not None and n <= COMPILED_BATCH_LIMIT:
        return st
    st = fns.stepper_of(kind, n, _ROWS[kind], getattr(fns, kind), lambda: fns._casadi_rhs(kind), medium=True)
    if isinstance(st, _int.CasadiStepper) and fns._casadi.get(("stepper compiled", kind)):
        kept[("stepper", kind)] = st
    return st


def _attempts(fns, kind: str) -> dict:
    """The shooting's attempt function of ``kind`` (:meth:`~coexist.shooting._Integrators.attempts`); once compiled
    its entry is kept here (asking the shooting for it again computes its cache key every time)."""
    kept = fns.__dict__.setdefault("_patterned_kept", {})
    entry = kept.get(("attempts", kind))
    if entry is None:
        entry = fns.attempts(kind)
        if entry.get("fast"):
            kept[("attempts", kind)] = entry
    return entry


def _dT1_dphi(model: MembraneModel, l1, l2, phi) -> np.ndarray:
    """``∂T̂1/∂Φ̂`` at ``(λ1, λ2; Φ̂)`` (the CasADi derivative of the model's ``T̂1``, built once per model)."""
    fn = model._built.get("patterned dT1/dphi")
    if fn is None:
        import casadi as ca

        sym = model.symbols
        fn = model._built["patterned dT1/dphi"] = ca.Function(
            "dT1_dphi", [sym["l1"], sym["l2"], sym["phi"]], [ca.densify(ca.jacobian(sym["T1"], sym["phi"]))]
        )
    a, b, c = np.broadcast_arrays(*(np.asarray(x, dtype=float) for x in (l1, l2, phi)))
    if a.size == 0:
        return np.zeros(a.shape)
    return np.asarray(fn(a.reshape(1, -1), b.reshape(1, -1), c.reshape(1, -1))).reshape(a.shape)


def _jump_sensitivities(model, lay, k, go, lam_cols, Yg, Yn, f_in, f_out, g1, g2, T11o, l1p, u_q):
    """The sensitivity rows across the interface into region ``k`` (columns ``go``), written into ``Yn``.

    With ``x = (λ1, λ2, θ)``, the quadratures ``w = (V̂/π, Q̂/2π)`` and the jump ``λ1⁺ = g(λ1⁻, λ2; Φ̂)``
    (``λ2, θ, w`` continuous), for the interface at ``R̂i = s fi``:

    * ``a = s`` (it moves the interface): ``Z⁺ = D (Z⁻ + f⁻ fi) − f⁺ fi`` on all five rows;
    * ``a = λ0``: ``Z⁺ = D Z⁻``;
    * ``a = Φ̂``: ``Z⁺ = D Z⁻ + (∂g/∂Φ̂) e_λ1`` with ``∂g/∂Φ̂ = (e⁻ ∂T̂1⁻/∂φ − e⁺ ∂T̂1⁺/∂φ)/(n⁺ ∂T̂1⁺/∂λ1)``
      (``e = 1`` on an electrode, ``φ = Φ̂/n`` the per-layer voltage), carried as ``U = n Z``.

    ``D`` is the jump's Jacobian (``∂λ1⁺/∂λ1⁻ = g1``, ``∂λ1⁺/∂λ2 = g2``, the identity on the other rows).
    ``u_q`` (all columns) holds ``U_Q`` through a region without electrode (see :func:`_pass`).
    """
    fi = lay.f[k - 1]
    fs = np.where(lam_cols[go], 0.0, fi)
    Z = Yg[7:12] + f_in[:5] * fs
    Yn[7] = g1 * Z[0] + g2 * Z[1] - f_out[0] * fs
    for r in range(1, 5):
        Yn[7 + r] = Z[r] - f_out[r] * fs
    n_in, n_out = lay.n[k - 1, go], lay.n[k, go]
    U = Yg[12:17].copy()
    if not lay.electrode[k - 1]:
        U[4] = u_q[go]
    Z = U / n_in
    g_phi = np.zeros(go.size)
    if lay.electrode[k - 1]:
        g_phi += _dT1_dphi(model, Yg[0], Yg[1], lay.phi[k - 1, go])
    if lay.electrode[k]:
        g_phi -= _dT1_dphi(model, l1p, Yg[1], lay.phi[k, go])
    g_phi /= n_out * T11o
    Z[0] = g1 * Z[0] + g2 * Z[1] + g_phi
    Yn[12:17] = n_out * Z
    if not lay.electrode[k]:
        u_q[go] = Yn[16]


def _failure_codes(y, T1, T11, margin):
    """Status per column of a node (0: fine): a trajectory stops where the meridional tension or its stiffness
    is gone, the chains lock or the meridian folds back (the hoop tension is judged on the converged state)."""
    code = np.zeros(y.shape[1], dtype=int)
    code[T1 <= 0] = WRINKLED
    code[(code == 0) & (margin <= 0)] = LOCKED
    code[(code == 0) & (T11 <= 0)] = LOST_ELLIPTICITY
    code[(code == 0) & (np.abs(y[2]) > math.pi)] = FOLDED_BACK
    return code


def _region_params(y, lay, k, cols, p_t):
    """Set the pressure and voltage rows of a region-``k`` state (``p̂t/nk``, ``Φ̂/nk`` or 0)."""
    y[-2] = p_t[cols] / lay.n[k, cols]
    y[-1] = lay.phi[k, cols]


def pole_series_radius(model, settings, phi1, n1, l0, p_t, p1=None, f1=None) -> np.ndarray:
    """The radius at which the pole region starts from its series, per state.

    The shooting's series radius (``settings.series_radius``) is chosen for a zone whose own trial pressure
    ``p̂1 = trial_pressure(λ0, Φ̂/n1)`` puts its clamp near ``R̂ = 1``. The pole region of a pattern is integrated at
    the stack's trial pressure ``p̂t/n1`` instead, i.e. (``R → cR, p → p/c``) on lengths ``c = n1 p̂1/p̂t`` times
    the uniform zone's, and its series must start at ``c`` times the radius too: near the voltage at which the
    pole wrinkles ``p̂1`` (∝ the pole tension) falls towards zero while ``p̂t`` (set by the passive regions) does
    not, and a fixed radius would start the series outside the boundary layer at the pole (measured on the
    ``inner-circle`` zone: ``p̂`` off by 4e-3 at rtol 1e-10, its states jumping between branches). Never larger
    than the shooting's radius (``c ≤ 1``); that radius where ``p̂1`` is not positive (the state fails anyway). With
    the pole region's outer fraction ``f1``, never more than ``FLOOR_SCALE_MAX (1 − POLE_MARGIN) f1 / SCALE_FLOOR``
    either: a small pole region (an electrode disc of 1e-4 of the radius) starts its series inside itself at the
    scales where states lie (:data:`FLOOR_SCALE_MAX`); at the default rtol (series radius 3.2e-4) regions wider than
    about 6 % of the radius are not affected (20 % at rtol 1e-6, where the series radius is 1e-3).

    Parameters
    ----------
    model : MembraneModel
        The one-layer membrane.
    settings : SolverSettings
        Its ``series_radius``.
    phi1 : ndarray
        The pole region's voltage per layer, ``Φ̂/n1`` (0 without electrode).
    n1 : ndarray or float
        The pole region's layers.
    l0, p_t : ndarray
        Pole stretches and the stack's trial pressures.
    p1 : ndarray, optional
        ``trial_pressure(λ0, Φ̂/n1)`` if the caller has it (else computed here).
    f1 : float, optional
        The pole region's outer radius over the zone's (None: not capped by it).

    Returns
    -------
    ndarray
        ``settings.series_radius · min(1, n1 p̂1/p̂t)``, at most ``FLOOR_SCALE_MAX (1 − POLE_MARGIN) f1 / SCALE_FLOOR``.
    """
    if p1 is None:
        p1 = trial_pressure(model, l0, phi1)
    with np.errstate(all="ignore"):
        c = np.asarray(n1 * p1 / p_t, dtype=float)
    c = np.where(np.isfinite(c) & (c > 0), np.minimum(c, 1.0), 1.0)
    R0 = settings.series_radius * c * np.ones(np.shape(l0))
    if f1 is not None:
        R0 = np.minimum(R0, FLOOR_SCALE_MAX * (1.0 - POLE_MARGIN) * float(f1) / SCALE_FLOOR)
    return R0


def _pole_start(model, settings, lay, l0, p_t, tp=None):
    """The pole region's start, the same in every pass at fixed ``p̂t``: the rows at the series radius
    ``(λ1, λ2, θ, V̂/π, Q̂/2π, Ψ̂/2π, ẑ, p̂t/n1, Φ̂/n1)``, the absolute tolerances, the series (with its
    sensitivities, for the derivative pass), the pole tension ``T̂0`` and field ``|Ê0|`` (per layer).

    The absolute tolerances are :func:`~coexist.shooting.start_rows`' (``atol`` times the size of each row at
    ``R̂ = 1`` by the series at the region's own trial pressure, 1 for the stretches and the parameters), the
    largest over the regions: a passive pole region has no charge, and a charge row that starts from 0 at an
    electrode edge must not be held to 1e-30. ``tp``: every region's trial pressure (:func:`_trial_pressures`)
    if the caller has it. The series at ``R̂ = 1`` of every region and the pole region's start at its pressure
    ``p̂t/n1`` are one evaluation (the generated series costs per call, not per column)."""
    m = l0.size
    K = lay.f.size
    phi1 = lay.phi[0]
    if tp is None:
        tp = _trial_pressures(model, lay, l0)
    R0 = pole_series_radius(model, settings, phi1, lay.n[0], l0, p_t, tp[0], lay.f[0])
    both = model.series_start(
        np.concatenate([l0, np.tile(l0, K)]),
        np.concatenate([p_t / lay.n[0], tp.reshape(-1)]),
        np.concatenate([phi1, lay.phi.reshape(-1)]),
        np.concatenate([R0, np.ones(K * m)]),
    )
    both = [np.broadcast_to(x, ((K + 1) * m,)) for x in both]
    series = [x[:m] for x in both]
    unit = np.vstack([np.abs(x[m:]) for x in both[2:7]]).reshape(5, K, m).max(axis=1)
    ones = np.ones((2, m))
    atol0 = settings.atol * np.maximum(np.vstack([ones, unit, ones]), 1e-30)
    y0 = np.vstack([*series[:7], p_t / lay.n[0], phi1])
    T0 = np.asarray(model.pole(l0, phi1)[0]) * np.ones(m)
    E0 = np.abs(np.asarray(model.tensions(l0, l0, phi1)[5])) * np.ones(m)
    return y0, atol0, series, T0, E0, R0


def _trial_pressures(model, lay, l0) -> np.ndarray:
    """Every region's own spherical-cap trial pressure at its per-layer voltage, ``(K, m)``
    (:func:`~coexist.shooting.trial_pressure`, one call: its cap angle costs per call, not per column)."""
    return np.reshape(trial_pressure(model, np.tile(l0, lay.f.size), lay.phi.reshape(-1)), (lay.f.size, l0.size))


def _take_pole(pole, cols):
    """:func:`_pole_start`'s values of the states ``cols``."""
    y0, atol0, series, T0, E0, R0 = pole
    return (
        y0[:, cols],
        atol0[:, cols],
        None if series is None else [np.broadcast_to(x, T0.shape)[cols] for x in series],
        T0[cols],
        E0[cols],
        R0[cols],
    )


#: the rows of the plain equations (``"radius"``) in the 19-row layout of ``"radius_sens"``
_PLAIN_ROWS = np.r_[0:7, 17:19]
#: a Newton iteration integrates its pole region first to this fraction below the first interface and keeps it
#: (:class:`_Warm`): a later pass takes it up from there (a few steps instead of the whole region)
POLE_MARGIN = 0.02
#: the smallest interface scale ``s`` a Newton iteration tries (:func:`_newton`): its pole region, kept to
#: ``(1 − POLE_MARGIN) s f1``, ends this many series radii from the pole. Below, it would end inside the series
#: radius: integrated backwards, towards the singular pole, to a meaningless failure. There the zone is flat: its
#: stretches differ from the unpressurised zone's by ``O((p̂t s/T̂)²)`` (~1e-6 on a prestretched inner circle), so a
#: state whose clamp is still reached before the rim has a pole stretch below the flat zone's (``BELOW_FLAT``)
SCALE_FLOOR = 2.0
#: the interface scale at which :data:`SCALE_FLOOR` lies at most: a pole region too small for it at the shooting's
#: series radius starts its series nearer the pole instead (:func:`pole_series_radius`). States lie near ``s = 1``
#: (the trial pressure puts the clamp there) and down to ~1e-2 near a prestretched zone's flat end; an electrode
#: disc of fraction 1e-4 had put the floor at ``s ≈ 6.5`` (two series radii of 3.2e-4 over the disc), above every
#: state, and its whole curve was called ``BELOW_FLAT`` (helper-95)
FLOOR_SCALE_MAX = 1e-2
#: the first step of a region after an interface at ``R̂i``, as a fraction of ``R̂i`` (Hairer's estimate there,
#: measured on the headline curve at rtol 1e-10: 0.065–0.10; the step control corrects it in an attempt or two)
OUTER_FIRST_STEP = 0.07
#: the interface jump's Newton iteration from the last pass's ``λ1⁺`` takes the next iterate once a step is below
#: this relative size (the next error ~ step², at rounding; :func:`_jump`)
QUICK_JUMP_STEP = 1e-8
#: Newton iterations of the interface jump from the last pass's ``λ1⁺`` at most (then :func:`interface_stretch`)
QUICK_JUMP_ITERATIONS = 5


class _Warm:
    """What the Newton passes on the interface scale of one call keep for each other, per state of the iteration:
    the pole region integrated up to a radius ``R`` just below the first interface (the packed attempt-function
    states ``X``, :func:`_pole_region`; the pole region does not depend on ``s`` and its start is the same in
    every pass at fixed ``p̂t``), and the stretch ``λ1⁺`` across every interface (the start of the next pass's
    jump, :func:`_jump`)."""

    def __init__(self, m: int):
        self.X: np.ndarray | None = None
        self.R = np.full(m, np.nan)
        self.l1: dict = {}

    def jump_guess(self, k: int, cols):
        """The last ``λ1⁺`` across interface ``k`` of the states ``cols`` (NaN where none), or None."""
        g = self.l1.get(k)
        return None if g is None else g[cols]

    def keep_jump(self, k: int, cols, l1) -> None:
        """Keep ``λ1⁺`` across interface ``k`` of the states ``cols``."""
        self.l1.setdefault(k, np.full(self.R.size, np.nan))[cols] = l1


def _pole_region(fns, warm, R0, y0, t1, rtol, atol, max_steps, start) -> _AttemptResult:
    """The pole region of every column up to ``t1 = s f1`` by the attempt function (:func:`_attempt_region`), taken
    up from the kept integration (``warm = (_Warm, the columns' states)``) where it stops below ``t1``. Elsewhere it
    is integrated from the pole to ``(1 − POLE_MARGIN) t1`` (kept) and then on to ``t1``: a later pass with a
    slightly different ``s`` costs a step or two. The steps from the kept radius on are the same DOP853 steps as
    one integration's would be after a node there (the state differs from one integration to ``t1`` at the level
    of the integration's tolerance)."""
    from .shooting import _H

    store, cols = warm
    kept = store.R[cols]
    fresh = np.flatnonzero(~(np.isfinite(kept) & (kept <= t1)))
    if fresh.size:
        t_mid = (1.0 - POLE_MARGIN) * t1[fresh]
        part = _attempt_region(
            fns,
            "radius",
            R0[fresh],
            y0[:, fresh],
            t_mid,
            rtol[fresh],
            atol[:, fresh],
            max_steps,
            tuple(a[fresh] for a in start),
            False,
            R0[fresh],  # the first step the series radius itself, as the uniform shooting's
        )
        if store.X is None:
            store.X = np.full((part.X.shape[0], store.R.size), np.nan)
        store.X[:, cols[fresh]] = part.X
        store.R[cols[fresh]] = np.where(part.status == _int.REACHED_END, t_mid, np.nan)
    X = store.X[:, cols].copy()
    steps_before = X[_H["steps"]].copy()
    steps_before[fresh] = 0.0  # a fresh column counts its steps from the pole
    go = np.flatnonzero(X[_H["status"]] == _int.REACHED_END)
    X[_H["t_end"], go] = t1[go]
    X[_H["status"], go] = 0.0
    return _attempt_run(fns, "radius", X, False, steps_before.astype(int))


def _jump(model, l1_in, l2, phi_in, n_in, phi_out, n_out, T1_in, guess):
    """:func:`interface_stretch` (``T1_in`` = ``T̂1(λ1⁻, λ2; Φ̂⁻)``), by Newton's method from ``guess`` (the last pass's
    ``λ1⁺``) where there is one: a column whose step falls below :data:`QUICK_JUMP_STEP` ``λ1⁺`` on the stable branch
    with a residual below ``1e-6`` of the force within :data:`QUICK_JUMP_ITERATIONS` takes the next iterate (the
    root to rounding: the convergence is quadratic, the next error ``~ step²``); the others are solved by
    :func:`interface_stretch`."""
    if guess is None:
        return interface_stretch(model, l1_in, l2, phi_in, n_in, phi_out, n_out)
    x = np.where(np.isfinite(guess), guess, l1_in)
    target = n_in * T1_in / n_out
    l1_b, l2_b, phi_b = (np.asarray(a, dtype=float) for a in np.broadcast_arrays(l1_in, l2, phi_out))
    done = np.zeros(x.size, dtype=bool)
    out = np.full(x.size, np.nan)
    todo = np.flatnonzero(np.isfinite(guess) & np.isfinite(target))
    # interface_stretch's first bracket from λ1⁻: [λ1⁻, 2λ1⁻] (or [λ1⁻/2, λ1⁻]), good at once where T̂1 − target changes
    # sign across it with ∂T̂1/∂λ1 > 0 at the upper end; its ends are evaluated with the first iterate
    g_in = np.full(x.size, np.nan)
    first_lo, first_hi, first_ok = np.full(x.size, np.nan), np.full(x.size, np.nan), np.zeros(x.size, dtype=bool)
    for it in range(QUICK_JUMP_ITERATIONS):
        if todo.size == 0:
            break
        m = todo.size
        if it == 0:
            pts = np.concatenate([x[todo], l1_b[todo], 0.5 * l1_b[todo], 2.0 * l1_b[todo]])
            T1, T11 = _meridional_tension(model, pts, np.tile(l2_b[todo], 4), np.tile(phi_b[todo], 4))
            T1 = T1 - np.tile(target[todo], 4)
            g, d = T1[:m], T11[:m]
            gi, gh, gd = T1[m : 2 * m], T1[2 * m : 3 * m], T1[3 * m :]
            g_in[todo] = gi
            below = gi < 0
            first_lo[todo] = np.where(below, l1_b[todo], 0.5 * l1_b[todo])
            first_hi[todo] = np.where(gi > 0, l1_b[todo], 2.0 * l1_b[todo])
            g_lo, g_hi = np.where(below, gi, gh), np.where(gi > 0, gi, gd)
            d_hi = np.where(gi > 0, T11[m : 2 * m], T11[3 * m :])
            first_ok[todo] = (g_lo < 0) & (g_hi > 0) & (d_hi > 0)
            first_hi[todo], first_ok[todo] = _below_first_maximum(
                model, l1_b[todo], first_hi[todo], l2_b[todo], phi_b[todo], target[todo], first_ok[todo]
            )
        else:
            g, d = _meridional_tension(model, x[todo], l2_b[todo], phi_b[todo])
            g = g - target[todo]
        with np.errstate(all="ignore"):
            step = g / d
        nxt = x[todo] - step
        fine = np.isfinite(nxt) & (d > 0)
        # Newton's next error is ~(T̂111/2T̂11) step²: a step below 1e-8 λ1 leaves ~1e-16 λ1, the root to rounding
        small = np.abs(g) <= 1e-6 * np.maximum(1.0, np.abs(target[todo]))
        conv = fine & small & (np.abs(step) <= QUICK_JUMP_STEP * np.abs(x[todo]))
        out[todo[conv]] = nxt[conv]
        done[todo[conv]] = True
        x[todo] = np.where(fine, nxt, x[todo])
        todo = todo[fine & ~conv]
    # a quick root counts only where interface_stretch would find it: inside the bracket it widens from λ1⁻ on the
    # stable branch (from a neighbour's λ1⁺ Newton can reach a far, stiffening branch that interface_stretch refuses
    # because the widening meets ∂T̂1/∂λ1 ≤ 0 first: the start would change which states exist). The bracket's first
    # ends were evaluated with the first Newton iterate; only a column whose bracket must widen costs more.
    quick = np.flatnonzero(done)
    if quick.size:
        lo, hi, ok = first_lo[quick], first_hi[quick], first_ok[quick]
        wide = np.flatnonzero(~first_ok[quick])
        if wide.size:
            cols = quick[wide]
            lo[wide], hi[wide], ok[wide] = _stable_bracket(
                model, l1_b[cols], g_in[cols], l2_b[cols], phi_b[cols], target[cols]
            )
        inside = ok & (out[quick] > lo) & (out[quick] < hi)
        done[quick[~inside]] = False
    rest = np.flatnonzero(~done)
    if rest.size:
        sub = (a[rest] for a in np.broadcast_arrays(l1_in, l2, phi_in, n_in, phi_out, n_out))
        out[rest], _ = interface_stretch(model, *sub)
    return out, np.isfinite(out)


def _pass(
    model, settings, lay, l0, p_t, sigma, rtol, track: bool, lam_cols=None, fast=None, pole=None, warm=None, slope=True
):
    """One shooting of every state with the interfaces at ``s fi`` (``s = e^σ``): the clamp radius ``R*``, the
    slope ``dR*/ds``, the quadratures, the tracked tensions, and a status per state (0 where it reached the
    clamp).

    ``lam_cols`` (bool per column, or None): the derivative pass (:func:`_derivative_pass`). Every region is
    then integrated with the variational equations: rows 7–11 carry ``Z = ∂(λ1, λ2, θ, V̂/π, Q̂/2π)/∂a`` at
    fixed ``R̂`` for ``a = λ0`` (columns where ``lam_cols``, from the pole's series) or ``a = s`` (the others,
    zero in the pole region), rows 12–16 carry ``U = nk ∂(…)/∂Φ̂`` (``U' = (∂f/∂y)U + ∂f/∂φ`` at the
    region's ``φ = Φ̂/nk``), and the last return value holds, per column, ``Z`` and ``U/nK`` at the clamp and
    the right-hand side there (``(15, m)``: rows 0–4 ``Z``, 5–9 ``∂/∂Φ̂``, 10–14 ``f``)."""
    fns = _integrators(model)
    K = lay.f.size
    m = l0.size
    s = np.exp(sigma)
    lam_clamp = model.prestretch
    status = np.zeros(m, dtype=int)
    steps = np.zeros(m, dtype=int)
    tracker = _Tracker(m)
    # both sides of every interface: (R̂, r̂, ẑ from the pole, θ, n T̂1), in the trial membrane's units
    edges = np.full((m, K - 1, 2, 5), np.nan)
    deriv = lam_cols is not None
    ends = np.full((15, m), np.nan)
    if pole is None:
        pole = _pole_start(model, settings, lay, l0, p_t)
    y0, atol0, series, T0, E0, R0 = pole
    y0 = y0.copy()
    tracker.node[:, :] = np.vstack([R0, lay.n[0] * T0, lay.n[0] * T0, np.zeros(m), np.zeros(m)])
    tracker.min_T[:] = lay.n[0] * T0
    tracker.where_R[:] = 0.0
    tracker.kind[:] = 1
    tracker.max_E[:] = E0
    atol_state = atol0[:7]
    if deriv:
        # the sensitivities start from the series (to λ0; to s: zero), U = n1 ∂/∂Φ̂ = ∂/∂φ1 (0 without electrode)
        e1 = 1.0 if lay.electrode[0] else 0.0
        y0 = np.vstack([y0[:7], np.zeros((10, m)), y0[7:9]])
        for i in range(5):
            y0[7 + i] = np.where(lam_cols, series[7 + i], 0.0)
            y0[12 + i] = e1 * series[12 + i]
    # a region without electrode: its charge row does not change (φ = 0), but U's charge row would gain
    # ∂(q̂R̂)/∂φ = λ1²λ2²R̂ there; U_Q is held at its value from the region's start (u_q)
    u_q = np.zeros(m)

    def make_event(region, cols_all, check_clamp, t_end, kind, y_start):
        if track:
            tracker.set_states(cols_all, y_start)

        def event(R, y, cols, f):
            c = cols_all[cols]
            side = np.where(R >= t_end[cols], 1, 0)
            T1, T2, T11, T12, margin, E, T22 = (
                np.asarray(a) * np.ones_like(R) for a in model.tensions(y[0], y[1], y[-1])
            )
            below = y[1] <= lam_clamp
            crossed = below if check_clamp else np.zeros(R.size, dtype=bool)
            code = _failure_codes(y, T1, T11, margin)
            code[crossed] = 0
            if not check_clamp:  # the clamp stretch reached before the last region: the interfaces lie too far out
                code[(code == 0) & below] = _EARLY_CLAMP
            keep = ~crossed
            if track and keep.any():
                n = lay.n[region, c]
                node = np.vstack([R, n * T1, n * T2, n * (T11 * f[0] + T12 * f[1]), n * (T12 * f[0] + T22 * f[1])])
                tracker.add(
                    c[keep], node[:, keep], np.abs(E)[keep], region, side[keep], y[:, keep], (fns, model, kind, n[keep])
                )
            res = np.where(code != 0, _int.FAILED + code, _int.CONTINUE)
            res[crossed] = _int.CROSSED
            return res

        return event

    # region 1: from the pole to s f1 (no sensitivity: the pole region does not depend on s)
    live = np.arange(m)
    kind0 = "radius_sens" if deriv else "radius"
    atol_r1 = np.vstack([atol_state, np.full((y0.shape[0] - 7, m), np.inf)])
    if fast is None:
        fast = _attempts_serve(fns, m)
    if fast:
        # the pole node: both tensions T̂0 (per layer), no slope (even in R̂)
        start = (T0, T0, np.zeros(m), np.zeros(m), tracker.max_E.copy())
        t1 = s * lay.f[0]
        if warm is None or deriv:
            res = _attempt_region(
                fns, kind0, R0.copy(), y0, t1, rtol, atol_r1, settings.max_steps, start, False, R0.copy()
            )
        else:
            res = _pole_region(fns, warm, R0, y0, t1, rtol, atol_r1, settings.max_steps, start)
        _track_attempts(tracker, res, live, lay.n[0], 0, track, (fns, model))
    else:
        res = _int.integrate(
            _stepper(fns, kind0, m),
            R0.copy(),
            y0,
            s * lay.f[0],
            rtol,
            atol_r1,
            settings.max_steps,
            event=make_event(0, live, False, s * lay.f[0], kind0, y0),
            h0=R0.copy(),
        )
    steps += res.steps
    status[res.status == _int.STEP_LIMIT] = STEP_LIMIT
    failed = res.status >= _int.FAILED
    status[failed] = res.status[failed] - _int.FAILED
    stop_R = np.where(failed, res.t, np.nan)
    status[(status == 0) & (res.status != _int.REACHED_END)] = NOT_FINITE
    y = res.y
    # the sensitivity rows S = ∂(λ1, λ2, θ, V̂/π, Q̂/2π)/∂s (rows 7–11 of the 19-row layout; rows 12–16 unused)
    if deriv:
        Y = y.copy()
    else:
        Y = np.zeros((19, m))
        Y[:7] = y[:7]
        Y[17] = y[7]
        Y[18] = y[8]
    psi_n = lay.n[0].copy()  # the Ψ̂ row holds Ψ̂/(2π n) of the current region
    dRs = np.full(m, np.nan)
    R_star = np.full(m, np.nan)
    quad = np.full((4, m), np.nan)
    sens = np.ones(m, dtype=bool) if deriv else np.broadcast_to(np.asarray(slope, dtype=bool), (m,))
    for k in range(1, K):
        go = np.flatnonzero(status == 0)
        if go.size == 0:
            break
        R_i = s[go] * lay.f[k - 1]
        Yg = Y[:, go]
        n_in, n_out = lay.n[k - 1, go], lay.n[k, go]
        phi_in, phi_out = lay.phi[k - 1, go], lay.phi[k, go]
        f_in = np.asarray(model.rhs(R_i, Yg[0], Yg[1], Yg[2], Yg[17], phi_in))
        T_in = [np.asarray(a) * np.ones_like(R_i) for a in model.tensions(Yg[0], Yg[1], phi_in)]
        guess = None if warm is None else warm[0].jump_guess(k, warm[1][go])
        l1p, ok = _jump(model, Yg[0], Yg[1], phi_in, n_in, phi_out, n_out, T_in[0], guess)
        status[go[~ok]] = LOST_ELLIPTICITY
        if warm is not None:
            warm[0].keep_jump(k, warm[1][go], l1p)
        # the jump's Jacobian on (λ1, λ2, θ): λ1⁺ = g(λ1⁻, λ2)
        T_out = [np.asarray(a) * np.ones_like(R_i) for a in model.tensions(l1p, Yg[1], phi_out)]
        T11i, T12i, T11o, T12o = T_in[2], T_in[3], T_out[2], T_out[3]
        g1 = n_in * T11i / (n_out * T11o)
        g2 = (n_in * T12i - n_out * T12o) / (n_out * T11o)
        S_in = Yg[7:10] + f_in[:3] * lay.f[k - 1]
        Yn = Yg.copy()
        Yn[0] = l1p
        Yn[17] = p_t[go] / n_out
        Yn[18] = phi_out
        Yn[5] = Yg[5] * n_in / n_out
        psi_n[go] = n_out
        f_out = np.asarray(model.rhs(R_i, Yn[0], Yn[1], Yn[2], Yn[17], phi_out))
        if deriv:
            _jump_sensitivities(model, lay, k, go, lam_cols, Yg, Yn, f_in, f_out, g1, g2, T11o, l1p, u_q)
        else:
            Yn[7] = g1 * S_in[0] + g2 * S_in[1] - f_out[0] * lay.f[k - 1]
            Yn[8] = S_in[1] - f_out[1] * lay.f[k - 1]
            Yn[9] = S_in[2] - f_out[2] * lay.f[k - 1]
            Yn[10:17] = 0.0
        Y[:, go] = Yn
        N_in = n_in * T_in[0]
        N_out = n_out * T_out[0]
        for side, (YY, N) in enumerate(((Yg, N_in), (Yn, N_out))):
            edges[go, k - 1, side] = np.stack([R_i, YY[1] * R_i, YY[6], YY[2], N], axis=-1)
        # the region's first node (its interface, clamp side): per-layer tensions and slopes, field
        T1s, T2s, T11s, T12s, _, Es, T22s = T_out
        fo = f_out
        first = (T1s, T2s, T11s * fo[0] + T12s * fo[1], T12s * fo[0] + T22s * fo[1], np.abs(Es))
        if track:
            n = lay.n[k, go]
            node = np.vstack([R_i, n * first[0], n * first[1], n * first[2], n * first[3]])
            # the pole side of the edge: the last node of region k−1 (already recorded), re-marked as an edge
            tracker.start(go[ok], node[:, ok], first[4][ok], k)
        last = k == K - 1
        # integrated with the variational equations where the slope dR*/ds is asked for, without elsewhere
        landing: list = []
        for group in (ok & sens[go], ok & ~sens[go]):
            if not group.any():
                continue
            cols = go[group]
            with_s = bool(sens[cols[0]])
            rows = slice(None) if with_s else _PLAIN_ROWS
            kind = "radius_sens" if with_s else "radius"
            Rg = R_i[group]
            t_end = s[cols] * (min(LAST_REGION_REACH, settings.max_radius_factor) if last else lay.f[k])
            yk = Y[rows][:, cols]
            atol = np.vstack([atol_state[:, cols], np.full((yk.shape[0] - 7, cols.size), np.inf)])
            if fast:
                start = tuple(a[group] for a in first)
                res = _attempt_region(
                    fns, kind, Rg, yk, t_end, rtol[cols], atol, settings.max_steps, start, last, OUTER_FIRST_STEP * Rg
                )
                _track_attempts(tracker, res, cols, lay.n[k, cols], k, track, (fns, model))
            else:
                res = _int.integrate(
                    _stepper(fns, kind, cols.size),
                    Rg,
                    yk,
                    t_end,
                    rtol[cols],
                    atol,
                    settings.max_steps,
                    event=make_event(k, cols, last, t_end, kind, yk),
                    h0=OUTER_FIRST_STEP * Rg,
                )
            steps[cols] += res.steps
            st = np.zeros(cols.size, dtype=int)
            st[res.status == _int.STEP_LIMIT] = STEP_LIMIT
            fl = res.status >= _int.FAILED
            st[fl] = res.status[fl] - _int.FAILED
            stop_R[cols[fl]] = res.t[fl]
            if last:
                st[res.status == _int.REACHED_END] = _FAR_CLAMP
                st[(st == 0) & (res.status != _int.CROSSED)] = NOT_FINITE
            else:
                st[(st == 0) & (res.status != _int.REACHED_END)] = NOT_FINITE
            status[cols] = st
            if with_s:
                Y[:, cols] = res.y
            else:
                Y[:7, cols] = res.y[:7]
                Y[17:19, cols] = res.y[7:9]
            if last:
                land = np.flatnonzero(st == 0)
                landing.append((cols[land], res.t[land], np.full(land.size, with_s)))
        if landing and sum(c.size for c, _, _ in landing):
            # both groups land in one call (its cost is per call more than per column)
            idx, R_h, slope_cols = (np.concatenate(a) for a in zip(*landing))
            _land(
                fns,
                model,
                settings,
                idx,
                R_h,
                Y[:, idx],
                rtol,
                np.vstack([atol_state[:, idx], np.full((12, idx.size), np.inf)]),
                status,
                steps,
                R_star,
                dRs,
                quad,
                psi_n,
                tracker if track else None,
                lay,
                K - 1,
                (ends, u_q) if deriv else None,
                slope=slope_cols,
            )
    if K == 1:  # not used (one region is a uniform zone), kept for completeness
        raise AssertionError("a one-region pattern is shot by solve_states")
    tracker.edges = edges
    return R_star, dRs, quad, status, steps, tracker, stop_R, ends


def _single_step(stepper, t, y, h, rtol, atol):
    """:func:`coexist.numerics.dop853.single_step` without the numpy right-hand side at the start when the stepper
    is a CasADi step function (which evaluates its first stage itself): the same step and error norm."""
    f = None if isinstance(stepper, _int.CasadiStepper) else stepper.rhs(t, y)
    y_new, _, e5, e3 = stepper.step(t, y, f, h)
    scale = atol + np.maximum(np.abs(y), np.abs(y_new)) * np.asarray(rtol)
    err = np.where(np.all(np.isfinite(y_new), axis=0), _int._error_norm(e5, e3, h, scale), np.inf)
    return y_new, err


def _in_halves(fns, kind, t0, y0, t_end, rtol, atol, max_steps):
    """From ``t0`` to ``t_end`` (a step that was rejected in one) in two halves by the compiled step function, as
    :func:`coexist.numerics.dop853.integrate` from ``h0 = (t_end − t0)/2`` does it where its second step is the
    rest (no Python loop, no numpy right-hand side); a column where a half is rejected is integrated adaptively.

    Returns
    -------
    y, steps, reached : ndarray
        The states at ``t_end``, the steps taken and whether ``t_end`` was reached, per column.
    """
    stepper = _stepper(fns, kind, t0.size)
    h = 0.5 * (t_end - t0)
    y_mid, e1 = _single_step(stepper, t0, y0, h, rtol[None, :], atol)
    y, e2 = _single_step(stepper, t0 + h, y_mid, t_end - (t0 + h), rtol[None, :], atol)
    steps = np.full(t0.size, 2)
    reached = np.ones(t0.size, dtype=bool)
    rest = np.flatnonzero(~((e1 <= 1.0) & (e2 <= 1.0)))
    if rest.size:
        hop = _int.integrate(
            _stepper(fns, kind, rest.size),
            t0[rest],
            y0[:, rest],
            t_end[rest],
            rtol[rest],
            atol[:, rest],
            max_steps,
            h0=np.abs(h[rest]),
        )
        y[:, rest], steps[rest], reached[rest] = hop.y, hop.steps, hop.status == _int.REACHED_END
    return y, steps, reached


def _land(
    fns,
    model,
    settings,
    idx,
    R_h,
    y_h,
    rtol,
    atol,
    status,
    steps,
    R_star,
    dRs,
    quad,
    psi_n,
    tracker,
    lay,
    k,
    ends=None,
    slope=True,
):
    """The last step onto the clamp with ``λ2`` as the independent variable, then (``slope``, a bool or one per
    column: those integrated with the variational equations, rows 7–16 of ``y_h``) the sensitivity carried to
    ``R*`` (:func:`_clamp_sensitivity`: ``dR*/ds``, and with ``ends`` those of the derivative pass)."""
    lam_clamp = model.prestretch
    z0 = np.vstack([R_h, y_h[0], y_h[2:7], y_h[17:19]])
    atol_h = np.vstack([np.full(idx.size, settings.atol), atol[0], atol[2:7], np.full((2, idx.size), np.inf)])
    hoop = _stepper(fns, "hoop", idx.size)
    zf, err = _single_step(hoop, y_h[1], z0, lam_clamp - y_h[1], rtol[idx][None, :], atol_h)
    landed = err <= 1.0
    steps[idx] += 1
    redo = np.flatnonzero(~landed)
    if redo.size:
        zf[:, redo], n_redo, landed[redo] = _in_halves(
            fns,
            "hoop",
            y_h[1][redo],
            z0[:, redo],
            np.full(redo.size, lam_clamp),
            rtol[idx][redo],
            atol_h[:, redo],
            settings.max_steps,
        )
        steps[idx[redo]] += n_redo
    bad = ~landed | np.any(~np.isfinite(zf), axis=0) | (zf[0] <= R_h)
    status[idx[bad]] = NOT_FINITE
    good = ~bad
    if not good.any():
        return
    gi = idx[good]
    zg = zf[:, good]
    R = zg[0]
    f = np.asarray(model.rhs(R, zg[1], lam_clamp, zg[2], zg[7], zg[8]))
    R_star[gi] = R
    with_s = np.broadcast_to(np.asarray(slope, dtype=bool), idx.shape)
    sel = with_s[good]
    if sel.all():
        _clamp_sensitivity(fns, settings, gi, good, R, R_h, y_h, rtol, atol, steps, f, dRs, lay, k, ends)
    elif sel.any():
        sub = good & with_s
        _clamp_sensitivity(
            fns, settings, gi[sel], sub, R[sel], R_h, y_h, rtol, atol, steps, f[:, sel], dRs, lay, k, ends
        )
    fV, fQ, fPsi, _ = QUADRATURE_FACTORS
    quad[0, gi] = fV * zg[3]
    quad[1, gi] = fQ * zg[4]
    quad[2, gi] = fPsi * zg[5] * psi_n[gi]
    quad[3, gi] = zg[6]
    if tracker is not None:
        y_clamp = np.vstack([zg[1], np.full(gi.size, lam_clamp), zg[2]])
        node, E = tracker.values(model, R, y_clamp, f, lay.n[k, gi], zg[8])
        tracker.add(gi, node, E, k, side=1)


def _clamp_sensitivity(fns, settings, gi, good, R, R_h, y_h, rtol, atol, steps, f, dRs, lay, k, ends) -> None:
    """The sensitivities carried from the last node onto the clamp ``R*`` (one step in ``R̂``, its state rows not
    used): ``dR*/ds = −S_λ2/λ2'`` into ``dRs``; ``ends = (array, u_q)`` (the derivative pass): the sensitivities at
    the clamp and the right-hand side ``f`` there, into ``array`` (see :func:`_pass`)."""
    stepper = _stepper(fns, "radius_sens", gi.size)
    y_end, err = _single_step(stepper, R_h[good], y_h[:, good], R - R_h[good], rtol[gi][None, :], atol[:, good])
    steps[gi] += 1
    again = np.flatnonzero(~(err <= 1.0))
    if again.size:
        y_end[:, again], n_again, _ = _in_halves(
            fns,
            "radius_sens",
            R_h[good][again],
            y_h[:, good][:, again],
            R[again],
            rtol[gi][again],
            atol[:, good][:, again],
            settings.max_steps,
        )
        steps[gi[again]] += n_again
    dRs[gi] = -y_end[8] / f[1]
    if ends is not None:
        arr, u_q = ends
        n_last = lay.n[k, gi]
        if not lay.electrode[k]:
            y_end[16] = u_q[gi]
        arr[0:5, gi] = y_end[7:12]
        arr[5:10, gi] = y_end[12:17] / n_last
        arr[10:15, gi] = np.asarray(f[:5]) * np.ones(gi.size)


# --- the states -------------------------------------------------------------------------------------------


def _layout(pattern: ZonePattern, phi: np.ndarray) -> _Layout:
    n = np.array([[r.layers] for r in pattern.regions], dtype=float) * np.ones((1, phi.size))
    on = np.array([[1.0 if r.electrode else 0.0] for r in pattern.regions])
    return _Layout(
        n=n,
        phi=on * phi[None, :] / n,
        f=np.array([r.outer for r in pattern.regions]),
        electrode=tuple(r.electrode for r in pattern.regions),
    )


def _uniform(model, pattern, l0, phi, settings, derivatives=False, formal=False) -> PatternedStates:
    """A one-region pattern: :func:`~coexist.shooting.solve_states` at ``Φ̂/n`` (or 0), scaled to the stack.

    With ``φ = e Φ̂/n`` (``e = 1`` with electrode, else 0): ``p̂ = n p̂1(λ0, φ)``, ``V̂ = V̂1``, ``Q̂ = e Q̂1``, so
    ``∂p̂/∂λ0 = n ∂p̂1/∂λ0``, ``∂p̂/∂Φ̂ = e ∂p̂1/∂φ``, ``∂V̂/∂Φ̂ = (e/n) ∂V̂1/∂φ``, ``∂Q̂/∂λ0 = e ∂Q̂1/∂λ0``,
    ``∂Q̂/∂Φ̂ = (e/n) ∂Q̂1/∂φ``."""
    region = pattern.regions[0]
    n = float(region.layers)
    e = 1.0 if region.electrode else 0.0
    per_layer = phi / n if region.electrode else np.zeros_like(phi)
    st = solve_states(model, l0, per_layer, settings, derivatives=derivatives, formal=formal)
    detail = [None if s == OK else reason_text(s) for s in st.status]
    deriv = None
    if st.derivatives is not None:
        d = st.derivatives
        deriv = StateDerivatives(
            dp_dl0=n * d.dp_dl0,
            dv_dl0=d.dv_dl0,
            dq_dl0=e * d.dq_dl0,
            dp_dphi=e * d.dp_dphi,
            dv_dphi=e / n * d.dv_dphi,
            dq_dphi=e / n * d.dq_dphi,
        )
    return _patterned(
        MembraneStates(
            pole_stretch=l0,
            phi_hat=phi,
            p_hat=n * st.p_hat,
            v_hat=st.v_hat,
            q_hat=st.q_hat,
            psi_hat=n * st.psi_hat,
            apex_height=st.apex_height,
            max_field=st.max_field,
            min_tension=n * st.min_tension,
            clamp_radius=st.clamp_radius,
            status=st.status,
            fail_radius=st.fail_radius,
            steps=st.steps,
            wrinkled_radii=st.wrinkled_radii,
            derivatives=deriv,
        ),
        detail,
    )


def _detail_of_tension(pattern, T, R_rel, kind, region, side) -> str:
    reg = pattern.regions[region]
    name = "hoop" if kind == 2 else "meridional"
    where = f"at R/A = {R_rel:.6g} in region {region + 1} ({reg.describe()})"
    if side == -1 and region > 0:
        where += f", on its side of the edge at R/A = {pattern.regions[region - 1].outer:g}"
    elif side == 1 and region < len(pattern.regions) - 1:
        where += f", on its side of the edge at R/A = {reg.outer:g}"
    elif side == 1:
        where += ", at the clamp"
    return f"the {name} tension of the stack falls to {T:.4g} μH {where}: the membrane wrinkles"


def solve_patterned_states(
    model: MembraneModel,
    pattern: ZonePattern,
    pole_stretch,
    phi_hat=0.0,
    settings: SolverSettings | None = None,
    scale_guess=None,
    derivatives: bool = False,
    formal: bool = False,
) -> PatternedStates:
    """Equilibrium states of a patterned, layered zone at the given pole stretches and voltage.

    Region ``k`` (``nk`` layers, electrode or not) obeys the one-layer equations with ``p̂/nk`` and ``Φ̂/nk``
    (``0`` without electrode); at the interfaces ``r, z, θ, λ2`` are continuous and ``λ1`` jumps so that the
    meridional force per reference hoop length ``nk T̂1`` is continuous. The interface scale ``s`` is found by
    Newton's method per state (module docstring); the result is the unit membrane
    ``p̂ = p̂t R*``, ``V̂ = V̂t/R*³``, ``Q̂ = Q̂t/R*²``, ``Ψ̂ = Ψ̂t/R*²``, ``ẑ = ẑt/R*`` with ``Q̂`` over the
    electrode only and ``Ψ̂ = Σ nk ∫ W*(λ1, λ2; Φ̂/nk) dA``.

    Parameters
    ----------
    model : MembraneModel
        The membrane material (every layer is one such membrane).
    pattern : ZonePattern
        The regions.
    pole_stretch : array_like
        Pole stretches ``λ0 > λpre``.
    phi_hat : float or array_like
        Normalised voltage ``Φ̂ = (Φ/H)√(ε/μ)`` of the electrode (``H`` one layer's thickness), ``≥ 0``,
        broadcast against ``pole_stretch``.
    settings : SolverSettings, optional
        Tolerances (``rtol``) and limits; default ``SolverSettings()``.
    scale_guess : array_like, optional
        Starting ``ln s`` per state (e.g. from converged neighbours along a curve); default 0.
    derivatives : bool
        Also return the exact first derivatives of ``p̂, V̂, Q̂`` with respect to ``λ0`` and ``Φ̂``
        (:class:`~coexist.shooting.StateDerivatives`, as :func:`~coexist.shooting.solve_states` gives them):
        one more shooting at the converged interface scale with the variational equations to ``λ0``, ``Φ̂``
        and ``s`` carried through every region and mapped across every interface, and the scale's own
        dependence from the implicit function theorem on ``ln R*(s; λ0, Φ̂) = ln s`` (:func:`_derivative_pass`,
        docs/physics.md section 12). About 1.3 times the cost of the states alone.
    formal : bool
        Keep a converged state whose hoop tension is not positive somewhere (its ``min_tension`` then goes
        smoothly through zero), as :func:`~coexist.shooting.solve_states` does: such a state is not a membrane
        equilibrium; it is only for locating the onset of wrinkling as the root of a smooth function.

    Returns
    -------
    PatternedStates
        Failed states are flagged by ``status`` (with ``failure_detail``); a state with a non-positive
        tension anywhere is ``WRINKLED``, never returned as a state. ``derivatives`` is set (NaN where a
        state failed) when asked for.

    Raises
    ------
    SceneError
        If the pattern is not a :class:`ZonePattern`, a pole stretch is not above ``λpre``, a voltage is
        negative or not finite, or not zero for a model without electrostatics.

    Examples
    --------
    >>> from coexist import MembraneModel
    >>> st = solve_patterned_states(MembraneModel(), ZonePattern.full(layers=2), [2.0], 0.0)
    >>> round(float(st.p_hat[0]) / 2, 6)  # two layers carry twice the pressure of one
    1.869555
    """
    return _solve(model, pattern, pole_stretch, phi_hat, settings, scale_guess, derivatives, formal)[0]


def _solve(
    model,
    pattern,
    pole_stretch,
    phi_hat,
    settings,
    scale_guess,
    derivatives,
    formal,
    hint=None,
    stage=None,
    starts=None,
):
    """:func:`solve_patterned_states`, with what a curve keeps of its converged states for the next calls.

    ``hint`` (optional, from :func:`patterned_pressure_volume_curve`): ``{"slope": dG/dσ per state (NaN where
    none), "jump": {k: λ1⁺ across interface k per state}}``, values interpolated from converged neighbours
    (:func:`_newton`: a start, never a result). Returns the states and ``{"slope": the last exact dG/dσ of each
    converged state (NaN where only a hinted one served), "jump": {k: its λ1⁺}, "warm": the states started from
    ``starts``}`` (empty for one region).

    ``stage`` (optional, from :func:`patterned_pressure_volume_curve`): ``(later, start)``, a mask of the states
    that join the Newton iteration only once the others are nearly converged, started by ``start(λ0 known, σ
    known, exact slopes known, {k: λ1⁺ known}, λ0 of the joining states) -> (σ guess, hint)`` (:func:`_newton`).

    ``starts`` (optional, a continuation's :class:`ScaleStarts`; only without ``scale_guess``, ``hint`` and
    ``stage``): the states near a kept converged one start from it (the scale extrapolated to first order, its
    slope and jumps as the hint), the others from :func:`_pole_region_scale`; the converged states are kept.
    """
    validation.membrane_model(model)
    validation.instance(pattern, ZonePattern, "pattern", "a ZonePattern (e.g. ZonePattern.inner_circle(0.5))")
    if isinstance(model, PatternedModel):  # its material; the pattern is the one given here
        model = model.uniform
    settings, l0, phi = checked_state_inputs(model, pole_stretch, phi_hat, settings)
    if len(pattern.regions) == 1:
        return _uniform(model, pattern, l0, phi, settings, derivatives, formal), {}
    n_states = l0.size
    lay = _layout(pattern, phi)
    warm_started = np.zeros(n_states, dtype=bool)
    if scale_guess is not None:
        g = validation.real_array(scale_guess, "scale_guess")
        if g.size not in (1, n_states):
            raise SceneError(f"must give one value or one per state ({n_states}), got {g.size}", "scale_guess")
        sigma0 = np.broadcast_to(g, (n_states,)).astype(float).copy()
    elif stage is not None:  # the joining states are started from the others
        sigma0 = np.zeros(n_states)
        first = ~stage[0]
        sigma0[first] = _pole_region_scale(model, settings, _sub_layout(lay, first), l0[first])
    else:
        sigma0 = np.full(n_states, np.nan)
        if starts is not None and hint is None:
            warm = starts.start(model, pattern, l0, phi)
            if warm is not None:
                sigma0, hint = warm
        cold = ~np.isfinite(sigma0)  # (the cold guess is a function of each state alone: the same on a subset)
        warm_started = ~cold
        if cold.all():
            sigma0 = _pole_region_scale(model, settings, lay, l0)
        elif cold.any():
            sigma0[cold] = _pole_region_scale(model, settings, _sub_layout(lay, cold), l0[cold])
    status = np.zeros(n_states, dtype=int)
    with np.errstate(all="ignore"):
        T0, alpha, _, _, _ = (np.asarray(x, dtype=float) * np.ones(n_states) for x in model.pole(l0, lay.phi[0]))
        margin0 = np.asarray(model.tensions(l0, l0, lay.phi[0])[4]) * np.ones(n_states)
    status[l0 - model.prestretch < FLAT_LIMIT * model.prestretch] = BELOW_RESOLUTION
    status[(status == OK) & (margin0 <= LOCKING_LIMIT)] = LOCKED
    status[(status == OK) & ((T0 <= 0) | ~np.isfinite(T0))] = WRINKLED_AT_POLE
    status[(status == OK) & (alpha <= 0)] = LOST_ELLIPTICITY
    detail: list = [None] * n_states
    edges = np.full((n_states, len(pattern.regions) - 1, 2, 5), np.nan)
    for i in np.flatnonzero(status != OK):
        detail[i] = f"{reason_text(status[i])} (at the pole)"
    keys: tuple[str, ...] = ("R", "p", "V", "Q", "Psi", "z", "minT", "maxE", "failR", "sigma", "slope")
    keys += tuple(f"jump{k}" for k in range(1, len(pattern.regions)))
    out = {k: np.full(n_states, np.nan) for k in keys}
    steps = np.zeros(n_states, dtype=int)
    live = np.flatnonzero(status == OK)
    if live.size:
        with np.errstate(all="ignore"):
            _newton(
                model,
                pattern,
                settings,
                lay,
                l0,
                phi,
                sigma0,
                live,
                status,
                out,
                steps,
                detail,
                edges,
                formal,
                hint,
                None if stage is None else (stage[0][live], stage[1]),
                warm_started[live],
            )
    d_out = None
    dsig = {"l0": np.full(n_states, np.nan), "phi": np.full(n_states, np.nan)}
    exact_slope = out["slope"].copy()  # (NaN where only a hinted slope served)
    if derivatives:
        d_out = {k: np.full(n_states, np.nan) for k in ("dR_dl0", "dV_dl0", "dQ_dl0", "dR_dphi", "dV_dphi", "dQ_dphi")}
        ok = np.flatnonzero(status == OK)
        if ok.size:
            with np.errstate(all="ignore"):
                dp = _derivative_pass(model, settings, _sub_layout(lay, ok), l0[ok], out["sigma"][ok])
            steps[ok] += dp["steps"]
            for k in d_out:
                d_out[k][ok] = dp[k]
            exact_slope[ok] = dp["slope"]
            if starts is not None:  # dσ/da at fixed p̂t, and σ's share of the trial pressure's own change
                for a, v in _trial_log_slopes(model, settings, pattern, l0[ok], phi[ok]).items():
                    dsig[a][ok] = dp[f"dsigma_d{a}"] - v
            lost = ok[(dp["status"] != 0) | ~np.all(np.isfinite([dp[k] for k in d_out]), axis=0)]
            for i in lost:  # not expected: the same shooting as the converged state's
                status[i] = NOT_FINITE
                detail[i] = f"{reason_text(NOT_FINITE)} (the shooting with the variational equations)"
    bad = status != OK
    R = out["R"]
    states = MembraneStates(
        pole_stretch=l0,
        phi_hat=phi,
        p_hat=np.where(bad, np.nan, out["p"] * R),
        v_hat=np.where(bad, np.nan, out["V"] / R**3),
        q_hat=np.where(bad, np.nan, out["Q"] / R**2),
        psi_hat=np.where(bad, np.nan, out["Psi"] / R**2),
        apex_height=np.where(bad, np.nan, out["z"] / R),
        max_field=np.where(bad, np.nan, out["maxE"]),
        min_tension=np.where(bad, np.nan, out["minT"]),
        clamp_radius=np.where(bad, np.nan, R),
        status=status,
        fail_radius=np.where(bad, out["failR"], np.inf),
        steps=steps,
    )
    if d_out is not None:
        states.derivatives = clamped_derivatives(d_out, out["p"], R, states.v_hat, states.q_hat, bad)
    edges[bad] = np.nan
    if starts is not None:  # (a wrinkled state is a converged taut one too: a tension-field zone relaxes it next)
        good = np.flatnonzero(((status == OK) | (status == WRINKLED)) & np.isfinite(out["sigma"]))
        starts.keep(
            model,
            pattern,
            {
                "l0": l0[good],
                "phi": phi[good],
                "sigma": out["sigma"][good],
                "slope": exact_slope[good],
                "dsig_dl0": dsig["l0"][good],
                "dsig_dphi": dsig["phi"][good],
                "jump": {k: out[f"jump{k}"][good] for k in range(1, len(pattern.regions))},
            },
        )
    kept = {
        "warm": warm_started,
        "slope": np.where(bad, np.nan, out["slope"]),
        "jump": {k: np.where(bad, np.nan, out[f"jump{k}"]) for k in range(1, len(pattern.regions))},
    }
    return _patterned(states, detail, edges), kept


def _sub_layout(lay: _Layout, cols) -> _Layout:
    """The layout of the states ``cols``."""
    return _Layout(n=lay.n[:, cols], phi=lay.phi[:, cols], f=lay.f, electrode=lay.electrode)


def _trial(model, settings, lay, l0, tp=None):
    """The trial pressure ``p̂t`` (the area-weighted spherical-cap estimate of the stack) and the relative
    tolerance per state (``settings.rtol``, raised to what roundoff allows near the flat membrane); ``tp``: the
    regions' own trial pressures (:func:`_trial_pressures`) if the caller has them."""
    area = np.diff(np.concatenate([[0.0], lay.f**2]))
    if tp is None:
        tp = _trial_pressures(model, lay, l0)
    p_t = np.sum(area[:, None] * lay.n * tp, axis=0)
    rtol = np.maximum(settings.rtol, ROUNDOFF_TOLERANCE / (l0 / model.prestretch - 1))
    return p_t, rtol


def _trial_log_slopes(model, settings, pattern, l0, phi) -> dict:
    """``d ln p̂t/dλ0`` and ``d ln p̂t/dΦ̂`` of the trial pressure (forward differences, relative step 1e-7: a
    continuation's first-order start, :class:`ScaleStarts`, not a result). The scale ``σ = ln(R*)`` is measured
    in the trial membrane's units: at a fixed state ``R* ∝ 1/p̂t``, so ``dσ/da = (dσ/da at fixed p̂t) − d ln p̂t/da``."""
    base = np.log(_trial(model, settings, _layout(pattern, phi), l0)[0])
    h = 1e-7 * np.maximum(l0, 1.0)
    out = {"l0": (np.log(_trial(model, settings, _layout(pattern, phi), l0 + h)[0]) - base) / h}
    hp = 1e-7 * np.maximum(phi, 1.0)
    out["phi"] = (np.log(_trial(model, settings, _layout(pattern, phi + hp), l0)[0]) - base) / hp
    return out


def _pole_region_scale(model, settings, lay, l0) -> np.ndarray:
    """The starting ``σ = ln s`` of a state without a guess: ``ln(p̂1/p̂t)``, ``p̂1 = n1 p̂(λ0, Φ̂/n1)`` the pressure
    of the uniform zone made of the pole region's stack (one shooting of :func:`~coexist.shooting.solve_states`),
    ``p̂t`` the trial pressure. The pole stretch is set by the pole region, so this is closer to the converged
    scale than the trial pressure's own (``σ = 0``): measured ``|σ − σ*| ≤ 0.33`` against ``≤ 0.65`` on an
    inner circle with a two-layer annulus, a ring and a wide inner circle, a Newton iteration or two fewer.
    A deterministic function of ``(λ0, Φ̂)`` (no history: a state is the same whichever call computes it);
    ``0`` where the uniform zone has no state."""
    with np.errstate(all="ignore"):  # states past locking or wrinkled at the pole: no guess (they fail anyway)
        p_t, _ = _trial(model, settings, lay, l0)
        uni = solve_states(model, l0, lay.phi[0], settings)
        guess = np.log(lay.n[0] * uni.p_hat / p_t)
    return np.where((uni.status == OK) & np.isfinite(guess), guess, 0.0)


def _derivative_pass(model, settings, lay, l0, sigma):
    """The exact derivatives of converged states (interfaces at ``s = e^σ``, ``ln R*(s) = σ``).

    One more shooting at the converged ``σ`` (the same state to the integration tolerance: ``R*`` agrees to about
    1e-10), each state twice: with the sensitivity to ``s`` and with that to ``λ0`` (both with that to ``Φ̂``),
    :func:`_pass`. At the clamp, for
    ``a = s, λ0, Φ̂``: ``∂R*/∂a = −Z_λ2/λ2'``, ``∂w/∂a = Z_w + w' ∂R*/∂a``. The scale follows the parameters by
    the implicit function theorem on ``G(σ; λ0, Φ̂) = ln R* − σ = 0``:

        dσ/da = −G_a/G_σ,   G_a = (∂R*/∂a)/R*,   G_σ = (s/R*) ∂R*/∂s − 1,

    so ``dR*/da = ∂R*/∂a + (∂R*/∂s) s dσ/da`` and ``dw/da = ∂w/∂a + (∂w/∂s) s dσ/da``.

    Returns
    -------
    dict
        ``R`` (the clamp radius of this pass), ``dR_dl0, dV_dl0, dQ_dl0, dR_dphi, dV_dphi, dQ_dphi`` (the
        trial membrane's ``V̂t``, ``Q̂t``, with their factors π and 2π), ``status`` (0 where it landed), the exact
        ``slope`` ``G_σ`` and ``dsigma_dl0``, ``dsigma_dphi`` (at fixed ``p̂t``).
    """
    m = l0.size
    p_t, rtol = _trial(model, settings, lay, l0)
    two = np.concatenate([np.arange(m), np.arange(m)])
    lam_cols = np.arange(2 * m) >= m
    R_star, _, _, st, steps, _, _, ends = _pass(
        model, settings, _sub_layout(lay, two), l0[two], p_t[two], sigma[two], rtol[two], False, lam_cols
    )
    fV, fQ = QUADRATURE_FACTORS[:2]
    s = np.exp(sigma)
    R = R_star[:m]
    f = ends[10:15, :m]
    status = np.where((st[:m] == 0) & (st[m:] == 0) & (R_star[m:] == R), 0, np.maximum(st[:m], st[m:]))
    status[(status == 0) & ~(R_star[m:] == R)] = NOT_FINITE

    def partial(Z):
        dR = -Z[1] / f[1]
        return dR, Z[3] + f[3] * dR, Z[4] + f[4] * dR

    Rs, Vs, Qs = partial(ends[0:5, :m])
    slope = s / R * Rs - 1.0
    out = {"R": R, "status": status, "steps": steps[:m] + steps[m:], "slope": slope}
    for a, Z in (("l0", ends[0:5, m:]), ("phi", ends[5:10, :m])):
        Ra, Va, Qa = partial(Z)
        ds = -s * (Ra / R) / slope
        out[f"dsigma_d{a}"] = ds / s  # (at fixed p̂t: a continuation's first-order start, ScaleStarts)
        out[f"dR_d{a}"] = Ra + Rs * ds
        out[f"dV_d{a}"] = fV * (Va + Vs * ds)
        out[f"dQ_d{a}"] = fQ * (Qa + Qs * ds)
    return out


def _newton(
    model,
    pattern,
    settings,
    lay_all,
    l0_all,
    phi_all,
    sigma0,
    live,
    status,
    out,
    steps,
    detail,
    edges_out,
    formal=False,
    hint=None,
    stage=None,
    warm_started=None,
):
    """Newton's method on ``σ = ln s`` for the live states; fills ``status``, ``out``, ``steps``, ``detail``
    (``formal``: a converged state whose hoop tension is not positive somewhere stays a state).

    ``hint`` (see :func:`_solve`): a slope ``dG/dσ`` interpolated from converged neighbours serves the first
    Newton step of a state instead of the variational equations (its first pass integrates none); it is replaced
    by the exact slope as soon as a residual exceeds :data:`HINTED_SLOPE_AGAIN`. The hinted ``λ1⁺`` start the
    first pass's jumps (:func:`_jump`). Neither changes a converged state: it is the one evaluated, ``|G| ≤
    rtol``.

    ``stage = (later, start)`` (see :func:`_solve`; ``later`` per live state): those states wait while the
    others iterate, and join once every other is converged or has a residual at most :data:`JOIN_RESIDUAL`
    (its next iterate is then within ``~|G|²`` of its root), started by ``start`` from the others' converged or
    next scales, their exact slopes and jumps (or after :data:`JOIN_AFTER` passes from those that are). One
    Newton iteration for a whole curve: the joining states' passes are the others' last ones. Once a state has
    ended without a valid state beyond a valid one, the states beyond it are no longer solved (the curve, the first
    run of valid states, ends before them: :func:`_beyond_run_end`).

    No iterate goes below the interface scale :data:`SCALE_FLOOR` (its pole region would end inside the series
    radius): a state whose iterates meet the clamp too near (``G < 0``, or the clamp stretch before the last
    region) down to it has a pole stretch below the flat zone's, ``BELOW_FLAT``; a state left open after
    :data:`MAX_SCALE_ITERATIONS` with ``G < 0`` at every iterate takes one trial there to know (just below the flat
    pole stretch ``G`` is nearly constant in ``σ``: its steps are small). Measured on a Gent 97 inner circle
    (``f = 0.3``, three passive layers, prestretch 1.2, flat pole stretch 1.4151 at ``Φ̂ = 0.1``): they had gone
    on into the series radius, integrating the pole region backwards, to "solver_budget" or "wrinkling" after
    2700–24000 steps each."""
    m = live.size
    l0 = l0_all[live]
    lay = _sub_layout(lay_all, live)
    tp = _trial_pressures(model, lay, l0)
    p_t, rtol = _trial(model, settings, lay, l0, tp)
    # |G| is the relative misplacement of the interfaces of the returned state (it is the exact state of a
    # pattern whose fractions are off by that much): held to the integration's own tolerance
    tol = np.maximum(rtol, 4e-16)
    pole = _pole_start(model, settings, lay, l0, p_t, tp)  # the pole region's start: the same in every pass
    pole = (*pole[:2], None, *pole[3:])  # (its series' sensitivities serve the derivative pass only)
    # the smallest scale tried (SCALE_FLOOR): a state whose iterates reach the clamp too near (G < 0, or the clamp
    # stretch before the last region) at every scale down to it, where the zone is flat, has no equilibrium
    floor = np.log(SCALE_FLOOR * pole[5] / ((1.0 - POLE_MARGIN) * lay.f[0]))
    floor_tried = np.zeros(m, dtype=bool)
    floor_reach = np.full(m, np.nan)  # where the trial at the floor met the clamp stretch, over s (< 1: too near)
    warm = _Warm(m)  # the pole region and the jumps, kept from pass to pass
    last_slope = np.full(m, np.nan)  # the last exact slope dG/dσ of each state
    hinted = np.zeros(m, dtype=bool)  # the slope is the hint's (interpolated), not yet an exact one
    if hint is not None:
        h = np.asarray(hint["slope"], dtype=float)[live]
        hinted = np.isfinite(h) & (h < SLOPE_CEILING)
        last_slope[hinted] = h[hinted]
        for k, l1 in hint["jump"].items():
            warm.keep_jump(k, np.arange(m), np.asarray(l1, dtype=float)[live])
    sigma = sigma0[live].copy()
    good_sigma = np.full(m, np.nan)
    lo = np.full(m, -np.inf)
    hi = np.full(m, np.inf)
    last_code = np.zeros(m, dtype=int)
    failures = np.zeros(m, dtype=int)
    open_ = np.ones(m, dtype=bool)
    G_prev = np.full(m, np.inf)
    result = {k: np.full(m, np.nan) for k in out}
    final = np.zeros(m, dtype=int)
    waiting = np.zeros(m, dtype=bool)
    if stage is not None:
        waiting = stage[0].copy()
        open_[waiting] = False
    # a state started from a kept neighbour (ScaleStarts) is accepted on its first pass only with a residual far
    # below the tolerance: a cold state's last pass follows a Newton step (|G| ~ G_prev² ≪ tol), and a warm one
    # should be as close to its root (accepted at |G| ≤ tol, the states' noise amplified the ramp's
    # equal-free-energy voltages' error estimates up to 18-fold)
    strict = np.zeros(m, dtype=bool) if warm_started is None else np.asarray(warm_started, dtype=bool).copy()
    passes = 0
    while passes < MAX_SCALE_ITERATIONS:
        if stage is not None:
            beyond = _beyond_run_end(waiting, open_, final, model.tension_field or formal)
            final[beyond], waiting[beyond], open_[beyond] = BEYOND_RUN, False, False
            for i in np.flatnonzero(beyond):
                detail[live[i]] = reason_text(BEYOND_RUN)
            near = (open_ & (G_prev <= JOIN_RESIDUAL)) | (~open_ & np.isfinite(result["sigma"]))
            ready = near | waiting | (final == BEYOND_RUN)  # those left unsolved wait for nothing
            if waiting.any() and (np.all(ready) or passes >= JOIN_AFTER or not open_.any()):
                _join(stage[1], l0, waiting, near, sigma, result["sigma"], last_slope, hinted, warm, open_)
                hinted[waiting] = np.isfinite(last_slope[waiting])
                waiting[:] = False
                passes = 0  # the joining states have their own iterations
        idx = _at_floor(
            np.flatnonzero(open_), sigma, (floor, floor_tried, floor_reach), last_code, final, detail, live, open_
        )
        if idx.size == 0:
            break
        passes += 1
        sub = _Layout(n=lay.n[:, idx], phi=lay.phi[:, idx], f=lay.f, electrode=lay.electrode)
        # the slope where the last residual was large (or there is none): elsewhere the last one serves
        # (a hinted slope serves until a residual exceeds HINTED_SLOPE_AGAIN: before the first pass G_prev is inf)
        Gp = G_prev[idx]
        # (a small slope, above SLOPE_CEILING, is taken again where the last step |G/slope| exceeded SLOPE_AGAIN:
        # near the flat end it changes by a factor e^(2Δσ) from one iterate to the next)
        ls = last_slope[idx]
        again = np.where(ls > SLOPE_CEILING, SLOPE_AGAIN * np.abs(ls), SLOPE_AGAIN)
        need = ~np.isfinite(last_slope[idx]) | np.where(
            hinted[idx], np.isfinite(Gp) & ~(Gp <= HINTED_SLOPE_AGAIN), ~(Gp <= again)
        )
        R_star, dRs, quad, st, nsteps, tr, stop_R, _ = _pass(
            model,
            settings,
            sub,
            l0[idx],
            p_t[idx],
            sigma[idx],
            rtol[idx],
            True,
            pole=_take_pole(pole, idx),
            warm=(warm, idx),
            slope=need,
        )
        steps[live[idx]] += nsteps
        s = np.exp(sigma[idx])
        okp = st == 0
        G = np.where(okp, np.log(R_star) - sigma[idx], np.nan)
        at = np.flatnonzero(sigma[idx] == floor[idx])
        if at.size:  # the trials at the floor: where the clamp stretch was met, over s
            near = np.where(okp[at], R_star[at], np.where(st[at] == _EARLY_CLAMP, stop_R[at], np.nan)) / s[at]
            floor_reach[idx[at]] = np.where(near < 1.0, near, np.nan)
        slope = np.where(okp, s / R_star * dRs - 1.0, np.nan)
        last_slope[idx[need & okp]] = slope[need & okp]
        hinted[idx[need & okp]] = False
        last_slope[idx[~okp]] = np.nan  # a failed iterate: the slope is taken again at the next one
        slope = np.where(need, slope, last_slope[idx])
        conv = okp & ((np.abs(G) <= tol[idx]) | ((np.abs(G) >= 0.5 * G_prev[idx]) & (np.abs(G) <= 100 * tol[idx])))
        conv &= ~strict[idx] | (np.abs(G) <= WARM_FIRST_RESIDUAL * tol[idx])
        strict[idx] = False
        vague = np.flatnonzero(conv & ~(tr.min_T > 0) & ~tr.exact)
        if vague.size:
            # a tension not positive somewhere, from the attempt function (its place not recorded): the same
            # shooting step by step, which says which tension, where and on which side of an edge (the value
            # stays this pass's: the step-by-step steps start from another step size, and a formally continued
            # state's smallest tension must come from one shooting on both sides of its zero)
            exact = _pass(
                model,
                settings,
                _sub_layout(sub, vague),
                l0[idx][vague],
                p_t[idx][vague],
                sigma[idx][vague],
                rtol[idx][vague],
                True,
                fast=False,
            )[5]
            for name in ("where_R", "kind", "region", "side", "exact"):
                getattr(tr, name)[vague] = getattr(exact, name)
        # converged states: record
        cj = np.flatnonzero(conv)
        if cj.size:
            ci = idx[cj]
            result["R"][ci] = R_star[cj]
            result["sigma"][ci] = sigma[ci]
            result["slope"][ci] = np.where(hinted[ci], np.nan, last_slope[ci])
            for k, l1 in warm.l1.items():
                result[f"jump{k}"][ci] = l1[ci]
            result["p"][ci] = p_t[ci]
            for name, row in zip(("V", "Q", "Psi", "z"), quad[:, cj]):
                result[name][ci] = row
            result["minT"][ci] = tr.min_T[cj]
            result["maxE"][ci] = tr.max_E[cj]
            result["failR"][ci] = tr.where_R[cj] / R_star[cj]
            edge = tr.edges[cj].copy()
            # lengths of the unit membrane (θ and the force per length are scale-free)
            edge[..., :3] /= R_star[cj][:, None, None, None]
            edges_out[live[ci]] = edge
            wrinkled = ~(tr.min_T[cj] > 0) & ~(formal & (tr.kind[cj] == 2))
            for j in cj[wrinkled]:
                final[idx[j]] = WRINKLED
                detail[live[idx[j]]] = _detail_of_tension(
                    pattern, tr.min_T[j], tr.where_R[j] / R_star[j], tr.kind[j], tr.region[j], tr.side[j]
                )
            open_[ci] = False
        # the others: a Newton step kept inside the bracket [lo, hi] of σ (G > 0 at lo, G < 0 or an iterate
        # whose interfaces lie too far out at hi), bisection where it would leave it
        nj = np.flatnonzero(~conv & okp)
        if nj.size:
            ni = idx[nj]
            G_prev[ni] = np.abs(G[nj])
            good_sigma[ni] = sigma[ni]
            up = G[nj] > 0
            lo[ni[up]] = sigma[ni[up]]
            hi[ni[~up]] = sigma[ni[~up]]
            d = np.where((slope[nj] < 0.0) & np.isfinite(slope[nj]), slope[nj], -1.0)
            nxt = sigma[ni] + np.clip(-G[nj] / d, -MAX_SCALE_STEP, MAX_SCALE_STEP)
            _step_bracketed(ni, nxt, sigma, lo, hi, last_code, final, detail, live, open_)
        for j in np.flatnonzero(~conv & ~okp):
            i = idx[j]
            code = int(st[j])
            if code == _EARLY_CLAMP and np.isfinite(stop_R[j]):
                # the trajectory met the clamp stretch at stop_R inside the interfaces (s too large): with the
                # uniform slope −1, G ≈ ln(stop_R) − σ, so the next s is stop_R
                hi[i] = sigma[i]
                # (met at the pole itself, stop_R ≤ 0: no estimate, a step down; the bracket bisects past it)
                nxt = math.log(stop_R[j]) if stop_R[j] > 0 else sigma[i] - MAX_SCALE_STEP
            elif code == _FAR_CLAMP:
                lo[i] = sigma[i]  # R* > LAST_REGION_REACH·s: G > ln 8
                nxt = sigma[i] + MAX_SCALE_STEP
            else:
                last_code[i] = code
                failures[i] += 1
                if failures[i] >= MAX_FAILED_TRIALS:
                    final[i] = code
                    detail[live[i]] = (
                        f"{reason_text(code)} (at every one of {MAX_FAILED_TRIALS} placements of the interfaces tried, "
                        f"the last at interface scale {math.exp(sigma[i]):.6g})"
                    )
                    open_[i] = False
                    continue
                nxt = _after_failed_trial(i, sigma, lo, hi, good_sigma)
            _step_bracketed(np.array([i]), np.array([nxt]), sigma, lo, hi, last_code, final, detail, live, open_)
    # a state left open whose every iterate met the clamp too near (G < 0, none above 0) and that has not reached
    # the floor (its residual nearly constant, the steps small: a pole stretch just below the flat zone's): one
    # trial at the floor says whether it lies below the flat zone
    last = np.flatnonzero(open_ & np.isinf(lo) & np.isfinite(good_sigma) & ~floor_tried)
    if last.size:
        R_star, _, _, st, nsteps, _, _, _ = _pass(
            model,
            settings,
            _sub_layout(lay, last),
            l0[last],
            p_t[last],
            floor[last],
            rtol[last],
            False,
            pole=_take_pole(pole, last),
            slope=False,
        )
        steps[live[last]] += nsteps
        with np.errstate(all="ignore"):
            reach = np.where(st == 0, R_star / np.exp(floor[last]), np.nan)
        for i, r in zip(last[reach < 1.0], reach[reach < 1.0]):
            final[i] = BELOW_FLAT
            detail[live[i]] = _below_floor_detail(BELOW_FLAT, math.exp(floor[i]), r)
            open_[i] = False
    # a state whose last pass was the trial at the floor, there too near (G < 0), no iterate above 0: below the flat
    # zone's pole stretch as in _at_floor (its next iterate would have gone below the floor)
    for i in np.flatnonzero(open_ & floor_tried & np.isfinite(floor_reach) & np.isinf(lo)):
        final[i] = BELOW_FLAT
        detail[live[i]] = _below_floor_detail(BELOW_FLAT, math.exp(floor[i]), floor_reach[i])
        open_[i] = False
    for i in np.flatnonzero(waiting):
        # never joined: every state it was to start from ended in the same pass (all at the scale floor, say), and
        # the loop ended before the join; not a state (its status would stay OK with NaN values): failed, so a
        # curve retries it from the cap (helper-95: a tiny electrode disc's curve printed rows of NaN)
        final[i] = last_code[i] if last_code[i] else NO_CLAMP
        detail[live[i]] = f"{reason_text(final[i])} (not started: the states it was to start from all ended first)"
    for i in np.flatnonzero(open_):
        final[i] = last_code[i] if last_code[i] else NO_CLAMP
        detail[live[i]] = (
            f"{reason_text(final[i])} (the interfaces were not placed at their fractions of the clamp radius "
            f"within {MAX_SCALE_ITERATIONS} Newton iterations)"
        )
    status[live] = final
    for k in out:
        out[k][live] = result[k]


#: a curve's later states join its Newton iteration (:func:`_newton`) once the others' residuals are at most this
JOIN_RESIDUAL = 1e-4
#: ... or after this many passes at most
JOIN_AFTER = 4


def _beyond_run_end(waiting, open_, final, wrinkled_valid: bool) -> np.ndarray:
    """The states of a curve's :func:`_newton` (ordered by pole stretch) that need not be solved: those beyond a
    finished state without a valid state that lies beyond a finished valid one (the curve is the first run of
    valid states, and it ends before them). A ring electrode at Φ̂ = 0.3 spent 2.4 s of its 2.6 s on states beyond
    its end, each running out of integration steps at every placement of the interfaces tried. ``wrinkled_valid``:
    a state found wrinkled still counts as valid (tension-field states are relaxed later; formally continued ones
    are states). The caller solves them after all if a failed state is found valid later
    (:func:`patterned_pressure_volume_curve`)."""
    settled = ~waiting & ~open_
    valid = settled & (final == OK)
    invalid = settled & (final != OK) & (final != BEYOND_RUN) & ~(wrinkled_valid & (final == WRINKLED))
    beyond = np.zeros(waiting.size, dtype=bool)
    if valid.any():
        first = int(np.argmax(valid))
        after = np.flatnonzero(invalid[first:])
        if after.size:
            end = first + int(after[0])
            beyond[end + 1 :] = (waiting | open_)[end + 1 :]
    return beyond


def _join(start, l0, waiting, near, sigma, sigma_done, last_slope, hinted, warm, open_) -> None:
    """Start the ``waiting`` states of :func:`_newton` from the ``near`` ones (see there): ``σ`` (converged, or the
    next iterate), the exact slopes and the last ``λ1⁺``; a state without a guess keeps its ``σ``."""
    k_idx = np.flatnonzero(near)
    w_idx = np.flatnonzero(waiting)
    known_sigma = np.where(np.isfinite(sigma_done[k_idx]), sigma_done[k_idx], sigma[k_idx])
    exact = np.where(hinted[k_idx], np.nan, last_slope[k_idx])
    jumps = {k: v[k_idx] for k, v in warm.l1.items()}
    guess, hint = start(l0[k_idx], known_sigma, exact, jumps, l0[w_idx])
    sigma[w_idx] = np.where(np.isfinite(guess), guess, sigma[w_idx])
    h = np.asarray(hint["slope"], dtype=float)
    ok = np.isfinite(h) & (h < SLOPE_CEILING)
    last_slope[w_idx] = np.where(ok, h, np.nan)
    for k, l1 in hint["jump"].items():
        warm.keep_jump(k, w_idx, np.asarray(l1, dtype=float))
    open_[w_idx] = True


def _step_bracketed(ii, nxt, sigma, lo, hi, last_code, final, detail, live, open_) -> None:
    """Set the next ``σ`` of the states ``ii``: ``nxt`` kept inside the bracket (:func:`_keep_bracketed`, here for
    many states at once); a state whose bracket has closed (:func:`_bracket_closed`) is given up (``final``,
    ``detail``, ``open_``)."""
    a, b = lo[ii], hi[ii]
    both = np.isfinite(a) & np.isfinite(b)
    outside = np.where(np.isfinite(a), a + MAX_SCALE_STEP, b - MAX_SCALE_STEP)
    nxt = np.where((a < nxt) & (nxt < b), nxt, np.where(both, 0.5 * (a + b), outside))
    closed = np.isfinite(b) & (b - a <= 1e-12 * np.maximum(1.0, np.abs(b)))
    for i in ii[closed]:
        # the bracket closed on the edge of the iterates' domain, not on a root: no state here
        final[i] = last_code[i] if last_code[i] else NO_CLAMP
        detail[live[i]] = _closed_bracket_detail(final[i], hi[i])
        open_[i] = False
    sigma[ii] = nxt


def _at_floor(idx, sigma, floor_state, last_code, final, detail, live, open_) -> np.ndarray:
    """The open iterates ``idx`` of an interface-scale iteration kept at or above the smallest scale tried
    (:data:`SCALE_FLOOR`; ``floor_state = (floor, floor_tried, floor_reach)``, per state: ``ln`` of that scale,
    whether a trial there was taken, and where it met the clamp stretch over its scale): an iterate below it is set
    to it the first time; a second time (the trial there asked for a smaller scale) the state ends, ``BELOW_FLAT``
    where that trial met the clamp stretch before the rim, else with its last failure (or ``NO_CLAMP``). Updates
    ``sigma``, ``floor_tried``, ``final``, ``detail`` and ``open_`` in place; returns the iterates still open."""
    floor, floor_tried, floor_reach = floor_state
    low = idx[sigma[idx] < floor[idx]]
    if low.size == 0:
        return idx
    for i in low[floor_tried[low]]:  # the trial at the floor asked for a smaller scale: no state
        final[i] = BELOW_FLAT if np.isfinite(floor_reach[i]) else (last_code[i] or NO_CLAMP)
        detail[live[i]] = _below_floor_detail(final[i], math.exp(floor[i]), floor_reach[i])
        open_[i] = False
    first = low[~floor_tried[low]]
    sigma[first] = floor[first]
    floor_tried[first] = True
    return np.flatnonzero(open_)


def _below_floor_detail(code: int, s: float, reach: float) -> str:
    """Why a state has none: its trial at the smallest interface scale ``s`` (:data:`SCALE_FLOOR`) asked for a
    smaller one, meeting the clamp stretch at ``reach`` of the rim radius (``BELOW_FLAT``; NaN: it failed with
    ``code``)."""
    where = f"at interface scale {s:.6g}, the smallest tried: its first interface {SCALE_FLOOR:g} series radii"
    where += " from the pole"
    if code == BELOW_FLAT:
        return f"{reason_text(code)} ({where}, the clamp stretch reached at {reach:.6g} of the rim radius)"
    return f"{reason_text(code)} ({where}; no larger scale tried gave a state)"


def _closed_bracket_detail(code: int, hi: float, state: str = "state") -> str:
    """Why a state has none: the bracket of its interface scale closed on the edge of the trials' domain (the trials
    fail beyond ``ln s = hi``), not on a root; ``state`` names what was sought ("relaxed state")."""
    return (
        f"{reason_text(code)} (no placement of the interfaces at their fractions of the clamp "
        f"radius gives a {state}: the trials fail beyond interface scale {math.exp(hi):.6g})"
    )


def _after_failed_trial(i, sigma, lo, hi, good_sigma) -> float:
    """After an iterate ``σ_i`` that fails (not a state): it bounds the bracket on the side away from the last
    good ``σ`` (the trials fail beyond it), and the next ``σ`` steps :data:`MAX_SCALE_STEP` back inside."""
    if np.isfinite(good_sigma[i]) and good_sigma[i] > sigma[i]:
        lo[i] = sigma[i]
    else:
        hi[i] = sigma[i]
    return sigma[i] + (MAX_SCALE_STEP if hi[i] > sigma[i] else -MAX_SCALE_STEP)


def _keep_bracketed(nxt: float, lo: float, hi: float) -> float:
    """The next ``σ``: ``nxt`` inside the bracket ``(lo, hi)``, else its midpoint, or :data:`MAX_SCALE_STEP` from
    its one finite end."""
    if lo < nxt < hi:
        return nxt
    if np.isfinite(lo) and np.isfinite(hi):
        return 0.5 * (lo + hi)
    return lo + MAX_SCALE_STEP if np.isfinite(lo) else hi - MAX_SCALE_STEP


def _bracket_closed(lo: float, hi: float) -> bool:
    """Has the bracket of ``σ`` closed (to 1e-12) on the edge of the iterates' domain (no state there)?"""
    return bool(np.isfinite(hi) and hi - lo <= 1e-12 * max(1.0, abs(hi)))


# --- curves ---------------------------------------------------------------------------------------------------

#: a curve's grid is first solved on a coarse subset of about one in COARSE_STRIDE pole stretches (evenly spaced in
#: ``u``, :func:`_abscissa`, :func:`_coarse`), the rest started from the polynomial through the converged scales
COARSE_STRIDE = 8


#: the power of ``λ0/λpre − 1`` in which a curve's interface scale is interpolated (:func:`_abscissa`)
ABSCISSA_POWER = 0.4


def _abscissa(model: MembraneModel, l0) -> np.ndarray:
    """``u = (λ0/λpre − 1)^0.4``, in which a curve's interface scale is interpolated and its coarse states spaced:
    ``σ(λ0)`` bends sharply as the membrane flattens (``λ0 → λpre``) and is smooth in ``u`` (measured, 26 of the
    default 200 states known, Gent 97 at ``Φ̂ = 0.1``: the 6-point polynomial's largest error on the others 3e-5
    for the headline inner circle, a ring and a one-layer inner circle, against 7e-2 in ``λ0`` on every eighth
    state and 1e-3 in ``√(λ0/λpre − 1)``)."""
    return np.maximum(np.asarray(l0, dtype=float) / model.prestretch - 1.0, 0.0) ** ABSCISSA_POWER


def _coarse(u: np.ndarray) -> np.ndarray:
    """The coarse subset of a grid with abscissae ``u`` (increasing): the points nearest to ``⌈n/COARSE_STRIDE⌉ + 1``
    evenly spaced values from ``u[0]`` to ``u[-1]`` (both ends included), as a mask."""
    targets = np.linspace(u[0], u[-1], -(-u.size // COARSE_STRIDE) + 1)
    right = np.clip(np.searchsorted(u, targets), 1, u.size - 1)
    nearest = np.where(targets - u[right - 1] <= u[right] - targets, right - 1, right)
    mask = np.zeros(u.size, dtype=bool)
    mask[nearest] = True
    return mask


#: the starting ``ln s`` of a state is the polynomial through this many converged neighbours (:func:`_interpolate`)
GUESS_POINTS = 6


def _known(known_l0: list, known_values: list) -> tuple[np.ndarray, np.ndarray]:
    """The pole stretches and values kept by a curve's calls (``known_values``: arrays of one value per state, or
    of rows of values), sorted, each stretch once, where every value is finite."""
    kl = np.concatenate(known_l0)
    kv = np.concatenate([np.atleast_2d(v) for v in known_values], axis=1)
    fin = np.all(np.isfinite(kv), axis=0)
    kl, first = np.unique(kl[fin], return_index=True)
    kv = kv[:, fin][:, first]
    return kl, (kv[0] if np.ndim(known_values[0]) == 1 else kv)


def _interpolate(kl: np.ndarray, kv: np.ndarray, x: np.ndarray):
    """The Lagrange polynomial through the :data:`GUESS_POINTS` nodes ``kl`` nearest to each ``x`` (values ``kv``,
    one per node or rows of them) and an estimate of its error (of the first row): its difference from the
    polynomial through the same nodes less the farthest one (the size of the last term). Constant outside the
    nodes, linear (error estimate ``inf``) with fewer than four; ``(NaN, inf)`` without nodes."""
    kv = np.asarray(kv, dtype=float)
    rows = np.atleast_2d(kv)
    if kl.size == 0:
        return np.full((rows.shape[0], x.size), np.nan).reshape(kv.shape[:-1] + (x.size,)), np.full(x.size, np.inf)
    inside = np.clip(x, kl[0], kl[-1])
    if kl.size < 4:
        out = np.array([np.interp(inside, kl, r) for r in rows])
        return out.reshape(kv.shape[:-1] + (x.size,)), np.full(x.size, np.inf)
    n = min(GUESS_POINTS, kl.size)
    at = np.clip(np.searchsorted(kl, inside) - n // 2, 0, kl.size - n)[:, None] + np.arange(n)
    nodes = kl[at]
    # Lagrange weights of all n nodes, and of the n − 1 without the node farthest from x (first or last)
    diff = inside[:, None] - nodes  # (x, n)
    den = nodes[:, :, None] - nodes[:, None, :]  # (x, j, i)
    eye = np.eye(n, dtype=bool)
    factor = np.where(eye[None], 1.0, diff[:, None, :] / np.where(eye[None], 1.0, den))  # (x, j, i)
    w = np.prod(factor, axis=2)
    far_first = np.abs(diff[:, 0]) > np.abs(diff[:, -1])
    drop = np.where(far_first, 0, n - 1)  # the node left out of the lower polynomial
    keep = np.arange(n)[None, :] != drop[:, None]
    # without node d: w_j' = w_j / factor[j, d] for j ≠ d
    fd = np.take_along_axis(factor, np.broadcast_to(drop[:, None, None], (x.size, n, 1)), axis=2)[..., 0]
    w_less = np.where(keep, w / np.where(keep, fd, 1.0), 0.0)
    values = rows[:, at]  # (q, x, n)
    full = np.sum(w[None] * values, axis=2)
    less = np.sum(w_less[None] * values[:1], axis=2)[0]
    return full.reshape(kv.shape[:-1] + (x.size,)), np.abs(full[0] - less)


#: a curve's hinted slope (:func:`_newton`) is given where the interface scale's interpolation error estimate is at
#: most this (elsewhere the first pass integrates the variational equations: the residual would exceed
#: :data:`HINTED_SLOPE_AGAIN`)
HINT_SCALE_ERROR = 1e-6


def _take_patterned(st: PatternedStates, mask) -> PatternedStates:
    """The states of ``st`` where ``mask`` holds."""
    keep = np.flatnonzero(mask)
    kw: dict = {}
    for k, v in st.__dict__.items():
        if isinstance(v, np.ndarray):
            kw[k] = v[mask]
        elif k == "wrinkled_radii" and v is not None:  # a relaxed state's bands (coexist.patterned_relaxed)
            kw[k] = [v[i] for i in keep]
        elif k == "derivatives" and v is not None:
            kw[k] = v.take(mask)
        else:
            kw[k] = None
    return _patterned(
        MembraneStates(**kw), [d for d, keep in zip(st.failure_detail, mask) if keep], st.interfaces[mask]
    )


def _merge(x, first_mask, first: PatternedStates, rest: PatternedStates) -> PatternedStates:
    """The states of ``first`` (at ``x[first_mask]``) and ``rest`` (at the others) in the order of ``x``."""
    kw: dict = {}
    for name, a in first.__dict__.items():
        b = rest.__dict__[name]
        if isinstance(a, np.ndarray) or isinstance(b, np.ndarray):
            like = a if isinstance(a, np.ndarray) else b
            merged = np.full(x.size, np.nan if like.dtype.kind == "f" else 0, dtype=like.dtype)
            if isinstance(a, np.ndarray):
                merged[first_mask] = a
            if isinstance(b, np.ndarray):
                merged[~first_mask] = b
            kw[name] = merged
        elif name == "wrinkled_radii" and (a is not None or b is not None):  # relaxed states' bands
            bands: list = [[] for _ in range(x.size)]
            for i, w in zip(np.flatnonzero(first_mask), a or [[]] * int(first_mask.sum())):
                bands[i] = w
            for i, w in zip(np.flatnonzero(~first_mask), b or [[]] * int((~first_mask).sum())):
                bands[i] = w
            kw[name] = bands
        elif name == "derivatives" and a is not None and b is not None:
            merged_d = {}
            for k, va in a.__dict__.items():
                both = np.full(x.size, np.nan)
                both[first_mask], both[~first_mask] = va, b.__dict__[k]
                merged_d[k] = both
            kw[name] = StateDerivatives(**merged_d)
        else:
            kw[name] = None
    detail: list = [None] * x.size
    for i, d in zip(np.flatnonzero(first_mask), first.failure_detail):
        detail[i] = d
    for i, d in zip(np.flatnonzero(~first_mask), rest.failure_detail):
        detail[i] = d
    edges = np.empty((x.size, *first.interfaces.shape[1:]))
    edges[first_mask] = first.interfaces
    edges[~first_mask] = rest.interfaces
    return _patterned(MembraneStates(**kw), detail, edges)


def patterned_pressure_volume_curve(
    model: MembraneModel,
    pattern: ZonePattern,
    phi_hat: float = 0.0,
    pole_stretch=None,
    settings: SolverSettings | None = None,
) -> Curve:
    """The ``p̂–V̂`` curve of a patterned zone at fixed ``Φ̂``, traced by the pole stretch, limit points located.

    As :func:`coexist.curves.pressure_volume_curve` (the same grid, valid run and limit-point search: the exact
    slopes of the states' derivatives at the curve's ends and bends, limit points as their roots, errors measured at
    rtol/100), with every state from :func:`solve_patterned_states`. The grid is one Newton iteration on the
    interface scales (:func:`_newton`): a coarse subset (:func:`_coarse`, evenly spaced in ``u = (λ0/λpre −
    1)^0.4``) from the pole region's uniform zone, and once its residuals are below :data:`JOIN_RESIDUAL` every
    other state joins, started from the 6-point polynomial in ``u`` through the coarse scales (:func:`_interpolate`)
    with the interpolated slope ``dG/dσ`` and interface stretches (no variational equations in its first pass where
    the scale's error estimate is small): 5 passes for the default grid of the headline zone. The limit-point
    search's states start from all the converged ones. Every state is returned from a pass whose own residual is
    ``|G| ≤ rtol``: the starts change the passes, not the states. States beyond the first that ends the first run of
    valid states are not solved (status :data:`coexist.shooting.BEYOND_RUN`; they are no part of the curve) unless
    that state is found valid after all.

    Parameters
    ----------
    model : MembraneModel
    pattern : ZonePattern
    phi_hat : float
        ``Φ̂`` of the electrode.
    pole_stretch : array_like, optional
        Increasing pole stretches; default ``settings.curve_points`` from ``1.01 λpre`` to ``max(4, 1.5 λpre)``.
    settings : SolverSettings, optional

    Returns
    -------
    Curve
        ``states`` are plain :class:`~coexist.shooting.MembraneStates`; ``starts_because`` /
        ``stopped_because`` say why the valid run is shorter than the grid (e.g. the electrode edge wrinkling
        at low inflation).

    Raises
    ------
    SceneError
        Bad pattern, grid or voltage.
    ModelRangeError
        No valid state anywhere on the grid.
    SolverError
        No valid state near a limit point while refining it (a state found failing between two valid states of
        the grid ends the curve before it instead: ``stopped_because`` names it).
    """
    settings = validation.settings_or_default(settings)
    validation.membrane_model(model)
    validation.instance(pattern, ZonePattern, "pattern", "a ZonePattern (e.g. ZonePattern.inner_circle(0.5))")
    phi_hat = validation.real(phi_hat, "phi_hat", lo=0.0)
    known_l0: list = []
    known_sigma: list = []
    known_slope: list = []
    known_jump: dict = {k: [] for k in range(1, len(pattern.regions))}

    def start(l0_known, sigma_known, slope_known, jump_known: dict, x):
        """The scale guess at ``x`` and the hint (:func:`_solve`) from converged states (or nearly, :func:`_newton`):
        polynomials in ``u = (λ0/λpre − 1)^0.4`` (:func:`_abscissa`, :func:`_interpolate`); the slope only where
        the scale's error estimate is at most :data:`HINT_SCALE_ERROR`."""
        u, ux = _abscissa(model, l0_known), _abscissa(model, x)
        jump: dict = {}
        jumps = np.vstack(list(jump_known.values())) if jump_known else None
        if jumps is not None and np.array_equal(np.isfinite(sigma_known), np.all(np.isfinite(jumps), axis=0)):
            # the same nodes: the scale and the stretches in one polynomial evaluation (the scale's row first)
            rows, err = _interpolate(*_known([u], [np.vstack([sigma_known, jumps])]), ux)
            guess, jump = rows[0], dict(zip(jump_known, rows[1:]))
        else:
            guess, err = _interpolate(*_known([u], [sigma_known]), ux)
            if jumps is not None:
                jump = dict(zip(jump_known, _interpolate(*_known([u], [jumps]), ux)[0]))
        slope = _interpolate(*_known([u], [slope_known]), ux)[0]
        slope = np.where(err <= HINT_SCALE_ERROR, slope, np.nan)
        return guess, {"slope": slope, "jump": jump}

    def solve(x, from_known, later=None, at=settings, derivatives=False):
        """The states at ``x``: from the cap estimate, from the states kept (``from_known``), or (``later``, the
        curve's first call) one Newton iteration in which the ``later`` states join from the others. ``at``: the
        settings (those of the curve, whose states are kept as starts, or the tighter ones its limit points'
        errors are measured with); ``derivatives``: with the exact derivatives (the limit points' slopes)."""
        guess = h = stage = None
        if from_known:
            cat = {k: np.concatenate(v) for k, v in known_jump.items()}
            guess, h = start(np.concatenate(known_l0), np.concatenate(known_sigma), np.concatenate(known_slope), cat, x)
        if later is not None:
            stage = (later, start)
        st, kept = _solve(model, pattern, x, phi_hat, at, guess, derivatives, False, h, stage)
        again = ~st.ok & (from_known or later is not None) & (np.ones(x.size, dtype=bool) if later is None else later)
        again &= st.status != BEYOND_RUN  # left unsolved on purpose: beyond the end of the curve's first run
        if again.any():  # a start from neighbours that failed: once more from the cap
            retry = solve_patterned_states(model, pattern, x[again], phi_hat, at, derivatives=derivatives)
            st = _merge(x, ~again, _take_patterned(st, ~again), retry)
        if model.tension_field:  # a tension-field membrane: its WRINKLED states shot again relaxed
            from .patterned_relaxed import relax_wrinkled

            st = relax_wrinkled(model, pattern, st, at, derivatives=derivatives)
        ok = st.ok & np.isfinite(st.clamp_radius)
        if ok.any() and kept and at is settings:
            known_l0.append(x[ok])
            known_sigma.append(np.log(st.clamp_radius[ok]))
            known_slope.append(np.where(again, np.nan, kept["slope"])[ok])
            for k, v in known_jump.items():
                v.append(np.where(again, np.nan, kept["jump"][k])[ok])
        unsolved = st.status == BEYOND_RUN
        if unsolved.any():
            # the states left unsolved lay beyond one that ended the first run of valid states in the Newton
            # iteration; where the run now reaches them (that state found valid by the retry from the cap), or no
            # run comes before them (the states taken as valid there failed their relaxation), they are solved
            run = first_valid_run(st.ok) if st.ok.any() else None
            if run is None or unsolved[: run.stop + 1].any():
                rest = solve(x[unsolved], bool(known_l0), at=at, derivatives=derivatives)
                st = _merge(x, ~unsolved, _take_patterned(st, ~unsolved), rest)
        return st

    def slopes(x, at):
        st = solve(np.asarray(x, dtype=float), bool(known_l0), at=at, derivatives=True)
        return st, _slopes_along(st, "pressure_volume")

    def evaluate(x):
        x = np.asarray(x, dtype=float)
        if not known_l0 and x.size >= 4 * COARSE_STRIDE:
            # a coarse subset first, from the crude start; the rest joins from the interpolated scales
            return solve(x, False, ~_coarse(_abscissa(model, x)))
        return solve(x, bool(known_l0))

    return _trace(
        "pressure_volume",
        phi_hat,
        model,
        pole_stretch,
        settings.curve_points,
        evaluate,
        {"p_hat": ("pressure_max", "pressure_min"), "v_hat": ("volume_max", "volume_min")},
        settings,
        lambda x: slopes(x, settings),
        lambda x, _: slopes(x, error_reference(settings)),
        same_states=True,  # the derivatives come from a pass of their own at the converged interface scales
    )
