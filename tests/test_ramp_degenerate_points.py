"""Ramps through degenerate points of the states: a path voltage on a pitchfork (two zones whose split falls
exactly on the path grid) and a wrinkled band that pulls in over a stretch shorter than a continuation step
(one pressure-controlled zone). Both used to exit with "no converged state ... on its stable segment"."""

import numpy as np
import pytest

from coexist.scene import load_scene
from coexist.simulation import Simulation

MEMBRANE = """
name = "degenerate"
[membrane]
material = "gent"
jlim = 97
shear_modulus_kPa = 45
relative_permittivity = 4.7
thickness_mm = 0.5
zone_radius_mm = {radius}
prestretch = 1.0
wrinkling = "tension-field"
"""


def _scene(tmp_path, text):
    path = tmp_path / "scene.toml"
    path.write_text(text)
    return load_scene(path)


def test_path_voltage_on_a_pitchfork(tmp_path):
    """Two zones on a 300 ml chamber, the radius fitted so that the (continuous) split is at 3.9 kV: on the
    way down 3.9 kV lies within the symmetric branch point's uncertainty (4e-11 in Φ̂ above the located
    merge, whose error is about 3e-10), where Newton's method at fixed voltage on the split configuration
    cannot converge. The state there is the coincident one: both zones equal, to 1e-9 in pole stretch, and
    the same state as on the way up (the homogeneous one) to 1e-9."""
    text = MEMBRANE.format(radius="21.386364016105813") + (
        "[zones]\ncount = 2\n[chamber]\nvolume_ml = 300\nclosing_pressure_mbar = 20\n"
        "atmospheric_pressure_kPa = 101.325\n[voltage]\nvalues_kV = [3.9, 3.92, 5.0, 3.92, 3.9, 3.88]\n"
    )
    rep = Simulation.from_scene(_scene(tmp_path, text)).ramp()
    steps = rep.result.steps
    up, down = steps[0], steps[4]
    assert up.state is not None and down.state is not None
    assert up.state.configuration.counts == (2,)
    assert down.state.configuration.counts == (1, 1)
    assert np.ptp(down.state.pole_stretch) < 1e-9  # the coincident state
    assert down.state.pole_stretch[0] == pytest.approx(up.state.pole_stretch[0], abs=1e-9)
    assert down.state.residual < 1e-9
    assert any("symmetric branch point" in n for n in down.state.notes)
    kinds = [t.kind for t in rep.result.transitions]
    assert kinds[0] == "spinodal" and kinds[-1] == "merge"
    # the split and the merge are one voltage, 3.9 kV, within their measured errors (about 5e-9 kV)
    split, merge = rep.result.transitions[0], rep.result.transitions[-1]
    for t in (split, merge):
        kv = rep.voltage_kV(t.phi_hat)
        assert kv == pytest.approx(3.9, abs=2e-8)
        assert 0 < rep.voltage_kV(t.phi_hat_error) < 2e-8
    # no equal-free-energy voltage at the pitchfork (the two segments hold one state there)
    assert all(abs(rep.voltage_kV(t.phi_hat) - 3.9) > 1e-3 for t in rep.result.equal_free_energy)
    # and the output says which state it is (JSON and table)
    (row,) = [d for d in rep.to_dict()["steps"] if d["direction"] == "down" and d["voltage_kV"] == 3.9]
    assert any("symmetric branch point" in n for n in row["state_notes"])


def test_pull_in_inside_a_continuation_step(tmp_path):
    """One zone at a controlled 17.8235 mbar, tension-field wrinkling: the wrinkled band's states stop being
    valid (pull-in) at 3.7229449 kV, are invalid up to about 3.76 kV and valid again beyond. The segment
    must end at the first invalid state, reported as the range end with its measured error; 3.74 kV has
    no stable state (it used to be solved on the segment and fail)."""
    text = MEMBRANE.format(radius="21.4165") + (
        "[zones]\ncount = 1\npressure_mbar = 17.82347895732696\n"
        "[voltage]\nvalues_kV = [3.3, 3.72, 3.74, 5.0, 3.74, 3.72, 1.8]\n"
    )
    rep = Simulation.from_scene(_scene(tmp_path, text)).ramp()
    steps = rep.result.steps
    assert steps[1].state is not None and steps[2].state is None and steps[4].state is None
    assert steps[5].state is not None and min(steps[5].state.min_tension) == 0  # wrinkled, re-entered
    ends = [t for t in rep.result.transitions if t.kind == "no_stable_state"]
    assert len(ends) == 1 and ends[0].event == "range_end"
    assert "pull-in" in ends[0].reason
    # located at rtol 1e-10, measured again at rtol/100: 3.7229449 kV, its error below 1e-6 kV
    assert rep.voltage_kV(ends[0].phi_hat) == pytest.approx(3.7229449, abs=1e-6)
    assert 0 < rep.voltage_kV(ends[0].phi_hat_error) < 1e-6
