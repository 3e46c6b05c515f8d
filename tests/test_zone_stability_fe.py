"""Independent check of the stability index of one zone at fixed volume, by finite elements.

The claim under test (``coexist.equilibria.zone_index``): along one zone's curve at fixed ``Φ̂``,
parametrised by the pole stretch ``λ0``, the number of unstable axisymmetric modes *at fixed volume*
changes by one at every volume fold (``dV̂/dλ0 = 0``), by ``Δ = −sign(dp̂/dλ0 · σ)`` with ``σ`` the
sign of ``dV̂/dλ0`` just below the fold (Maddocks' rule on the distinguished diagram ``(V̂, p̂)``).

The independent calculation, written here from scratch (nothing of ``coexist`` is used for it except
``solve_states``, whose shooting shapes serve as starting points, and ``build_model``, which only
builds the model handed to ``solve_states`` / ``zone_index``):

* **Energy.** Nodes at reference radii ``0 = R_0 < … < R_n = 1`` (graded: element size ~ √R near
  the pole, where the states near the end of a spiral have a boundary layer). Unknowns ``r_i, z_i``
  with ``r_0 = 0``, ``r_n = 1``, ``z_n = 0`` fixed (``z_0`` free). Linear elements, one-point
  (midpoint) rule: on ``(i, i+1)``, ``λ1 = |x_{i+1} − x_i| / ΔR``, ``λ2 = (r_i + r_{i+1}) /
  (R_i + R_{i+1})``, energy ``W*(λ1, λ2; Φ̂) 2π R_mid ΔR`` with
  ``W* = Ws − Φ̂² λ1² λ2² / 2`` (neo-Hookean ``Ws = I/2``, Gent ``Ws = −(Jlim/2) ln(1 − I/Jlim)``,
  ``I = λ1² + λ2² + λ1⁻²λ2⁻² − 3``). Volume exact for the piecewise-linear surface of revolution,
  ``V = Σ (π/3)(r_i² + r_i r_{i+1} + r_{i+1}²)(z_i − z_{i+1})``. Element gradients and Hessians are
  exact (CasADi), assembled in numpy.
* **Equilibrium.** The shooting shape is interpolated onto the mesh. Newton's method first solves the
  discrete equilibrium ``∇Ψ − p∇V = 0`` with the pole stretch pinned (``r_1 = λ0 R_1``, ``p`` free),
  which follows the same branch as the shooting state even deep in a spiral, where the volumes of
  neighbouring branches differ by less than the discretisation error; from there Newton solves the
  fixed-volume problem ``∇Ψ − p∇V = 0``, ``V = V̂_s`` (unknowns ``r, z, p``). Checked: residual,
  that it stayed on the branch (pole stretch, shape), and ``p`` against the shooting ``p̂``.
* **Index.** The Hessian of ``Ψ − pV`` restricted to the tangent space of the volume constraint
  (an orthonormal basis ``Z`` of the null space of ``∇Vᵀ``): the number of negative eigenvalues of
  ``Zᵀ(∇²Ψ − p∇²V)Z``. The generalised problem with a lumped ``L2`` mass matrix has the same inertia
  (Sylvester) and eigenvalues that converge with the mesh, so they are what is reported.
* **Mesh convergence.** Every state is computed on two meshes (``n = 200, 400``; the state past the
  fourth fold of the neo-Hookean spiral on 400, 800): the counts must agree, the eigenvalue nearest
  zero must have a resolved sign, and the error of ``p`` against the shooting ``p̂`` must shrink like
  ``h²``.

The folds themselves are located here too (a dense ``λ0`` scan with the exact ``dV̂/dλ0`` and Brent's
method), the sign of ``dp̂/dλ0`` at each fold is asserted (S-shape or spiral), and the rule is
applied to those folds: FE count == rule at the folds == ``zone_index``.
"""

from __future__ import annotations

import functools

import casadi as ca
import numpy as np
import pytest
import scipy.linalg as sla
import scipy.sparse as sp
import scipy.sparse.linalg as spla
from scipy.interpolate import PchipInterpolator
from scipy.optimize import brentq

from coexist.equilibria import zone_index
from coexist.model import build_model
from coexist.settings import SolverSettings
from coexist.shooting import solve_states

SETTINGS = SolverSettings(rtol=1e-10)
JLIM = 97.0
MESHES = (200, 400)

