"""The coexistence table's equal-free-energy voltages of k of N bulged zones on variations of the ``tricircle`` scene,
against a calculation from scratch.

The independent calculation uses only the single-zone shooting (:func:`coexist.shooting.solve_states`, verified to
1e-8 in tests/test_shooting.py) and scipy. Its gas is built from the scene's own fields (the zones at the closing
pressure at 0 V on their rising branch, ``n̂ = (V̂c + N V̂)(p̂atm + p̂c)``). At each ``Φ̂`` the homogeneous state
(``brentq`` on ``p̂(λ0) = p̂gas(N V̂)``) and the state of ``N − k`` unbulged and ``k`` bulged zones (``hybr`` on the
common pressure and the gas) are solved on freshly shot states, and ``ΔĜ = Ĝ(k bulged) − Ĝ(homogeneous)`` is
bracketed by ``brentq`` in ``Φ̂``; the gas's part of ``ΔĜ`` is formed as ``−n̂ log1p(ΔV̂/(V̂c + V̂)) + p̂atm ΔV̂``,
without the rounding of two large logarithms. Its error: twice the change from rtol 1e-12 to 1e-11, plus the
rounding of ``ΔĜ`` over ``|ΔQ̂|``. Nothing of ``coexist.continuation``, ``coexist.ramp`` or the solvers of
``coexist.equilibria`` is used; the table's states serve only as first guesses (which branch).

Measured (kV; coexist at rtol 1e-10, error as printed; independent at 1e-12, its error; difference):

=============== ==== ================================ ================================ ==========
variation       k/N  coexist                          independent                      difference
=============== ==== ================================ ================================ ==========
4 zones         1/4  3.262126263 ± 2.8e-8             3.2621262541 ± 2.2e-11           8.4e-9
5 zones         1/5  3.017370563 ± 4.5e-9             3.0173705632 ± 2.6e-11           -2.4e-10
50 ml           1/3  3.654805005 ± 5.2e-9             3.6548050057 ± 4.2e-11           -2.3e-10
3000 ml         1/3  3.048015513 ± 7.8e-8             3.0480154875 ± 3.1e-11           2.5e-8
Gent Jlim 200   1/3  2.308209747 ± 3.8e-9             2.3082097471 ± 5.1e-11           -4.5e-11
radius −5 %     1/3  4.129829291 ± 4.2e-9             4.1298292904 ± 3.9e-11           2.6e-10
radius +2 %     1/3  2.783732141 ± 4.3e-9             2.7837321411 ± 7.5e-13           3.0e-11
=============== ==== ================================ ================================ ==========

(The default scene, 1/3, is checked the same way in tests/test_ramp.py.) The printed coexisting states (pressure,
both volumes and pole stretches) agree to every printed digit (relative 5e-8 at most, the 3000 ml chamber's).

Where the table has no equal-free-energy voltage the independent calculation agrees: two zones (the bulged
configuration branches continuously from the homogeneous one, which is unstable wherever it is stable), and the
configurations the table calls never stable between 0 and 5 kV (closing at 15 mbar, Gent Jlim 40, 2 of 4 and 2 of 5
bulged): a scan of the zone curve at 26 voltages finds no equilibrium, or only unstable ones. A radius 5 % larger
cannot hold the closing pressure (refused).
"""

import numpy as np
import pytest
from conftest import independent_gas, shoot_ok, variant
from scipy.optimize import brentq, root

from coexist.errors import SceneError
from coexist.scene import load_scene
from coexist.shooting import solve_states
from coexist.simulation import Simulation

RADIUS = 21.4165  # the tricircle's zone radius, mm
EPS = np.finfo(float).eps


