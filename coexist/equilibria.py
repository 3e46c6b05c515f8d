"""N identical zones on one gas: configurations, exact residuals, and stability in closed form.

Potential of the whole system at fixed voltage (docs/physics.md, normalised by ``μHA²``)::

    G(V̂1..V̂N) = Σ Ψ̂(V̂i) + G_gas(Σ V̂i)

with ``G_gas = −n̂ ln(V̂c + ΣV̂i) + p̂atm ΣV̂i`` for an isothermal ideal gas of amount ``n̂`` in a rigid
chamber ``V̂c`` (seed eq. 1; evaluated relative to the gas at zero gauge pressure, without cancellation,
:meth:`~coexist.effects.GasChamber.free_energy`), or ``G_gas = −p̂ ΣV̂i`` for a pressure reservoir. Its
stationary points are the equilibria: every zone at the gauge pressure of the gas.

**Configurations.** Identical zones in equilibrium sit in a few distinct states. A configuration
puts ``n1`` zones at pole stretch ``λ1``, ``n2`` at ``λ2`` and so on (groups ordered by pole stretch,
``Σ nj = N``); ``(N,)`` is homogeneous, ``(N − k, k)`` has ``k`` bulged zones. With ``u = √(λ0 − λpre)``
(in which the states are smooth down to the flat membrane) the unknowns are ``u1 < u2 < …`` at the
voltage ``Φ̂``, and the equilibrium conditions are::

    r0 = p̂(u1) − p̂_gas(Σ nj V̂(uj)) = 0
    rj = [p̂(u_{j+1}) − p̂(uj)] / (u_{j+1} − uj) = 0        j = 1 … M−1

The divided difference removes the trivial solution ``u_{j+1} = uj`` (the homogeneous state solves
the undivided equations for every ``Φ̂``), so a branch of the configuration passes cleanly through the
symmetric branch point where it meets the homogeneous branch. Every ``p̂, V̂`` is a state shot
directly (:func:`coexist.shooting.solve_states`), and the Jacobian comes from the variational
equations integrated with it: no spline enters a residual.

**Stability** (docs/physics.md). Two conditions, both in closed form:

1. The Hessian of ``G`` over the zone volumes, ``diag(aj) + c 1 1ᵀ`` with ``aj = dp̂/dV̂`` of group ``j``
   and ``c = n̂/(V̂c + ΣV̂)²`` (0 for a reservoir), has the eigenvalue ``aj`` with multiplicity
   ``nj − 1`` (zones of one group moving against each other) and the ``M`` eigenvalues of
   ``B = diag(aj) + c √(nj nl)`` (groups moving as wholes). No ``N × N`` matrix is formed.
2. Each zone is stable at fixed volume: along one zone's curve the number of unstable axisymmetric
   modes at fixed volume changes by one at every volume fold ``dV̂/dλ0 = 0``, increasing where the
   pressure falls at the fold (``dp̂/dλ0 < 0`` approached with ``dV̂/dλ0 > 0``; Maddocks' rule for the
   distinguished diagram ``(V̂, p̂)``). :func:`zone_index` counts it.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .errors import SceneError, SolverError
from .numerics.roots import bracketed_root
from .settings import SolverSettings
from .shooting import OK, StateDerivatives, reason_tag, reason_text, solve_states


# --- configurations --------------------------------------------------------------------------------
@dataclass(frozen=True)
class Configuration:
    """How ``N`` identical zones split into groups of equal state, ordered by pole stretch.

    ``counts = (N,)`` is homogeneous; ``(N − k, k)`` has ``k`` bulged zones and ``N − k`` unbulged.
    """

    counts: tuple

    def __post_init__(self):
        counts = self.counts
        whole = (
            not isinstance(counts, (str, bytes))
            and hasattr(counts, "__iter__")
            and all(
                not isinstance(x, (bool, np.bool_))
                and isinstance(x, (int, np.integer, float))
                and float(x).is_integer()
                for x in counts
            )
        )  # a bare number, text or 1.7 was an int() error or silently truncated (review, helper-62)
        c = tuple(int(x) for x in counts) if whole else ()
        if not c or any(x < 1 for x in c):
            raise SceneError(f"group sizes must be positive integers, got {self.counts!r}", "configuration")
        object.__setattr__(self, "counts", c)

    @property
    def zones(self) -> int:
        """``N = Σ nj``, the number of zones."""
        return sum(self.counts)

    @property
    def groups(self) -> int:
        """``M``, the number of groups (distinct states)."""
        return len(self.counts)

    @property
    def bulged(self) -> int:
        """Zones in the most inflated group (0 when homogeneous)."""
        return 0 if self.groups == 1 else self.counts[-1]

    @property
    def label(self) -> str:
        """Name: ``"homogeneous"``, ``"k of N bulged"`` (two groups) or ``"n1 + n2 + … zones in M states"``."""
        if self.groups == 1:
            return "homogeneous"
        if self.groups == 2:
            return f"{self.counts[1]} of {self.zones} bulged"
        return f"{' + '.join(map(str, self.counts))} zones in {self.groups} states"

    def reversed(self) -> Configuration:
        """The same groups in the opposite order: ``(N − k, k)`` becomes ``(k, N − k)``.

        Returns
        -------
        Configuration
            ``Configuration(counts[::-1])``.
        """
        return Configuration(tuple(reversed(self.counts)))


def two_group(zones: int, bulged: int) -> Configuration:
    """``(N − k, k)``: ``k`` bulged zones among ``N`` (``k = 0``: homogeneous).

    Parameters
    ----------
    zones : int
        ``N ≥ 1``.
    bulged : int
        ``k`` in ``0 … N − 1``.

    Returns
    -------
    Configuration
        ``(N,)`` for ``k = 0``, else ``(N − k, k)``.

    Raises
    ------
    SceneError
        If ``zones`` is not a positive integer or ``bulged`` lies outside ``0 … N − 1``.
    """
    if not (isinstance(zones, (int, np.integer)) and zones >= 1):
        raise SceneError(f"zone count must be a positive integer, got {zones!r}", "zones")
    if not (0 <= bulged < zones) and not (bulged == 0):
        raise SceneError(f"bulged zones must lie in 0..{zones - 1}, got {bulged!r}", "bulged")
    return Configuration((zones,)) if bulged == 0 else Configuration((zones - bulged, bulged))


# --- exact states of the groups ----------------------------------------------------------------------
@dataclass
class GroupStates:
    """Directly shot states of every group at ``P`` points (arrays of shape ``(P, M)``) with their
    derivatives in ``u = √(λ0 − λpre)`` (``dp_du``, ``dv_du``) and ``Φ̂`` (``dp_dphi``, ``dv_dphi``)."""

    u: np.ndarray
    phi: np.ndarray
    p: np.ndarray
    v: np.ndarray
    q: np.ndarray
    psi: np.ndarray
    dp_du: np.ndarray
    dv_du: np.ndarray
    dp_dphi: np.ndarray
    dv_dphi: np.ndarray
    max_field: np.ndarray
    min_tension: np.ndarray
    status: np.ndarray
    wrinkled_fraction: np.ndarray
    #: per group ``K/T̂11`` at the outer ends of its wrinkled bands (``inf`` taut; None: refuses wrinkling)
    wrinkled_stiffness: np.ndarray | None = None

    @property
    def ok(self) -> np.ndarray:
        """Per point: every group's state valid."""
        return np.all(self.status == OK, axis=1)