#: Newton residual (max-norm of ∇Ψ − p∇V and V − V̂s) a converged FE state must reach
RESIDUAL_TOL = 1e-9
#: FE pole stretch r_1/R_1 against the shooting λ0: the FE state is on the shooting state's branch
#: (neighbouring branches at the same volume are ≥ 0.1 away in λ0 for every state used here)
POLE_TOL = 0.02
#: max |r_FE − r̂|, |z_FE − ẑ| at the shooting nodes (O(h²) plus the linear interpolation of the FE
#: solution between its nodes)
SHAPE_TOL = 2e-3
#: |p_FE − p̂| on the coarser mesh (measured ≤ 1.8e-4 at n = 200), and |Ψ_FE − Ψ̂| (measured ≤ 8e-5)
P_TOL = 5e-4
PSI_TOL = 2e-4
#: |V_FE − V̂| of the pinned-pole state (measured ≤ 8.5e-4 at n = 200, O(h²))
V_TOL = 2e-3
#: how many of the lowest constrained eigenvalues are computed (the largest of them must be positive,
#: so that every negative one is counted)
EIGENVALUES = 12
#: the p error must shrink at least by this factor when the mesh is refined twice (h²: 4)
P_CONVERGENCE = 2.5


# --- the finite-element model --------------------------------------------------------------------
@functools.cache
def _element(material: str, jlim: float) -> ca.Function:
    """Element energy, volume and their exact gradients and Hessians in ``q = (r_i, z_i, r_j, z_j)``."""
    q = ca.SX.sym("q", 4)
    Ri, Rj, phi = ca.SX.sym("Ri"), ca.SX.sym("Rj"), ca.SX.sym("phi")
    dR = Rj - Ri
    l1 = ca.sqrt((q[2] - q[0]) ** 2 + (q[3] - q[1]) ** 2) / dR
    l2 = (q[0] + q[2]) / (Ri + Rj)
    inv = l1**2 + l2**2 + 1 / (l1**2 * l2**2) - 3
    ws = inv / 2 if material == "neo-hookean" else -jlim / 2 * ca.log(1 - inv / jlim)
    w = ws - phi**2 * l1**2 * l2**2 / 2
    psi = w * 2 * ca.pi * (Ri + Rj) / 2 * dR
    vol = ca.pi / 3 * (q[0] ** 2 + q[0] * q[2] + q[2] ** 2) * (q[1] - q[3])
    return ca.Function(
        "element",
        [q, Ri, Rj, phi],
        [psi, ca.gradient(psi, q), ca.hessian(psi, q)[0], vol, ca.gradient(vol, q), ca.hessian(vol, q)[0]],
    )


def _mesh(n: int) -> np.ndarray:
    """``R(t) = t²/2 + (1 − cos πt)/4``: element size ~ √R at the pole, ~1/n at the clamp."""
    t = np.linspace(0.0, 1.0, n + 1)
    R = 0.5 * t**2 + 0.25 * (1 - np.cos(np.pi * t))
    R[-1] = 1.0
    return R