# --- the independent calculation ----------------------------------------------------------------------------------
class Pair:
    """The homogeneous state and the state of ``N − k`` unbulged and ``k`` bulged zones at one voltage, solved afresh
    near the pole stretches ``lam_h`` and ``(lam_u, lam_b)`` (which follow the last solution)."""

    def __init__(self, model, gas, N, k, settings, lam_h, lam_u, lam_b):
        self.model, self.gas, self.N, self.k, self.settings = model, gas, N, k, settings
        self.lam_h, self.lam_ub = lam_h, np.array([lam_u, lam_b], dtype=float)

    def homogeneous(self, phi):
        def f(lam):
            s = shoot_ok(self.model, lam, phi, self.settings)
            return s.p_hat[0] - self.gas.pressure(self.N * s.v_hat[0])

        for w in (0.01, 0.05):
            a, b = self.lam_h - w, self.lam_h + w
            if f(a) * f(b) < 0:
                self.lam_h = brentq(f, a, b, xtol=1e-15, rtol=4 * EPS)
                return shoot_ok(self.model, self.lam_h, phi, self.settings)
        raise AssertionError(f"no homogeneous state near λ0 = {self.lam_h} at Φ̂ = {phi}")

    def mixed(self, phi):
        N, k = self.N, self.k

        def f(x):
            s = shoot_ok(self.model, x, phi, self.settings)
            return [s.p_hat[0] - s.p_hat[1], s.p_hat[0] - self.gas.pressure((N - k) * s.v_hat[0] + k * s.v_hat[1])]

        sol = root(f, self.lam_ub, method="hybr", options={"xtol": 1e-14})
        # hybr may stop at the shooting's noise without "success"; the residual says whether it converged
        assert np.max(np.abs(f(sol.x))) < 1e-10, (phi, sol.x)
        assert sol.x[1] - sol.x[0] > 1e-3, (phi, sol.x)  # still two distinct states
        self.lam_ub = sol.x
        return shoot_ok(self.model, sol.x, phi, self.settings)

    def delta_g(self, phi):
        """``ΔĜ = Ĝ(k bulged) − Ĝ(homogeneous)`` and both states."""
        N, k = self.N, self.k
        h, m = self.homogeneous(phi), self.mixed(phi)
        dpsi = (N - k) * (m.psi_hat[0] - h.psi_hat[0]) + k * (m.psi_hat[1] - h.psi_hat[0])
        return dpsi + self.gas.free_energy_difference((N - k) * m.v_hat[0] + k * m.v_hat[1], N * h.v_hat[0]), h, m


def independent_efe(model, gas, N, k, phi0, guesses, settings):
    """``Φ̂`` of ``ΔĜ = 0`` near ``phi0`` (the bracket widened from 1e-7 relative until ``ΔĜ`` changes sign), its
    rounding error ``4 ε Σ|terms| / |ΔQ̂|``, and the k-bulged state there."""
    pair = Pair(model, gas, N, k, settings, *guesses)
    g = lambda x: pair.delta_g(x)[0]  # noqa: E731
    for rel in (1e-7, 1e-6, 1e-5, 1e-4, 1e-3):
        a, b = phi0 * (1 - rel), phi0 * (1 + rel)
        if g(a) * g(b) < 0:
            break
    else:
        raise AssertionError(f"ΔĜ does not change sign within 1e-3 of Φ̂ = {phi0}")
    phi = brentq(g, a, b, xtol=1e-16, rtol=4 * EPS)
    _, h, m = pair.delta_g(phi)
    dq = N * h.q_hat[0] - (N - k) * m.q_hat[0] - k * m.q_hat[1]
    terms = N * abs(h.psi_hat[0]) + (N - k) * abs(m.psi_hat[0]) + k * abs(m.psi_hat[1])
    return phi, 4 * EPS * terms / abs(dq), pair.lam_ub, m


# --- equal free energy on the variations ------------------------------------------------------------------------
EFE_CASES = {
    "4 zones": (dict(count=4), 1),
    "5 zones": (dict(count=5), 1),
    "50 ml": (dict(volume_ml=50), 1),
    "3000 ml": (dict(volume_ml=3000), 1),
    "Jlim 200": (dict(jlim=200), 1),
    "radius -5 %": (dict(zone_radius_mm=RADIUS * 0.95), 1),
    "radius +2 %": (dict(zone_radius_mm=RADIUS * 1.02), 1),
}