def shoot_groups(model, u, phi, settings, formal: bool = False, derivatives: bool = True, starts=None) -> GroupStates:
    """Shoot the states of every group at every point in one vectorised call (with derivatives).

    ``u`` has shape ``(P, M)`` and ``phi`` shape ``(P,)``.

    Each group is one clamped zone at pole stretch ``λ0 = λpre + u²``, shot directly
    (:func:`coexist.shooting.solve_states`); the ``u``-derivatives are ``d/du = 2u d/dλ0``. The energy
    depends on ``Φ̂²`` only, so a negative ``Φ̂`` is shot at ``|Φ̂|`` with ``Q̂`` and the ``Φ̂``-derivatives
    changing sign.

    Parameters
    ----------
    model : MembraneModel
        The zone's model.
    u : array_like, shape (P, M)
        ``u = √(λ0 − λpre)`` of each group at each point (a 1-d array is one point).
    phi : float or array_like, shape (P,)
        Normalised voltage ``Φ̂`` of each point.
    settings : SolverSettings
        Solver settings.
    formal : bool, optional
        Continue through a non-positive hoop tension (see :func:`coexist.shooting.solve_states`).
    derivatives : bool, optional
        Integrate the variational equations (default True); False leaves every derivative NaN.
    starts : coexist.patterned.ScaleStarts, optional
        A patterned zone's store of converged states to start from (see :func:`coexist.shooting.solve_states`).

    Returns
    -------
    GroupStates
        Arrays of shape ``(P, M)`` (``phi``: ``(P,)``); ``status`` is the shooting's code, ``-1`` where
        ``u ≤ 0`` or ``u`` or ``Φ̂`` is not finite (:func:`failure_reason`).
    """
    u = np.atleast_2d(np.asarray(u, dtype=float))
    P, M = u.shape
    phi = np.broadcast_to(np.asarray(phi, dtype=float), (P,))
    lam = model.prestretch + u**2
    good = np.isfinite(lam) & (u > 0) & np.isfinite(phi)[:, None]
    lam_safe = np.where(good, lam, model.prestretch + 1.0)
    # the energy depends on Φ̂² only: a negative voltage (a continuation stepping past Φ̂ = 0) is the
    # mirror image, with the charge and every Φ̂-derivative changing sign
    sign = np.where(phi < 0, -1.0, 1.0)[:, None]
    phi_rep = np.repeat(np.where(np.isfinite(phi), np.abs(phi), 0.0), M)
    st = solve_states(model, lam_safe.ravel(), phi_rep, settings, derivatives=derivatives, formal=formal, starts=starts)
    d = st.derivatives

    def shaped(a):
        return np.asarray(a, dtype=float).reshape(P, M)

    if d is None:  # residual only: the derivatives are left NaN (a chord step supplies its own Jacobian)
        nan = np.full(st.p_hat.shape, np.nan)
        from .shooting import StateDerivatives

        d = StateDerivatives(nan, nan, nan, nan, nan, nan)

    status = shaped(st.status).astype(int)
    status[~good] = -1
    du = 2 * u  # dλ/du
    return GroupStates(
        u=u,
        phi=np.asarray(phi, dtype=float),
        p=shaped(st.p_hat),
        v=shaped(st.v_hat),
        q=sign * shaped(st.q_hat),
        psi=shaped(st.psi_hat),
        dp_du=shaped(d.dp_dl0) * du,
        dv_du=shaped(d.dv_dl0) * du,
        dp_dphi=sign * shaped(d.dp_dphi),
        dv_dphi=sign * shaped(d.dv_dphi),
        max_field=shaped(st.max_field),
        min_tension=shaped(st.min_tension),
        status=status,
        wrinkled_fraction=shaped(st.wrinkled_fraction),
        wrinkled_stiffness=None if st.wrinkled_stiffness is None else shaped(st.wrinkled_stiffness),
    )