class _FE:
    """Assembled FE energy of one zone on a given mesh; dofs ``z_0, (r_i, z_i) i = 1..n−1``."""

    def __init__(self, material: str, jlim: float, phi: float, R: np.ndarray):
        self.R = np.asarray(R, dtype=float)
        self.n = n = self.R.size - 1
        self.phi = float(phi)
        self.f = _element(material, jlim).map(n)
        self.rdof = np.full(n + 1, -1)
        self.zdof = np.full(n + 1, -1)
        self.zdof[0] = 0
        self.rdof[1:n] = 1 + 2 * np.arange(n - 1)
        self.zdof[1:n] = 2 + 2 * np.arange(n - 1)
        self.ndof = 2 * n - 1
        self.edofs = np.stack([self.rdof[:-1], self.zdof[:-1], self.rdof[1:], self.zdof[1:]], axis=1)

    def nodes(self, x):
        r = np.zeros(self.n + 1)
        z = np.zeros(self.n + 1)
        r[-1] = 1.0
        m = self.rdof >= 0
        r[m] = x[self.rdof[m]]
        m = self.zdof >= 0
        z[m] = x[self.zdof[m]]
        return r, z

    def pack(self, r, z):
        x = np.empty(self.ndof)
        m = self.rdof >= 0
        x[self.rdof[m]] = r[m]
        m = self.zdof >= 0
        x[self.zdof[m]] = z[m]
        return x

    def assemble(self, x):
        """``Ψ, ∇Ψ, ∇²Ψ, V, ∇V, ∇²V`` at the dof vector ``x``."""
        r, z = self.nodes(x)
        out = self.f(np.vstack([r[:-1], z[:-1], r[1:], z[1:]]), self.R[:-1], self.R[1:], self.phi)
        psi, gp, hp, vol, gv, hv = (np.array(o) for o in out)
        hp = hp.reshape(4, self.n, 4).transpose(1, 0, 2)  # per element 4 x 4
        hv = hv.reshape(4, self.n, 4).transpose(1, 0, 2)
        N = self.ndof
        G, GV = np.zeros(N), np.zeros(N)
        rows, cols, vals, vals_v = [], [], [], []
        for a in range(4):
            da = self.edofs[:, a]
            ma = da >= 0
            np.add.at(G, da[ma], gp[a, ma])
            np.add.at(GV, da[ma], gv[a, ma])
            for b in range(4):
                db = self.edofs[:, b]
                m = ma & (db >= 0)
                rows.append(da[m])
                cols.append(db[m])
                vals.append(hp[m, a, b])
                vals_v.append(hv[m, a, b])
        ij = (np.concatenate(rows), np.concatenate(cols))
        H = sp.csc_matrix((np.concatenate(vals), ij), shape=(N, N))  # duplicates are summed
        HV = sp.csc_matrix((np.concatenate(vals_v), ij), shape=(N, N))
        return float(psi.sum()), G, H, float(vol.sum()), GV, HV

    def mass(self):
        """Lumped L2 mass (nodal lengths) of every dof."""
        w = np.zeros(self.n + 1)
        w[:-1] += np.diff(self.R) / 2
        w[1:] += np.diff(self.R) / 2
        m = np.zeros(self.ndof)
        k = self.rdof >= 0
        m[self.rdof[k]] = w[k]
        k = self.zdof >= 0
        m[self.zdof[k]] = w[k]
        return m

    def start(self, shape):
        """The shooting meridian ``(R̂, r̂, ẑ)`` interpolated (monotone cubic) onto the mesh."""
        Rs, rs, zs = shape[:, 0], shape[:, 1], shape[:, 2]
        keep = np.concatenate([[True], np.diff(Rs) > 0])
        r = PchipInterpolator(Rs[keep], rs[keep])(self.R)
        z = PchipInterpolator(Rs[keep], zs[keep])(self.R)
        r[0], r[-1], z[-1] = 0.0, 1.0, 0.0
        return self.pack(r, z)

    def solve_pinned(self, x, p, l0, maxit=30):
        """Newton on ``∇Ψ − p∇V = 0`` with ``r_1 = λ0 R_1`` fixed and ``p`` free (a square system)."""
        k = self.rdof[1]
        x = x.copy()
        x[k] = l0 * self.R[1]
        free = np.delete(np.arange(self.ndof), k)
        for _ in range(maxit):
            _, G, H, _, GV, HV = self.assemble(x)
            J = sp.hstack([(H - p * HV)[:, free], sp.csc_matrix(-GV[:, None])], format="csc")
            d = spla.spsolve(J, -(G - p * GV))
            x[free] += d[:-1]
            p += d[-1]
            if np.max(np.abs(d)) < 1e-12:
                break
        return x, p

    def solve_fixed_volume(self, x, p, v0, maxit=30):
        """Newton on ``∇Ψ − p∇V = 0``, ``V = v0``; returns ``x, p`` and the final residual."""
        N = self.ndof
        for _ in range(maxit):
            _, G, H, V, GV, HV = self.assemble(x)
            J = sp.bmat([[H - p * HV, sp.csc_matrix(-GV[:, None])], [sp.csc_matrix(GV[None, :]), None]], format="csc")
            d = spla.spsolve(J, -np.concatenate([G - p * GV, [V - v0]]))
            x = x + d[:N]
            p += d[N]
            if np.max(np.abs(d)) < 1e-12:
                break
        _, G, _, V, GV, _ = self.assemble(x)
        return x, p, float(np.max(np.abs(np.concatenate([G - p * GV, [V - v0]]))))

    def constrained_eigenvalues(self, x, p, count=EIGENVALUES):
        """The ``count`` lowest eigenvalues of ``Zᵀ(∇²Ψ − p∇²V)Z`` against ``ZᵀMZ`` (``Z``: an orthonormal
        basis of the null space of ``∇Vᵀ``, ``M`` the lumped mass)."""
        _, _, H, _, GV, HV = self.assemble(x)
        Z = sla.null_space(GV[None, :])
        K = Z.T @ ((H - p * HV) @ Z)
        M = Z.T @ (self.mass()[:, None] * Z)
        return sla.eigh(0.5 * (K + K.T), 0.5 * (M + M.T), eigvals_only=True, subset_by_index=[0, count - 1])


