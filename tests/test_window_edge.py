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