def failure_reason(status: int) -> tuple[str, str]:
    """``(tag, sentence)`` of a state's status code (``-1``: outside the physical range).

    Parameters
    ----------
    status : int
        A code of :attr:`GroupStates.status`.

    Returns
    -------
    tag : str
        Short machine-readable reason (``"out_of_range"`` for ``-1``, else the shooting's tag).
    sentence : str
        The reason in words.
    """
    if status == -1:
        return "out_of_range", "the pole stretch left the physical range (λ0 ≤ λpre)"
    return reason_tag(status), reason_text(status)


# --- residuals ---------------------------------------------------------------------------------------


@dataclass
class Residual:
    """Equilibrium residuals ``r`` (``(P, M)``) and their Jacobian ``J`` (``(P, M, M + 1)``, columns
    ``u1 … uM, Φ̂``) at ``P`` points, with the shot states."""

    r: np.ndarray
    J: np.ndarray
    states: GroupStates
    total_volume: np.ndarray
    gas_pressure: np.ndarray
    gas_stiffness: np.ndarray


def scale_starts(model):
    """A new store of converged states to start a patterned zone's shooting from.

    Parameters
    ----------
    model : MembraneModel
        The zone's model.

    Returns
    -------
    coexist.patterned.ScaleStarts or None
        Empty; None for a model without a pattern.
    """
    if getattr(model, "pattern", None) is None:
        return None
    from .patterned import ScaleStarts

    return ScaleStarts()