# --- shooting states, folds and the rule ---------------------------------------------------------
@functools.cache
def _model(material: str, voltage: bool = True):
    if material == "gent":
        return build_model("gent", jlim=JLIM, voltage=voltage)
    return build_model("neo-hookean", voltage=voltage)


@functools.cache
def _folds(material: str, phi: float, l0_max: float, samples: int = 600):
    """Volume folds of the curve at ``Φ̂`` up to ``λ0 = l0_max``: ``(λ0, dp̂/dλ0, σ)`` per fold, located
    by the sign changes of the exact ``dV̂/dλ0`` on a dense scan and refined by Brent's method (only
    the valid run of states that ends at ``l0_max`` counts: below it the membrane wrinkles)."""
    model = _model(material)
    grid = np.linspace(1.0, l0_max, samples + 1)[1:]
    st = solve_states(model, grid, phi, SETTINGS, derivatives=True)
    assert st.ok[-1], f"the state at λ0 = {l0_max} is not valid"
    first = int(np.flatnonzero(~st.ok)[-1]) + 1 if (~st.ok).any() else 0
    dv = st.derivatives.dv_dl0

    def dv_dl0(l0):
        return float(solve_states(model, [l0], phi, SETTINGS, derivatives=True).derivatives.dv_dl0[0])

    folds = []
    for i in range(first, grid.size - 1):
        if dv[i] * dv[i + 1] < 0:
            lf = brentq(dv_dl0, grid[i], grid[i + 1], xtol=1e-12)
            at = solve_states(model, [lf], phi, SETTINGS, derivatives=True)
            folds.append((lf, float(at.derivatives.dp_dl0[0]), float(np.sign(dv[i]))))
    return tuple(folds)


def _rule_index(folds, l0):
    """Maddocks' rule applied to the located folds below ``λ0``: ``Δ = −sign(dp̂/dλ0 · σ)`` each."""
    return sum(-int(np.sign(dp * sigma)) for lf, dp, sigma in folds if lf < l0)


@functools.cache
def _fe_state(material: str, phi: float, l0: float, n: int, voltage: bool = True, fixed_volume: bool = True):
    """FE equilibria near the shooting state ``(λ0, Φ̂)`` on the ``n``-element mesh: ``pinned`` (pole
    stretch ``λ0``, its own volume) and, unless ``fixed_volume`` is false, ``fixed`` (volume ``V̂s``,
    started from the pinned one), each with the data its checks need."""
    st = solve_states(_model(material, voltage), [l0], phi, SETTINGS, shape=True)
    assert st.status[0] == 0, f"shooting state λ0 = {l0}, Φ̂ = {phi} failed (status {st.status[0]})"
    shape = st.shapes[0]
    ps, vs, psis = float(st.p_hat[0]), float(st.v_hat[0]), float(st.psi_hat[0])
    fe = _FE(material, JLIM, phi, _mesh(n))

    def describe(x, p):
        psi, G, _, V, GV, _ = fe.assemble(x)
        r, z = fe.nodes(x)
        eig = fe.constrained_eigenvalues(x, p)
        shape_dev = max(
            np.max(np.abs(np.interp(shape[:, 0], fe.R, r) - shape[:, 1])),
            np.max(np.abs(np.interp(shape[:, 0], fe.R, z) - shape[:, 2])),
        )
        assert eig[-1] > 0, f"more than {eig.size - 1} negative eigenvalues: compute more"
        return dict(
            p=p,
            v=V,
            psi=psi,
            gradient=float(np.max(np.abs(G - p * GV))),
            pole=r[1] / fe.R[1],
            shape_dev=shape_dev,
            eig=eig,
            count=int(np.sum(eig < 0)),
        )

    x, p = fe.solve_pinned(fe.start(shape), ps, l0)
    out = dict(p_shoot=ps, v_shoot=vs, psi_shoot=psis, pinned=describe(x, p), fixed=None)
    if fixed_volume:
        x, p, res = fe.solve_fixed_volume(x, p, vs)
        out["fixed"] = dict(describe(x, p), residual=res)
    return out


