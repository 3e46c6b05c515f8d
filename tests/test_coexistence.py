"""Coexistence: the CasADi equal-free-energy solver, N zones on a gas, and the paper's 4 kV transition."""

from dataclasses import replace

import numpy as np
import pytest
from conftest import complete_scene
from scipy.integrate import quad
from scipy.optimize import brentq

from coexist.coexistence import MaxwellSolver, maxwell_coexistence, phase_diagram
from coexist.continuation import EquilibriumMap
from coexist.errors import ModelRangeError
from coexist.model import build_model
from coexist.scene import load_scene
from coexist.shooting import solve_states
from coexist.simulation import Simulation, simulate_ramp
from coexist.zone_curves import ZoneCurve


def gent_curve(jlim, phi, n=128):
    model = build_model("gent", jlim)
    u = np.linspace(np.sqrt(0.002), np.sqrt(0.95 * np.sqrt((jlim + 3) / 2) - 1), n)
    return model, ZoneCurve.compute(model, phi, 1 + u**2)


@pytest.mark.parametrize("phi", [0.0, 0.1, 0.2])
def test_casadi_maxwell_agrees_with_scipy_equal_area(phi):
    """The CasADi Newton solve and an independent brentq on the equal-area function, same curve."""
    _, curve = gent_curve(100.0, phi)
    co = maxwell_coexistence(curve)
    solver = MaxwellSolver(curve)
    rising = [b for b in curve.branches if b.rising and b.usable]
    lo = max(rising[0].p_range[0], rising[1].p_range[0]) + 1e-9
    hi = min(rising[0].p_range[1], rising[1].p_range[1]) - 1e-9
    p_brent = brentq(solver.equal_area, lo, hi, xtol=1e-14)
    assert co.p_hat == pytest.approx(p_brent, rel=1e-10)
    assert co.pole_stretch_bulged > co.pole_stretch_unbulged + 0.5  # not the trivial solution


def test_equal_areas_hold_on_the_curve():
    """∫ p̂ dV̂ from the unbulged to the bulged state equals p̂ (V̂b − V̂u): the Maxwell rule itself,
    checked by quadrature of the spline (independent of the Ψ̂ the solver used)."""
    _, curve = gent_curve(100.0, 0.0)
    co = maxwell_coexistence(curve)
    uu, ub = curve.to_u(co.pole_stretch_unbulged), curve.to_u(co.pole_stretch_bulged)
    area, _ = quad(lambda u: float(curve.p(u) * curve.dv(u)), uu, ub, limit=400, epsabs=1e-12)
    assert area == pytest.approx(co.p_hat * (co.v_bulged - co.v_unbulged), rel=2e-6)


def test_coexisting_states_verified_by_shooting():
    """The two coexisting states, shot afresh, carry the same pressure to the curve's interpolation error."""
    model, curve = gent_curve(100.0, 0.1)
    co = maxwell_coexistence(curve)
    s = solve_states(model, [co.pole_stretch_unbulged, co.pole_stretch_bulged], 0.1).require_ok()
    err = curve.interpolation_error(model)["p_hat"]
    assert s.p_hat[0] == pytest.approx(co.p_hat, abs=10 * err)
    assert s.p_hat[1] == pytest.approx(co.p_hat, abs=10 * err)


def test_neo_hookean_has_no_coexistence():
    model = build_model("neo-hookean")
    u = np.linspace(np.sqrt(0.002), np.sqrt(5.0), 96)
    curve = ZoneCurve.compute(model, 0.0, 1 + u**2)
    with pytest.raises(ModelRangeError, match="no second stable branch"):
        maxwell_coexistence(curve)