class GroupSystem:
    """The equilibrium equations of one configuration of identical zones on a gas.

    Parameters
    ----------
    model : MembraneModel
    gas : GasChamber or PressureReservoir
    configuration : Configuration
    settings : SolverSettings
    starts : coexist.patterned.ScaleStarts, optional
        A patterned zone's store of converged states (default: a new one for a patterned model, None otherwise):
        each state shot starts its interface-scale iteration from the nearest kept one (a start, never a result)
        and is kept. A system derived from this one (other settings, the same continuation) may share it.
    """

    def __init__(self, model, gas, configuration: Configuration, settings, starts=None):
        self.model = model
        self.gas = gas
        self.configuration = configuration
        self.settings = settings
        self.n = np.asarray(configuration.counts, dtype=float)
        self.starts = scale_starts(model) if starts is None else starts

    @property
    def groups(self) -> int:
        """``M``, the number of groups of the configuration."""
        return self.configuration.groups

    def residual(self, u, phi, formal: bool = False, derivatives: bool = True) -> Residual:
        """Residuals and Jacobian at points ``(u, Φ̂)``; ``u`` of shape ``(P, M)`` (``formal``: see
        :func:`coexist.shooting.solve_states`; ``derivatives=False``: the residuals alone, the Jacobian NaN).

        ``r0 = p̂(u1) − p̂_gas(Σ nj V̂(uj))`` and ``rj = [p̂(u_{j+1}) − p̂(uj)] / (u_{j+1} − uj)``; where two
        groups lie closer than ``settings.merge_tolerance`` in ``u``, ``rj`` is their mean ``dp̂/du`` and
        its Jacobian row is zero.

        Parameters
        ----------
        u : array_like, shape (P, M)
            ``u = √(λ0 − λpre)`` of each group at each point.
        phi : float or array_like, shape (P,)
            Normalised voltage ``Φ̂`` of each point.
        formal : bool, optional
            Shoot formally continued states (for locating the onset of wrinkling).
        derivatives : bool, optional
            Compute the Jacobian (default True).

        Returns
        -------
        Residual
            ``r`` of shape ``(P, M)``, ``J`` of shape ``(P, M, M + 1)`` (columns ``u1 … uM, Φ̂``), the
            shot states, and ``ΣV̂``, ``p̂_gas`` and the gas stiffness ``c`` per point.
        """
        st = shoot_groups(self.model, u, phi, self.settings, formal, derivatives, self.starts)
        return self._residual(st)

    def _residual(self, st: GroupStates) -> Residual:
        P, M = st.u.shape
        n = self.n
        total = st.v @ n
        pg = np.asarray(self.gas.pressure(total), dtype=float) + np.zeros(P)
        c = np.asarray(self.gas.stiffness(total), dtype=float) + np.zeros(P)
        r = np.empty((P, M))
        J = np.zeros((P, M, M + 1))
        r[:, 0] = st.p[:, 0] - pg
        J[:, 0, 0] = st.dp_du[:, 0]
        J[:, 0, :M] += c[:, None] * n[None, :] * st.dv_du
        J[:, 0, M] = st.dp_dphi[:, 0] + c * (st.dv_dphi @ n)
        for j in range(M - 1):
            du = st.u[:, j + 1] - st.u[:, j]
            near = np.abs(du) < self.settings.merge_tolerance  # one state: no divided difference
            safe = np.where(near, 1.0, du)
            D = (st.p[:, j + 1] - st.p[:, j]) / safe
            # merged groups: the divided difference is the slope there (no better value exists)
            D = np.where(near, 0.5 * (st.dp_du[:, j] + st.dp_du[:, j + 1]), D)
            r[:, j + 1] = D
            J[:, j + 1, j + 1] = np.where(near, 0.0, (st.dp_du[:, j + 1] - D) / safe)
            J[:, j + 1, j] = np.where(near, 0.0, (D - st.dp_du[:, j]) / safe)
            J[:, j + 1, M] = np.where(near, 0.0, (st.dp_dphi[:, j + 1] - st.dp_dphi[:, j]) / safe)
        return Residual(r, J, st, total, pg, c)


# --- stability -------------------------------------------------------------------------------------
def hessian_eigenvalues(counts, dp_dv, stiffness) -> list[tuple[float, int, str]]:
    """Eigenvalues of ``diag(aj, nj times) + c 1 1ᵀ`` in closed form, as ``(value, multiplicity, mode)``.

    ``mode`` is ``"within group j"`` for ``aj`` (zones of group ``j`` moving against each other; only when
    ``nj ≥ 2``) or ``"groups"`` for the eigenvalues of ``B = diag(aj) + c √(nj nl)``.

    Parameters
    ----------
    counts : sequence of int, length M
        Group sizes ``nj``.
    dp_dv : sequence of float, length M
        ``aj = dp̂/dV̂`` of one zone of each group along its curve.
    stiffness : float
        The gas stiffness ``c = n̂/(V̂c + ΣV̂)²`` (0 for a pressure reservoir).

    Returns
    -------
    list of (float, int, str)
        ``(value, multiplicity, mode)``, ascending in value; the multiplicities add up to ``N``.

    Examples
    --------
    >>> [(round(v, 12), m, mode) for v, m, mode in hessian_eigenvalues((2, 1), (1.0, -0.5), 0.0)]
    [(-0.5, 1, 'groups'), (1.0, 1, 'within group 0'), (1.0, 1, 'groups')]
    """
    counts = np.asarray(counts, dtype=float)
    a = np.asarray(dp_dv, dtype=float)
    out = []
    for j, (nj, aj) in enumerate(zip(counts, a)):
        if nj >= 2:
            out.append((float(aj), int(nj) - 1, f"within group {j}"))
    s = np.sqrt(counts)
    B = np.diag(a) + float(stiffness) * np.outer(s, s)
    for ev in np.linalg.eigvalsh(B):
        out.append((float(ev), 1, "groups"))
    return sorted(out, key=lambda x: x[0])


def group_block(counts, dp_dv, stiffness):
    """``B = diag(aj) + c √(nj nl)``: the Hessian restricted to whole-group motions.

    Parameters
    ----------
    counts : sequence of int, length M
        Group sizes ``nj``.
    dp_dv : sequence of float, length M
        ``aj = dp̂/dV̂`` of one zone of each group.
    stiffness : float
        The gas stiffness ``c`` (0 for a pressure reservoir).

    Returns
    -------
    ndarray, shape (M, M)
        ``B``, symmetric.
    """
    s = np.sqrt(np.asarray(counts, dtype=float))
    return np.diag(np.asarray(dp_dv, dtype=float)) + float(stiffness) * np.outer(s, s)


