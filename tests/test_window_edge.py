"""A continuation step that leaves the voltage window ends on the window's edge.

Two of three tricircle zones bulged on a 1e6 ml chamber closed at 20.1 mbar (the bulged zones' 0 V pressure
minimum is near the chamber's pressure): on the way down a step from Φ̂ = 0.0377 went to Φ̂ = −0.0169 and
landed on another branch of the mirrored states (bulged λ0 3.86 where the mirror of the branch has 4.5); a
"split" located on that jump (at 0.06 ± 0.05 kV, with the within-group eigenvalue 0.0016 > 0 at its own
state) ended the segment, the ramp exited 1 ("jump from 2 of 3 bulged ... no landing found") and
`coexistence` listed the configuration's range twice (review, helper-77 D2/D3).
"""

import pytest
from conftest import IndependentGas, variant

from coexist.simulation import Simulation


@pytest.fixture(scope="module")
def sim():
    return Simulation.from_scene(variant(volume_ml="1e6", closing_pressure_mbar="20.1"))


def test_the_ramp_comes_down_to_zero_volts_in_a_stable_state(sim):
    rep = sim.ramp()
    last = rep.result.steps[-1]
    assert last.phi_hat == 0.0 and last.direction == "down"
    eq = last.state
    assert eq.configuration.counts == (1, 2)
    assert eq.stable and eq.min_eigenvalue > 1e-4  # the bulged pair's within-group mode: dp̂/dV̂ ≈ 1.5e-3
    assert eq.residual < 1e-9
    # the pressure is the chamber's gas at the zones' total volume (an independent ideal gas closed with three
    # zones of the closing state's volume at the closing pressure)
    first = rep.result.steps[0].state
    assert first.configuration.counts == (3,)
    scene = sim.scene
    ps, vs = scene.shear_modulus * scene.thickness / scene.zone_radius, scene.zone_radius**3
    vc, patm = scene.chamber.volume / vs, scene.chamber.atmospheric_pressure / ps
    gas = IndependentGas(vc, patm, (vc + 3 * first.v_hat[0]) * (patm + first.p_hat))
    assert first.p_hat == pytest.approx(scene.chamber.closing_pressure / ps, rel=1e-9)
    assert eq.p_hat == pytest.approx(gas.pressure(sum(eq.zone_volumes)), rel=1e-9)
    # every transition lies inside the voltage path's range, with an error far below its voltage
    top = max(s.phi_hat for s in rep.result.steps)
    for t in rep.result.transitions:
        assert 0.0 < t.phi_hat < top
        assert t.phi_hat_error < 1e-6 * t.phi_hat


def test_each_configuration_is_listed_with_one_range_from_zero_volts(sim):
    entries = sim.coexistence()
    assert [e.k for e in entries] == [1, 2]
    for entry in entries:
        (seg,) = entry.segments
        lo, hi = seg.phi_range
        assert lo == 0.0 and hi > 0.05
        # every traced state of the segment lies in the window
        assert min(p.phi for p in seg.points) >= 0.0


@pytest.mark.parametrize("stop", ["2.13071", "2.1307062847"])
def test_a_path_that_stops_next_to_a_fold(stop):
    """The two bulged zones fold at 2.1307062847 kV (± 2e-9). A top 3.7e-6 kV above it: the jump's landing was sought
    past the top, where the landing's segment is cut off, and the ramp exited 1 ("outside the stable segment through
    it"); it lands halfway to the top now, on the all-bulged state as with a top of 5 kV. A top 5.8e-11 kV below it
    (inside its uncertainty, where Newton's method at fixed voltage cannot converge) exited 1 ("no converged
    state"); the fold's own state is given there, with a note (review, helper-81)."""
    sim = Simulation.from_scene(variant(volume_ml="1e6", closing_pressure_mbar="20.1", stop_kV=stop))
    rep = sim.ramp()
    ups = [t for t in rep.result.transitions if t.direction == "up"]
    kv = [rep.voltage_kV(t.phi_hat) for t in ups]
    assert kv[:2] == pytest.approx([1.488421154, 1.801153170], abs=1e-8)
    top = max(rep.result.steps, key=lambda s: s.phi_hat)
    if stop == "2.13071":
        assert kv[2] == pytest.approx(2.130706285, abs=1e-8) and ups[2].to_label == "homogeneous, all bulged"
        assert top.state.configuration.counts == (3,)
    else:
        assert len(ups) == 2 and top.state.configuration.counts == (1, 2)
        assert any("of the fold at" in n for n in top.state.notes)
        assert rep.voltage_kV(top.state.phi_hat) == pytest.approx(2.130706285, abs=1e-8)


def test_a_path_voltage_inside_a_split_that_is_also_a_fold():
    """Three Gent 30 zones of 9.835060062 mm on a 1e6 ml chamber at 27.75 mbar (a radius `coexist fit` put the
    split at 6.38 kV, a path voltage): the homogeneous segment ends at a split 6.5e-12 in Φ̂ above the path voltage,
    which under near pressure control is also the fold of the homogeneous branch, so Newton's method there did not
    converge and the ramp exited 1 ("no converged state ... on its stable segment"; a robustness sweep, helper-87).
    The split's own state is given there, with a note, and the ramp goes on (the transitions as measured, their
    errors ~7e-9 kV)."""
    scene = variant(
        jlim="30",
        zone_radius_mm="9.835060062",
        volume_ml="1e6",
        closing_pressure_mbar="27.75",
        start_kV="2",
        stop_kV="8",
        step_kV="0.02",
    )
    rep = Simulation.from_scene(scene).ramp()
    kinds = [(t.kind, t.from_label, t.to_label) for t in rep.result.transitions[:3]]
    assert kinds == [
        ("spinodal", "homogeneous", "1 of 3 bulged"),
        ("spinodal", "1 of 3 bulged", "2 of 3 bulged"),
        ("spinodal", "2 of 3 bulged", "homogeneous, all bulged"),
    ]
    assert rep.voltage_kV(rep.result.transitions[0].phi_hat) == pytest.approx(6.38, abs=1e-8)
    (at,) = [s for s in rep.result.steps if s.direction == "up" and abs(rep.voltage_kV(s.phi_hat) - 6.38) < 1e-9]
    assert any("of the split at" in n for n in at.state.notes)
    assert at.state.configuration.counts == (3,)