def test_phase_diagram_critical_point():
    """Gent Jlim = 40: the pressure maximum and minimum appear together at a critical voltage near
    Φ̂ ≈ 0.232 (measured 0.23207); above it a binodal lies between the two spinodals."""
    model = build_model("gent", 40.0)
    d = phase_diagram(model, np.linspace(0.2, 0.3, 11), 0.95 * np.sqrt(43 / 2))
    assert d.critical_point is not None
    phi_c, p_c, _ = d.critical_point
    assert phi_c == pytest.approx(0.2321, abs=5e-4)
    ok = np.isfinite(d.binodal)
    assert ok.sum() >= 6 and not ok[0]
    assert np.all(d.spinodal_min[ok] < d.binodal[ok]) and np.all(d.binodal[ok] < d.spinodal_max[ok])
    # the loop closes at the critical point: max and min pressures approach each other
    gap = (d.spinodal_max - d.spinodal_min)[ok]
    assert gap[0] < 0.01 < gap[-1]


def test_two_interconnected_balloons():
    """Two balloons, no voltage, fixed gas: the symmetric state is stable below the pressure maximum and
    unstable beyond it, where one balloon grows at the other's expense in a stable asymmetric state.
    Every equilibrium is converged on the exact equations (Simulation.equilibria_at)."""
    from coexist.curves import pressure_volume_curve
    from coexist.effects import GasChamber
    from coexist.shooting import solve_states

    base = load_scene("two-balloons")
    sim = Simulation.from_scene(base)
    eqs = sim.equilibria_at(0.0)
    assert [e.label for e in eqs] == ["homogeneous"] and eqs[0].stable
    assert eqs[0].p_hat == pytest.approx(base.closing_pressure_hat, rel=1e-9)
    # the same chamber filled until each zone sits 5 % past its pressure maximum (in pole stretch)
    lp = [x for x in pressure_volume_curve(sim.model, 0.0).limit_points if x.kind == "pressure_max"][0]
    past = solve_states(sim.model, [lp.pole_stretch * 1.05], 0.0).require_ok()
    gas = GasChamber.closed_at(
        base.chamber_volume_hat, base.atmospheric_pressure_hat, float(past.p_hat[0]), 2 * float(past.v_hat[0])
    )
    emap = EquilibriumMap(sim.model, gas, 2, sim.settings, sim.phi_window)
    filled = replace(sim, gas=gas, closing_stretch=lp.pole_stretch * 1.05, emap=emap)
    eqs = filled.equilibria_at(0.0)
    sym = [e for e in eqs if e.k == 0 and abs(e.pole_stretch[0] - lp.pole_stretch * 1.05) < 1e-6]
    assert len(sym) == 1 and not sym[0].stable
    asym = [e for e in eqs if e.k == 1 and e.stable]
    assert asym, "beyond the maximum a stable asymmetric state must exist"
    assert asym[0].v_bulged > sym[0].v_unbulged > asym[0].v_unbulged


@pytest.fixture(scope="module")
def tricircle_ramp():
    scene = load_scene("tricircle")
    return scene, simulate_ramp(scene)


def test_tricircle_transitions_and_hysteresis(tricircle_ramp):
    _, report = tricircle_ramp
    up = [t for t in report.result.transitions if t.direction == "up" and t.kind == "spinodal"]
    down = [t for t in report.result.transitions if t.direction == "down" and t.kind == "spinodal"]
    assert up[0].from_label == "homogeneous" and up[0].to_label == "1 of 3 bulged"
    assert 3.8 < report.voltage_kV(up[0].phi_hat) < 4.0
    assert report.voltage_kV(down[-1].phi_hat) < report.voltage_kV(up[0].phi_hat)  # hysteresis
    (eq,) = report.result.equal_free_energy
    assert report.voltage_kV(down[-1].phi_hat) < report.voltage_kV(eq.phi_hat) < report.voltage_kV(up[0].phi_hat)


def test_neo_hookean_tricircle_bulges_without_bound():
    """Under the paper's conditions a neo-Hookean zone has no stable bulged state: when the homogeneous
    state is lost, the bulging zone's flow runs to its largest volume (a volume fold of its curve) with
    nothing stable beyond: no coexistence, and the ramp says why."""
    scene = replace(load_scene("tricircle"), material="neo-hookean", jlim=None, zone_radius=0.0205206)
    report = simulate_ramp(scene)
    (lost,) = [t for t in report.result.transitions if t.kind == "no_stable_state"]
    assert lost.from_label == "homogeneous" and "largest volume" in lost.reason
    assert not any(s.state is not None and s.state.k > 0 for s in report.result.steps)