def fold_index(slopes, u: float, samples: int = 64, depth: int = 4) -> int:
    """Unstable axisymmetric modes at fixed volume of one zone at ``u``, from the folds of its curve below.

    ``slopes(u_array) -> (dV̂/du, dp̂/du)`` along the zone's curve at one voltage. Walking ``u`` up from the
    flat state, every volume fold (a root of ``dV̂/du``) changes the count by ``−sign(dp̂/du · σ)``, with
    ``dp̂/du`` taken *at the fold* and ``σ`` the sign of ``dV̂/du`` just below it (Maddocks' rule: approached
    from its stable side a fold has ``dp̂/dV̂ → −∞``). The folds are bracketed on ``samples`` points,
    intervals where ``|dV̂/du|`` is small against its largest value are halved up to ``depth`` times (the
    folds of a spiral crowd together where the volume hardly changes, and two of them inside one
    interval would not show as a sign change), and the folds are located all at once
    (:func:`coexist.numerics.roots.bracketed_root`). ``tests/test_zone_stability_fe.py`` checks the count
    against the negative eigenvalues of a finite-element energy Hessian at fixed volume.

    Only the run of valid (finite) slopes that ends at ``u`` is searched.

    Parameters
    ----------
    slopes : callable
        ``slopes(u_array) -> (dV̂/du, dp̂/du)``, arrays of the shape of ``u_array``; NaN where no valid
        state exists.
    u : float
        The zone's ``u = √(λ0 − λpre)``.
    samples : int, optional
        Points of the first grid on ``(0, u]`` (default 64).
    depth : int, optional
        Rounds of halving the intervals with an end where ``|dV̂/du|`` is below 5 % of its largest value
        (default 4).

    Returns
    -------
    int
        The fold index (0: stable at fixed volume), never negative; 0 for ``u ≤ 0``.
    """
    u = float(u)
    if u <= 0:
        return 0
    grid = np.linspace(0.0, u, samples + 1)[1:]
    dv, dp = (np.asarray(x, dtype=float) for x in slopes(grid))
    for _ in range(depth):
        scale = np.nanmax(np.abs(dv)) if np.isfinite(dv).any() else 1.0
        small = (np.abs(dv[:-1]) < 0.05 * scale) | (np.abs(dv[1:]) < 0.05 * scale)
        if not small.any():
            break
        mids = 0.5 * (grid[:-1] + grid[1:])[small]
        dvm, dpm = (np.asarray(x, dtype=float) for x in slopes(mids))
        grid = np.concatenate([grid, mids])
        order = np.argsort(grid)
        grid, dv, dp = grid[order], np.concatenate([dv, dvm])[order], np.concatenate([dp, dpm])[order]
    ok = np.isfinite(dv)
    # only the valid run that ends at u counts (below it the states wrinkle or are flat-like: no fold)
    first = int(np.flatnonzero(~ok)[-1]) + 1 if (~ok).any() else 0
    grid, dv = grid[first:], dv[first:]
    idx = np.flatnonzero(dv[:-1] * dv[1:] < 0)
    if idx.size == 0:
        return 0
    sigma = np.sign(dv[idx])
    folds = bracketed_root(
        lambda x, _: np.asarray(slopes(x)[0], dtype=float),
        grid[idx],
        grid[idx + 1],
        dv[idx],
        dv[idx + 1],
        xtol=1e-10,
        rtol=1e-10,
    )
    _, dp_fold = (np.asarray(x, dtype=float) for x in slopes(folds.x))
    return max(int(np.sum(-np.sign(dp_fold * sigma))), 0)


def pressure_branch(model, u, phi, settings: SolverSettings) -> int:
    """Which monotone piece of its zone curve a zone at ``(u, Φ̂)`` is on: the number of pressure extrema
    (roots of ``dp̂/du``) between the flat state and ``u`` — 0 on the first rising branch, 1 past the
    pressure maximum (falling), 2 past the following minimum (re-stiffened), and so on. Counted on
    ``settings.stability_samples`` directly shot states with exact derivatives.

    Only the run of valid states that ends at ``u`` is counted.

    Parameters
    ----------
    model : MembraneModel
        The zone's model.
    u : float
        ``u = √(λ0 − λpre)`` of the zone.
    phi : float
        Normalised voltage ``Φ̂``.
    settings : SolverSettings
        Solver settings (``stability_samples``).

    Returns
    -------
    int
        Sign changes of ``dp̂/du`` on the grid between the flat state and ``u``.
    """
    u = float(u)
    grid = np.linspace(0.0, u, settings.stability_samples + 1)[1:]
    s = solve_states(model, model.prestretch + grid**2, phi, settings, derivatives=True)
    dp = np.where(s.ok, StateDerivatives.of(s).dp_dl0, np.nan)
    ok = np.isfinite(dp)
    first = int(np.flatnonzero(~ok)[-1]) + 1 if (~ok).any() else 0
    dp = dp[first:]
    return int(np.sum(dp[:-1] * dp[1:] < 0))