def _fe_index(material, phi, l0, meshes=MESHES, voltage=True, fixed_volume=True):
    """The FE index at ``(λ0, Φ̂)``, asserted converged and mesh-converged; returns it and the states."""
    states = [_fe_state(material, phi, l0, n, voltage, fixed_volume) for n in meshes]
    tag = f"{material} Φ̂={phi} λ0={l0}"
    for n, s in zip(meshes, states):
        pin, fix = s["pinned"], s["fixed"]
        assert pin["gradient"] < RESIDUAL_TOL, f"{tag} n={n}: pinned Newton residual {pin['gradient']:.2e}"
        assert abs(pin["v"] - s["v_shoot"]) < V_TOL, f"{tag} n={n}: pinned V − V̂ = {pin['v'] - s['v_shoot']:.2e}"
        assert abs(pin["p"] - s["p_shoot"]) < P_TOL, f"{tag} n={n}: pinned p − p̂ = {pin['p'] - s['p_shoot']:.2e}"
        assert pin["shape_dev"] < SHAPE_TOL, f"{tag} n={n}: pinned FE shape deviates by {pin['shape_dev']:.2e}"
        if fix is not None:
            assert fix["residual"] < RESIDUAL_TOL, f"{tag} n={n}: fixed-V Newton residual {fix['residual']:.2e}"
            assert abs(fix["pole"] - l0) < POLE_TOL, f"{tag} n={n}: fixed-V pole stretch {fix['pole']:.5f} (off branch)"
            assert fix["shape_dev"] < SHAPE_TOL, f"{tag} n={n}: fixed-V FE shape deviates by {fix['shape_dev']:.2e}"
            assert fix["psi"] == pytest.approx(s["psi_shoot"], abs=PSI_TOL), f"{tag} n={n}: Ψ̂"
            assert fix["count"] == pin["count"], f"{tag} n={n}: fixed-V count {fix['count']} ≠ pinned {pin['count']}"
    primary = [s["fixed"] or s["pinned"] for s in states]
    coarse, fine = primary[0], primary[-1]
    err_c, err_f = coarse["p"] - states[0]["p_shoot"], fine["p"] - states[-1]["p_shoot"]
    assert abs(err_c) < P_TOL, f"{tag}: |p_FE − p̂| = {abs(err_c):.2e} on n={meshes[0]}"
    assert abs(err_f) < abs(err_c) / P_CONVERGENCE, (
        f"{tag}: p error does not converge: {err_c:+.2e} (n={meshes[0]}) → {err_f:+.2e} (n={meshes[-1]})"
    )
    counts = [s["count"] for s in primary]
    assert len(set(counts)) == 1, f"{tag}: FE counts differ between meshes {meshes}: {counts}"
    # the eigenvalue nearest zero has the same sign on both meshes and moves by less than half of itself
    k = int(np.argmin(np.abs(fine["eig"])))
    wc, wf = coarse["eig"][k], fine["eig"][k]
    assert abs(wf - wc) < 0.5 * abs(wf), f"{tag}: eigenvalue nearest zero not resolved: {wc:.4g} → {wf:.4g}"
    return counts[0], states


def _check_states(material, phi, l0s, expected, meshes=MESHES, fixed_volume=True):
    """FE count == rule at the located folds == ``zone_index`` == ``expected`` at every ``λ0``."""
    folds = _folds(material, phi, max(l0s))
    model = _model(material)
    for l0, want in zip(l0s, expected):
        rule = _rule_index(folds, l0)
        assert rule == want, f"{material} Φ̂={phi} λ0={l0}: rule at the folds {folds} gives {rule}, expected {want}"
        count, _ = _fe_index(material, phi, l0, meshes, fixed_volume=fixed_volume)
        assert count == want, f"{material} Φ̂={phi} λ0={l0}: FE index {count}, expected {want}"
        zi = zone_index(model, np.sqrt(l0 - 1.0), phi, SETTINGS)
        assert zi == count, f"{material} Φ̂={phi} λ0={l0}: zone_index {zi} but the FE index is {count}"