def test_breakdown_effect_ends_the_ramp_only_when_asked_for():
    """single-zone with a 15 MV/m breakdown field: the path ends where the largest field reaches it, an
    event located on the exact equations (3.16393 kV; the field is 14.9 MV/m at 3.15 kV); without the
    field nothing is checked."""
    from coexist.scene import builtin_scene_text, parse_scene

    text = builtin_scene_text("single-zone").replace("breakdown_field_MV_per_m = 100", "breakdown_field_MV_per_m = 15")
    scene = parse_scene(text)
    assert "breakdown-check" in scene.effects()
    report = simulate_ramp(scene)
    (bd,) = [t for t in report.result.transitions if t.kind == "breakdown"]
    assert report.voltage_kV(bd.phi_hat) == pytest.approx(3.16393, abs=1e-5)
    assert max(bd.state_before.max_field) * scene.field_scale == pytest.approx(15e6, rel=1e-8)
    after = [s for s in report.result.steps if s.phi_hat > bd.phi_hat or s.direction == "down"]
    assert after and all(s.state is None for s in after)
    fields = [s.max_field * scene.field_scale for s in report.result.steps if s.max_field is not None]
    assert max(fields) < 15e6 and all(np.isfinite(fields))
    assert "max_field_MV_per_m" in report.to_dict()["steps"][0]
    plain = simulate_ramp(load_scene("tricircle")).to_dict()
    assert "max_field_MV_per_m" not in plain["steps"][0]
    assert "breakdown-check" not in load_scene("tricircle").effects()


def test_pressure_control_equal_free_energy_is_the_maxwell_voltage():
    """Without a chamber the zones are pressure-controlled (the gas effect is off). Then the voltage at
    which one bulged zone has the free energy of none (the coexistence table, on exact states) must be
    where the CasADi Maxwell construction on the single-zone curve gives exactly the controlled
    pressure: two independent routes to one number (to the Maxwell solver's spline error)."""
    from coexist.effects import PressureReservoir
    from coexist.scene import parse_scene

    text = (
        '[membrane]\nmaterial = "gent"\njlim = 97\nshear_modulus_kPa = 45\nrelative_permittivity = 4.7\n'
        "thickness_mm = 0.5\nzone_radius_mm = 21.4165\n[zones]\ncount = 3\n"
        "pressure_mbar = 17\n[voltage]\nstop_kV = 5\nstep_kV = 0.05\n"
    )
    scene = parse_scene(text)
    assert "pressure-control" in scene.effects() and "gas:isothermal-ideal-gas" not in scene.effects()
    sim = Simulation.from_scene(scene)
    assert isinstance(sim.gas, PressureReservoir)
    (entry,) = sim.coexistence([1])
    # one bulged zone against the homogeneous unbulged state (beside it, the three zones can also all be
    # bulged: a homogeneous configuration of its own, labelled so)
    assert [(c.from_label, c.to_label) for c in entry.crossings] == [("homogeneous", "1 of 3 bulged")]
    assert any(s.label == "homogeneous, all bulged" for s in sim.emap.segments)
    phi = entry.crossings[0].phi_hat
    model = scene.model()
    u = np.linspace(np.sqrt(0.002), np.sqrt(0.95 * np.sqrt(100 / 2) - 1), 256)
    co = maxwell_coexistence(ZoneCurve.compute(model, phi, 1 + u**2))
    assert co.p_hat == pytest.approx(scene.p_hat(17 * 100), rel=1e-6)


def test_scene_with_chamber_and_controlled_pressure_is_rejected():
    from coexist.errors import SceneError
    from coexist.scene import parse_scene

    with pytest.raises(SceneError) as info:
        parse_scene(
            complete_scene(
                "[zones]\ncount = 1\npressure_mbar = 10\n[chamber]\nvolume_ml = 300\nclosing_pressure_mbar = 20\n"
            )
        )
    assert info.value.field == "[zones].pressure_mbar"