@pytest.mark.parametrize("name", list(EFE_CASES))
def test_equal_free_energy_agrees_with_an_independent_calculation(name):
    """The table's voltage within its printed error plus the independent one's; its coexisting state (pressure mbar,
    volumes ml, λ0) equal at every printed digit (half a unit of the fourth decimal) and to relative 1e-6 (measured:
    5e-8). Every other k of these scenes is never stable in the table (checked in
    ``test_never_stable_configurations_have_no_stable_equilibrium`` for 2 of 4 and 2 of 5)."""
    changes, k = EFE_CASES[name]
    scene = variant(**changes)
    sim = Simulation.from_scene(scene)
    entry = {e.k: e for e in sim.coexistence()}[k]
    # against the homogeneous state (Jlim 200 also has one between two branches of 1 of 3 bulged, 2.65655915 kV)
    (c,) = [x for x in entry.crossings if "homogeneous" in (x.from_label, x.to_label)]
    assert {c.from_label, c.to_label} == {"homogeneous", f"{k} of {scene.zone_count} bulged"}
    hom, mix = (c.state_before, c.state_after) if c.from_label == "homogeneous" else (c.state_after, c.state_before)
    N, kv = scene.zone_count, scene.voltage_scale / 1e3
    assert scene.voltage_scale == pytest.approx(16441.9, rel=1e-5)  # `coexist check`: voltage_scale_V
    guesses = (hom.pole_stretch[0], mix.pole_stretch_unbulged, mix.pole_stretch_bulged)
    res = {}
    for rtol in (1e-12, 1e-11):
        settings = sim.settings.with_rtol(rtol)
        gas = independent_gas(scene, sim.model, settings)
        res[rtol] = independent_efe(sim.model, gas, N, k, c.phi_hat, guesses, settings)
    assert gas.n == pytest.approx(sim.gas.gas_amount, rel=1e-9)  # the same gas
    phi, rounding, lam, m = res[1e-12]
    own_error = 2 * abs(phi - res[1e-11][0]) + rounding
    assert own_error * kv < 1e-9  # measured at most 1e-10 kV
    assert abs(c.phi_hat - phi) <= c.phi_hat_error + own_error, (c.phi_hat * kv, c.phi_hat_error * kv, phi * kv)
    # the printed coexisting state: mbar, unbulged ml, λ0, bulged ml, λ0 (`coexist coexistence`, 4 decimals)
    mine = (
        scene.pressure(m.p_hat[0]) / 100,
        scene.volume(m.v_hat[0]) * 1e6,
        lam[0],
        scene.volume(m.v_hat[1]) * 1e6,
        lam[1],
    )
    table = (
        scene.pressure(mix.p_hat) / 100,
        scene.volume(mix.v_unbulged) * 1e6,
        mix.pole_stretch_unbulged,
        scene.volume(mix.v_bulged) * 1e6,
        mix.pole_stretch_bulged,
    )
    for a, b in zip(mine, table):
        assert abs(a - b) < 5e-5 and a == pytest.approx(b, rel=1e-6), (mine, table)