# --- the FE model checks itself ------------------------------------------------------------------
def test_fe_energy_derivatives_and_volume():
    """The assembled gradient and Hessian match central differences; the volume of a spherical cap
    converges like h²; the flat membrane without voltage has zero energy and zero gradient."""
    fe = _FE("gent", JLIM, 0.25, _mesh(40))
    R = fe.R
    x = fe.pack(1.7 * R * (1 - 0.3 * R**2) + 0.3 * R * (1 - R), 1.2 * (1 - R**2) + 0.05 * np.sin(3 * R))
    psi, G, H, V, GV, HV = fe.assemble(x)
    H, HV = H.toarray(), HV.toarray()
    h = 1e-6
    rng = np.random.default_rng(0)
    for j in rng.choice(fe.ndof, 8, replace=False):
        e = np.zeros(fe.ndof)
        e[j] = h
        a, b = fe.assemble(x + e), fe.assemble(x - e)
        # tolerances: central differences, O(h²) truncation plus roundoff ~1e-16 · Ψ / h
        assert (a[0] - b[0]) / (2 * h) == pytest.approx(G[j], rel=1e-6, abs=1e-8)
        assert (a[3] - b[3]) / (2 * h) == pytest.approx(GV[j], rel=1e-6, abs=1e-8)
        assert np.max(np.abs((a[1] - b[1]) / (2 * h) - H[:, j])) < 1e-5 * (1 + np.max(np.abs(H[:, j])))
        assert np.max(np.abs((a[4] - b[4]) / (2 * h) - HV[:, j])) < 1e-6 * (1 + np.max(np.abs(HV[:, j])))
    # spherical cap of height c over the unit disc: V = π c (3 + c²)/6
    c = 0.8
    rho = (1 + c**2) / (2 * c)
    errs = []
    for n in (50, 100):
        fe = _FE("neo-hookean", JLIM, 0.0, _mesh(n))
        ang = fe.R * np.arcsin(1 / rho)  # polar angle on the sphere, uniform in R
        r, zc = rho * np.sin(ang), rho * np.cos(ang) - (rho - c)
        r[-1], zc[-1] = 1.0, 0.0
        errs.append(abs(fe.assemble(fe.pack(r, zc))[3] - np.pi * c * (3 + c**2) / 6))
    assert errs[0] < 1e-3 and errs[1] < errs[0] / 3.5, f"cap volume errors {errs}"
    fe = _FE("gent", JLIM, 0.0, _mesh(20))
    psi, G = fe.assemble(fe.pack(fe.R.copy(), np.zeros_like(fe.R)))[:2]
    assert abs(psi) < 1e-13 and np.max(np.abs(G)) < 1e-12


# --- case 3: no voltage, before any fold ---------------------------------------------------------
@pytest.mark.parametrize("material", ["neo-hookean", "gent"])
def test_no_voltage_states_are_stable(material):
    """Φ̂ = 0: no volume fold up to λ0 = 3 (V̂ rises monotonically); the FE index is 0 at λ0 = 1.5 and 3,
    on the rising and on the falling side of the pressure maximum (λ0 ≈ 2.2), and p̂ agrees."""
    assert _folds(material, 0.0, 3.0) == ()
    for l0 in (1.5, 3.0):
        count, states = _fe_index(material, 0.0, l0, voltage=False)
        assert count == 0, f"{material} Φ̂=0 λ0={l0}: FE index {count}"
        assert zone_index(_model(material, False), np.sqrt(l0 - 1.0), 0.0, SETTINGS) == 0
        assert min(states[-1]["fixed"]["eig"]) > 1.0  # clearly stable (measured lowest eigenvalue ≥ 10)


# --- case 1: the default scene, an S-shaped V̂(λ0) ------------------------------------------------
def test_gent_default_scene_s_curve():
    """Gent Jlim = 97, Φ̂ = 0.2372: a volume maximum at λ0 ≈ 4.142 and a minimum at λ0 ≈ 4.407, both
    with dp̂/dλ0 < 0 (≈ −0.072, −0.075): an S-shaped curve, index 0 → 1 → 0."""
    phi = 0.2372
    folds = _folds("gent", phi, 5.0)
    assert len(folds) == 2, folds
    (l1, dp1, s1), (l2, dp2, s2) = folds
    assert 4.1 < l1 < 4.2 and 4.35 < l2 < 4.45, folds
    assert (s1, s2) == (1.0, -1.0)
    assert dp1 < -0.05 and dp2 < -0.05, folds  # S-shape: the pressure falls through both folds
    _check_states("gent", phi, (2.0, 3.5, 4.29, 5.0), (0, 0, 1, 0))