def configuration_label(configuration: Configuration, branches=None) -> str:
    """The configuration's name; a homogeneous state whose zones are past their pressure maximum
    (``branches[0] ≥ 1``, :func:`pressure_branch`) is "homogeneous, all bulged" (e.g. under pressure
    control, beside the unbulged homogeneous state).

    Parameters
    ----------
    configuration : Configuration
        The configuration.
    branches : sequence of int, optional
        :func:`pressure_branch` of each group; only ``branches[0]`` of a homogeneous state is used.

    Returns
    -------
    str
        :attr:`Configuration.label`, with ``", all bulged"`` appended in that case.
    """
    base = configuration.label
    if branches is not None and configuration.groups == 1 and branches[0] >= 1:
        return f"{base}, all bulged"
    return base


def zone_index(model, u, phi, settings: SolverSettings) -> int:
    """Unstable axisymmetric modes at fixed volume of one zone at ``(u, Φ̂)``, on directly shot states with
    exact derivatives (:func:`fold_index`).

    Parameters
    ----------
    model : MembraneModel
        The zone's model.
    u : float
        ``u = √(λ0 − λpre)`` of the zone.
    phi : float
        Normalised voltage ``Φ̂ ≥ 0``.
    settings : SolverSettings
        Solver settings (``stability_samples``, ``fold_refinements``).

    Returns
    -------
    int
        The zone's index (0: stable at its own volume); 0 for ``u ≤ 0``.

    Raises
    ------
    SolverError
        If the state at ``(u, Φ̂)`` itself is not valid (the message gives the shooting's reason).
    """
    u = float(u)
    if u <= 0:
        return 0
    st = solve_states(model, model.prestretch + u * u, phi, settings)
    if not st.ok[0]:
        raise SolverError(
            f"zone_index: the state at u = {u:.6g}, Φ̂ = {phi:.6g} is not valid ({reason_text(int(st.status[0]))})"
        )

    def slopes(x):
        x = np.atleast_1d(np.asarray(x, dtype=float))
        s = solve_states(model, model.prestretch + x * x, phi, settings, derivatives=True)
        good = s.ok
        d = StateDerivatives.of(s)
        return np.where(good, d.dv_dl0 * 2 * x, np.nan), np.where(good, d.dp_dl0 * 2 * x, np.nan)

    return fold_index(slopes, u, settings.stability_samples, settings.fold_refinements)


def zone_index_on_curve(curve, u, settings: SolverSettings | None = None) -> int:
    """:func:`fold_index` on an interpolated zone curve (:class:`~coexist.zone_curves.ZoneCurve`, in ``u``): a first
    guess of a zone's index where exact states are not at hand (the jumps' gradient flow).

    Below the curve's first grid point the zone counts as rising (no fold); ``u`` beyond its last point
    is clipped to it.

    Parameters
    ----------
    curve : ZoneCurve
        One zone's curve at one voltage, with ``grid`` and the splines ``dv``, ``dp`` in ``u``.
    u : float
        ``u = √(λ0 − λpre)`` of the zone.
    settings : SolverSettings, optional
        Solver settings (``stability_samples``, ``fold_refinements``; default :class:`SolverSettings`).

    Returns
    -------
    int
        The zone's index estimated on the splines.
    """
    settings = settings or SolverSettings()
    lo = float(curve.grid[0])

    def slopes(x):
        x = np.atleast_1d(np.asarray(x, dtype=float))
        inside = x >= lo
        xc = np.maximum(x, lo)
        # below the curve's first point the zone is barely inflated: rising, no fold
        return np.where(inside, curve.dv(xc), 1.0), np.where(inside, curve.dp(xc), 1.0)

    return fold_index(
        slopes, min(float(u), float(curve.grid[-1])), settings.stability_samples, settings.fold_refinements
    )