# --- no equal free energy ---------------------------------------------------------------------------------------
def test_two_zones_have_no_equal_free_energy():
    """Two zones: 1 of 2 bulged is stable from the homogeneous state's branch point (a merge, 3.852 kV) up, so the two
    configurations are never stable at one voltage and the table lists no equal-free-energy voltage, with a note that
    says why. Independently, at voltages across both stable ranges of 1 of 2 bulged the homogeneous state
    (followed from 0 V) has ``dp̂/dV̂ < 0``, its antisymmetric mode unstable, and ``ΔĜ < 0``: no crossing."""
    scene = variant(count=2)
    sim = Simulation.from_scene(scene)
    (entry,) = sim.coexistence()
    assert len(entry.segments) == 2
    # none with the homogeneous state; the one between the two branches of 1 of 2 bulged is 3.997852120 kV
    assert [c for c in entry.crossings if "homogeneous" in (c.from_label, c.to_label)] == []
    (branches,) = entry.crossings
    assert branches.from_label == branches.to_label == "1 of 2 bulged"
    assert sim.scene.voltage_of(branches.phi_hat) / 1e3 == pytest.approx(3.997852120, abs=2e-8)
    assert "no equal free energy with the homogeneous state: the two are never stable at one voltage" in entry.note
    assert "homogeneous state from 0 kV to 3.85216 kV" in entry.note
    settings = sim.settings
    gas = independent_gas(scene, sim.model, settings)
    kv = scene.voltage_scale / 1e3
    pair = Pair(sim.model, gas, 2, 1, settings, sim.closing_stretch, np.nan, np.nan)
    for phi in np.linspace(0, entry.segments[0].end_phi(-1), 40)[1:]:  # follow the homogeneous state up
        pair.homogeneous(phi)
    assert min(seg.end_phi(-1) for seg in entry.segments) * kv == pytest.approx(3.852155, abs=1e-5)
    for seg in entry.segments:
        lo, hi = seg.end_phi(-1), seg.end_phi(1)
        for phi in np.linspace(lo, hi, 7)[1:-1]:
            st = seg.states([phi], coincident=False)[0]  # only the first guess: which branch
            pair.lam_ub = np.array([st.pole_stretch_unbulged, st.pole_stretch_bulged])
            dg, h, _ = pair.delta_g(phi)
            s = shoot_ok(sim.model, [pair.lam_h - 1e-6, pair.lam_h + 1e-6], phi, settings)
            slope = (s.p_hat[1] - s.p_hat[0]) / (s.v_hat[1] - s.v_hat[0])
            assert dg < 0 and slope < 0, (phi * kv, dg, slope)


def zone_index(model, lam_b, phi, settings, n=2000):
    """Unstable modes of one zone at fixed volume at ``λ0 = lam_b``, by the fold rule of docs/physics.md §4: walking
    ``λ0`` up, each volume fold (sign change of ``dV̂/dλ0`` from ``σ``) changes it by ``−sign(dp̂/dλ0 σ)``."""
    pre = model.prestretch
    lam = pre + np.linspace(np.sqrt(1e-3 * pre), np.sqrt(lam_b - pre), n) ** 2
    s = solve_states(model, lam, phi, settings)
    first = int(np.argmax(s.status == 0))
    assert (s.status[first:] == 0).all(), "a failed state on the way: a fold could hide there"
    dv, dp = np.diff(s.v_hat[first:]), np.diff(s.p_hat[first:])
    folds = np.nonzero(dv[:-1] * dv[1:] < 0)[0]
    return sum(-int(np.sign((dp[j] + dp[j + 1]) * np.sign(dv[j]))) for j in folds)


def scan(model, gas, N, k, phis, settings, lam_cap, n=600):
    """Equilibria of ``N − k`` zones on the zone curve's first rising branch and ``k`` further out at one pressure on
    the gas: at each ``Φ̂`` the sign changes of ``r(λb) = p̂(λb) − p̂gas((N − k) V̂(λu) + k V̂(λb))`` (``λu`` on the
    rising branch at the pressure ``p̂(λb)``, interpolated), each converged by ``hybr`` on fresh states. Returns
    ``(Φ̂, λu, λb)`` of each. (With ``N − k ≥ 2`` an unbulged zone past the pressure maximum is unstable itself.)"""
    pre = model.prestretch
    lam = pre + np.linspace(np.sqrt(1e-3 * pre), np.sqrt(lam_cap - pre), n) ** 2
    found = []
    for phi in phis:
        s = solve_states(model, lam, phi, settings)
        ok = s.status == 0
        p, v = np.where(ok, s.p_hat, np.nan), np.where(ok, s.v_hat, np.nan)
        first = int(np.argmax(ok))
        end = first + int(np.argmin(ok[first:])) if not ok[first:].all() else n
        falls = np.nonzero(np.diff(p[first:end]) < 0)[0]
        top = first + int(falls[0]) if len(falls) else end - 1
        pr, lr, vr = p[first : top + 1], lam[first : top + 1], v[first : top + 1]
        pb, vb = p[top + 1 :], v[top + 1 :]
        lu, vu = np.interp(pb, pr, lr), np.interp(pb, pr, vr)
        inside = (pb > pr[0]) & (pb < pr[-1])
        r = np.where(inside, pb - gas.pressure((N - k) * vu + k * vb), np.nan)
        for j in np.nonzero(r[:-1] * r[1:] < 0)[0]:  # NaN (outside, failed) compares False
            pair = Pair(model, gas, N, k, settings, np.nan, lu[j], lam[top + 1 + j])
            pair.mixed(phi)
            found.append((phi, *pair.lam_ub))
    return found