# --- case 2: spirals -----------------------------------------------------------------------------
def test_gent_high_voltage_spiral_then_unwinds():
    """Gent Jlim = 97, Φ̂ = 0.27: folds at λ0 ≈ 3.090 (dp̂/dλ0 ≈ −0.084), 4.404 (+0.016: a spiral) and
    5.103 (+0.028, with σ = +1: the count goes down); the index is 0, 1, 2, 1 on the four pieces."""
    phi = 0.27
    folds = _folds("gent", phi, 5.4)
    assert len(folds) == 3, folds
    assert [round(f[0], 2) for f in folds] == [3.09, 4.40, 5.10], folds
    assert [f[2] for f in folds] == [1.0, -1.0, 1.0]
    assert folds[0][1] < -0.05 and folds[1][1] > 0.01 and folds[2][1] > 0.01, folds
    _check_states("gent", phi, (2.0, 3.6, 4.75, 5.4), (0, 1, 2, 1))


def test_neo_hookean_spiral():
    """Neo-Hookean, Φ̂ = 0.2: folds at λ0 ≈ 3.284 (dp̂/dλ0 ≈ −0.071) and 4.362 (+0.0066: a spiral);
    the index is 0, 1, 2."""
    phi = 0.2
    folds = _folds("neo-hookean", phi, 4.55)
    assert len(folds) == 2, folds
    assert [round(f[0], 2) for f in folds] == [3.28, 4.36], folds
    assert folds[0][1] < -0.05 and folds[1][1] > 0.005, folds
    _check_states("neo-hookean", phi, (2.0, 3.8, 4.55), (0, 1, 2))


def test_neo_hookean_deep_spiral_third_fold():
    """Neo-Hookean, Φ̂ = 0.2, λ0 = 4.85: past a third fold at λ0 ≈ 4.767 (σ = +1, dp̂/dλ0 ≈ −5.5e-4) the
    spiral adds a third unstable mode (FE: 3 on both meshes, lowest eigenvalues ≈ −136, −53, −15).

    ``zone_index`` returns 1 here (with its default 48 samples): it takes the pressure slope at the
    sample nearest the fold, λ0 = 4.85, where dp̂/dλ0 ≈ +6e-5 has already changed sign (the pressure
    extremum lies between the fold and the sample), so it counts this fold as −1 instead of +1."""
    phi, l0 = 0.2, 4.85
    folds = _folds("neo-hookean", phi, l0)
    assert len(folds) == 3, folds
    assert abs(folds[2][0] - 4.767) < 0.005 and folds[2][2] == 1.0 and folds[2][1] < 0, folds
    _check_states("neo-hookean", phi, (l0,), (3,))


def test_neo_hookean_deep_spiral_fourth_fold():
    """Neo-Hookean, Φ̂ = 0.2, λ0 = 4.94: past a fourth fold at λ0 ≈ 4.915 (σ = −1, dp̂/dλ0 ≈ +4.5e-5)
    the index is 4 (FE on n = 400, 800: lowest eigenvalues ≈ −331, −126, −47, −12; n = 200 does not yet
    resolve the boundary layer at the pole and shows 3). Only the pinned-pole FE state is used: the
    discretisation error of V̂ (~1e-6) exceeds the volume swing of the spiral between its folds here, so
    the fixed-volume problem at V̂s has its solution on a neighbouring piece of the FE spiral.

    ``zone_index`` returns 2 here: the fourth fold lies between its samples λ0 ≈ 4.78 and 4.94, and
    at 4.94 (the nearer one) dp̂/dλ0 ≈ −3e-7 has the opposite sign to that at the fold (+4.5e-5)."""
    phi, l0 = 0.2, 4.94
    folds = _folds("neo-hookean", phi, l0)
    assert len(folds) == 4, folds
    _check_states("neo-hookean", phi, (l0,), (4,), meshes=(400, 800), fixed_volume=False)