# --- an equilibrium ----------------------------------------------------------------------------------
@dataclass
class Equilibrium:
    """One converged equilibrium of ``N`` identical zones at one voltage.

    Attributes
    ----------
    configuration : Configuration
    phi_hat : float
    pole_stretch, v_hat, q_hat, psi_hat, dp_dv, max_field, min_tension : tuple
        Per group (ordered by pole stretch): the shot states and ``dp̂/dV̂`` along the zone curve.
    p_hat : float
        The common gauge pressure.
    free_energy : float
        ``Ĝ = Σ nj Ψ̂j + G_gas``.
    eigenvalues : list of (value, multiplicity, mode)
        The Hessian's eigenvalues (:func:`hessian_eigenvalues`).
    zone_index : tuple
        Per group, unstable axisymmetric modes of one zone at fixed volume.
    residual : float
        Largest entry of the residual ``r`` at the reported state: the pressure balance ``p̂1 − p̂_gas`` and
        the divided differences ``(p̂_{j+1} − p̂_j)/(u_{j+1} − u_j)`` (units of ``dp̂/du``); converged states
        have it below ``residual_tol (1 + p̂)``, or on a stiff gas near its floor ``c · rtol ΣV̂`` (the gas stiffness
        times the volumes' error; above the former from ``p̂atm`` ≈ 1e3, docs/physics.md section 4).
    wrinkled_fraction : tuple
        Per group, the reference area fraction of its hoop-wrinkled region (tension-field models; empty
        for a model that refuses wrinkling).
    wrinkled_stiffness : tuple
        Per group, ``K/T̂11`` at the outer ends of its wrinkled bands (``inf`` when taut; empty for a model
        that refuses wrinkling): it falls to zero where a band pulls in.
    """

    configuration: Configuration
    phi_hat: float
    pole_stretch: tuple
    p_hat: float
    v_hat: tuple
    q_hat: tuple
    psi_hat: tuple
    dp_dv: tuple
    max_field: tuple
    min_tension: tuple
    free_energy: float
    eigenvalues: list
    zone_index: tuple
    residual: float
    notes: list = field(default_factory=list)
    wrinkled_fraction: tuple = ()
    wrinkled_stiffness: tuple = ()

    @property
    def zones(self) -> int:
        """``N``, the number of zones."""
        return self.configuration.zones

    @property
    def k(self) -> int:
        """Bulged zones (the most inflated group; 0 when homogeneous)."""
        return self.configuration.bulged

    @property
    def label(self) -> str:
        """The configuration's name (:attr:`Configuration.label`)."""
        return self.configuration.label

    @property
    def min_eigenvalue(self) -> float:
        """The smallest eigenvalue of the Hessian of ``Ĝ`` over the zone volumes."""
        return float(self.eigenvalues[0][0])

    @property
    def stable(self) -> bool:
        """Positive definite Hessian and every zone stable at its own volume."""
        return self.min_eigenvalue > 0 and all(i == 0 for i in self.zone_index)

    @property
    def zone_volumes(self) -> list:
        """Volume of every zone, least inflated first."""
        return [v for v, n in zip(self.v_hat, self.configuration.counts) for _ in range(n)]

    @property
    def zone_pole_stretches(self) -> list:
        """Pole stretch ``λ0`` of every zone, least inflated first."""
        return [lam for lam, n in zip(self.pole_stretch, self.configuration.counts) for _ in range(n)]

    @property
    def total_charge(self) -> float:
        """``Σ nj Q̂j``, the charge on all zones."""
        return float(sum(n * q for n, q in zip(self.configuration.counts, self.q_hat)))

    @property
    def v_unbulged(self) -> float:
        """``V̂`` of the least inflated group."""
        return self.v_hat[0]

    @property
    def v_bulged(self) -> float | None:
        """``V̂`` of the most inflated group; None when homogeneous."""
        return self.v_hat[-1] if self.configuration.groups > 1 else None

    @property
    def pole_stretch_unbulged(self) -> float:
        """``λ0`` of the least inflated group."""
        return self.pole_stretch[0]

    @property
    def pole_stretch_bulged(self) -> float | None:
        """``λ0`` of the most inflated group; None when homogeneous."""
        return self.pole_stretch[-1] if self.configuration.groups > 1 else None

    def to_dict(self) -> dict:
        """A plain summary of the state (for JSON output).

        Returns
        -------
        dict
            ``configuration`` (the label), ``group_sizes``, ``phi_hat``, ``p_hat``, ``pole_stretch`` and
            ``v_hat`` (per group), ``free_energy_hat`` (``Ĝ``), ``stable``, ``min_eigenvalue``, ``zone_index``
            and ``residual``.
        """
        return {
            "configuration": self.label,
            "group_sizes": list(self.configuration.counts),
            "phi_hat": self.phi_hat,
            "p_hat": self.p_hat,
            "pole_stretch": list(self.pole_stretch),
            "v_hat": list(self.v_hat),
            "free_energy_hat": self.free_energy,
            "stable": self.stable,
            "min_eigenvalue": self.min_eigenvalue,
            "zone_index": list(self.zone_index),
            "residual": self.residual,
        }


def merged(configuration: Configuration, u, tol: float | None = None) -> tuple[Configuration, np.ndarray]:
    """Groups closer than ``tol`` (default: ``SolverSettings().merge_tolerance``) in ``u`` joined into one
    (the configuration a state really is in), and the groups' ``u`` in order.

    The groups are sorted by ``u``; a group within ``tol · max(1, |u|)`` of the group before it joins
    it, at the count-weighted mean ``u``.

    Parameters
    ----------
    configuration : Configuration
        Group sizes, one per entry of ``u`` (in any order).
    u : array_like, shape (M,)
        ``u`` of each group.
    tol : float, optional
        Merge tolerance in ``u``.

    Returns
    -------
    configuration : Configuration
        The merged configuration, groups ordered by ``u``.
    u : ndarray, shape (M',)
        ``u`` of its groups.
    """
    tol = SolverSettings().merge_tolerance if tol is None else tol
    u = np.asarray(u, dtype=float)
    order = np.argsort(u, kind="stable")
    counts = [configuration.counts[i] for i in order]
    us = list(u[order])
    out_c, out_u = [counts[0]], [us[0]]
    for c, x in zip(counts[1:], us[1:]):
        if abs(x - out_u[-1]) <= tol * max(1.0, abs(x)):
            w = out_c[-1] / (out_c[-1] + c)
            out_u[-1] = w * out_u[-1] + (1 - w) * x
            out_c[-1] += c
        else:
            out_c.append(c)
            out_u.append(x)
    return Configuration(tuple(out_c)), np.asarray(out_u)