NEVER_STABLE = {
    "15 mbar, 1 of 3": (dict(closing_pressure_mbar=15), 1, 0),
    "15 mbar, 2 of 3": (dict(closing_pressure_mbar=15), 2, 0),
    "Jlim 40, 1 of 3": (dict(jlim=40), 1, 0),
    "4 zones, 2 of 4": (dict(count=4), 2, 4),
    "5 zones, 2 of 5": (dict(count=5), 2, 2),
}


@pytest.mark.parametrize("name", list(NEVER_STABLE))
def test_never_stable_configurations_have_no_stable_equilibrium(name):
    """The table: never stable between 0 and 5 kV, so no equal free energy. Independently, every 0.2 kV from 0 to 5 kV
    the scan finds no equilibrium (15 mbar, Jlim 40) or only unstable ones (2 of 4, 2 of 5: measured 4 and 2, each with
    a bulged zone on a falling part, ``dp̂/dV̂ < 0`` with multiplicity k − 1, or past an odd number of volume folds)."""
    changes, k, expected = NEVER_STABLE[name]
    scene = variant(**changes)
    sim = Simulation.from_scene(scene)
    (entry,) = sim.coexistence([k])
    N = scene.zone_count
    assert entry.segments == [] and entry.crossings == []
    assert entry.note == f"no stable state with {k} of {N} zones bulged between 0 and 5 kV"
    settings = sim.settings
    gas = independent_gas(scene, sim.model, settings)
    lam_cap = 0.999 * np.sqrt((scene.jlim + 3) / 2)  # Gent locking at the pole: 2λ0² + λ0⁻⁴ − 3 < Jlim
    found = scan(sim.model, gas, N, k, np.linspace(0, scene.phi_hat(5000), 26), settings, lam_cap)
    assert len(found) == expected, found
    for phi, lu, lb in found:
        s = shoot_ok(sim.model, [lu - 1e-6, lu + 1e-6, lb - 1e-6, lb + 1e-6], phi, settings)
        a_u = (s.p_hat[1] - s.p_hat[0]) / (s.v_hat[1] - s.v_hat[0])
        a_b = (s.p_hat[3] - s.p_hat[2]) / (s.v_hat[3] - s.v_hat[2])
        unstable = (N - k >= 2 and a_u < 0) or (k >= 2 and a_b < 0) or zone_index(sim.model, lb, phi, settings) != 0
        assert unstable, (phi, lu, lb, a_u, a_b)


def test_radius_five_percent_larger_is_refused():
    """A zone radius 5 % larger makes 20 mbar ``p̂c = 1.999``, above the zone's snap-through ``p̂max = 1.9727`` at 0 V
    (independently: the largest pressure on a fine grid of the zone curve): the scene is refused, nothing to compare."""
    scene = variant(zone_radius_mm=RADIUS * 1.05)
    model = load_scene("tricircle").model()
    lam = 1 + np.linspace(1e-3, 2, 4000)
    p_max = float(np.nanmax(solve_states(model, lam, 0.0).p_hat))
    assert p_max == pytest.approx(1.97275, abs=1e-4)
    assert scene.p_hat(2000.0) > p_max
    with pytest.raises(SceneError, match="snap-through"):
        Simulation.from_scene(scene)