def _common_pressure(res: Residual, i: int) -> float:
    """The common gauge pressure of point ``i``: the first group's own (shot) pressure on a gas, the reservoir's
    pressure under pressure control.

    At equilibrium zones and gas agree to the residual, but on a gas the gas pressure ``n̂/(V̂c + ΣV̂) − p̂atm``
    turns the volumes' error (the shooting's, ``~rtol V̂``) into ``c ΣδV̂``, with the gas stiffness ``c`` about
    ``(p̂atm + p̂)/(V̂c + ΣV̂)``: at ``p̂atm`` = 2e8 (``μ`` = 1 Pa, ``H`` = 10 µm under one atmosphere) the tricircle's
    reported pressure was 5e-3 off (against a run at rtol 1e-12; its pole stretches and volumes 3e-9), and the
    result depended on ``p̂atm``, which the zones' own pressure does not amplify. A reservoir's is exact.
    """
    if float(res.gas_stiffness[i]) > 0:
        return float(res.states.p[i, 0])
    return float(res.gas_pressure[i])


def make_equilibrium(system: GroupSystem, res: Residual, i: int, index=None) -> Equilibrium:
    """The :class:`Equilibrium` at point ``i`` of a residual evaluation (groups ordered by ``u``).

    ``dp̂/dV̂ = (dp̂/du)/(dV̂/du)`` per group, ``Ĝ = Σ nj Ψ̂j + G_gas(Σ nj V̂j)``, the Hessian's eigenvalues
    by :func:`hessian_eigenvalues`; ``p̂`` is the first group's own pressure on a gas (the gas pressure amplifies
    the volumes' error by its stiffness, :func:`_common_pressure`), the reservoir's under pressure control. No
    solve is done here: the point is taken as converged.

    Parameters
    ----------
    system : GroupSystem
        The system that was evaluated.
    res : Residual
        Its evaluation (with derivatives).
    i : int
        The point (row) of ``res``.
    index : sequence of int, optional
        Each group's :func:`zone_index`, in the system's group order (default all 0).

    Returns
    -------
    Equilibrium
        With ``residual`` the largest ``|r|`` at the point.
    """
    st = res.states
    order = np.argsort(st.u[i], kind="stable")
    counts = tuple(system.configuration.counts[j] for j in order)
    conf = Configuration(counts)
    n = np.asarray(counts, dtype=float)
    lam = system.model.prestretch + st.u[i, order] ** 2
    dv = st.dv_du[i, order]
    # exactly on a volume fold (a root finder can land there) dp/dV is infinite: taken as the limit from
    # the inflating side, a large finite slope, so that the Hessian's eigenvalues stay numbers
    dv = np.where(dv == 0, 1e-14 * max(float(np.max(np.abs(dv))), 1.0), dv)
    a = st.dp_du[i, order] / dv
    psi = st.psi[i, order]
    v = st.v[i, order]
    G = float(n @ psi + system.gas.free_energy(float(n @ v)))
    eig = hessian_eigenvalues(counts, a, float(res.gas_stiffness[i]))
    idx = tuple(int(index[j]) for j in order) if index is not None else (0,) * len(counts)
    return Equilibrium(
        configuration=conf,
        phi_hat=float(st.phi[i]),
        pole_stretch=tuple(float(x) for x in lam),
        p_hat=_common_pressure(res, i),
        v_hat=tuple(float(x) for x in v),
        q_hat=tuple(float(x) for x in st.q[i, order]),
        psi_hat=tuple(float(x) for x in psi),
        dp_dv=tuple(float(x) for x in a),
        max_field=tuple(float(x) for x in st.max_field[i, order]),
        min_tension=tuple(float(x) for x in st.min_tension[i, order]),
        free_energy=G,
        eigenvalues=eig,
        zone_index=idx,
        residual=float(np.max(np.abs(res.r[i]))) if res.r.size else 0.0,
        wrinkled_fraction=tuple(float(x) for x in st.wrinkled_fraction[i, order]) if system.model.tension_field else (),
        wrinkled_stiffness=(
            tuple(float(x) for x in st.wrinkled_stiffness[i, order]) if st.wrinkled_stiffness is not None else ()
        ),
    )
