"""The sweep's jump fields: the first transition up and down where the zones' state jumps. For two zones the
split is continuous (a pitchfork: the bulged branch starts at the homogeneous state), so the spinodal voltages
and their 'hysteresis' of 0 say nothing about where the zones jump; the jump is the fold inside the bulged
configuration (4.106 kV up, 3.949 kV down). For three zones the split is the jump. Checked against the ramp's
own transitions and the states either side of them."""

import numpy as np
import pytest

from coexist import load_scene
from coexist.settings import SolverSettings
from coexist.simulation import Simulation
from coexist.sweep import JUMP_VOLUME, evaluate_point, make_spec


@pytest.fixture(scope="module")
def records():
    spec = make_spec(load_scene("tricircle"), ["zones.count=2,3"], SolverSettings())
    return spec, [evaluate_point(spec, i) for i in range(spec.size)]


def _jumps(scene):
    """(kV, kind, event) of the ramp's transitions whose states differ by more than JUMP_VOLUME in some zone."""
    sim = Simulation.from_scene(scene, SolverSettings(error_estimates=False))
    report = sim.ramp()
    out = {}
    for t in report.result.transitions:
        if t.state_before is None or t.state_after is None:
            continue
        a, b = np.sort(t.state_before.zone_volumes), np.sort(t.state_after.zone_volumes)
        out.setdefault(t.direction, []).append((float(report.voltage_kV(t.phi_hat)), np.max(np.abs(b - a) / a)))
    return out


def test_two_zones_jump_at_the_fold_not_at_the_continuous_split(records):
    spec, recs = records
    two = recs[0]
    assert two["status"] == "bulges"
    assert two["spinodal_up_kV"] == pytest.approx(3.852155213, abs=1e-8)
    assert two["hysteresis_kV"] == pytest.approx(0.0, abs=1e-8)  # the split and the merge: one voltage
    assert two["jump_up_kV"] == pytest.approx(4.106048950, abs=1e-8)
    assert two["jump_down_kV"] == pytest.approx(3.948982644, abs=1e-8)
    assert two["jump_hysteresis_kV"] == pytest.approx(4.106048950 - 3.948982644, abs=2e-8)
    assert 0 < two["jump_up_error_kV"] < 1e-7 and 0 < two["jump_down_error_kV"] < 1e-7
    # independently: the ramp's transitions, and how far each moves the zones' volumes
    jumps = _jumps(spec.scene_at(0))
    ups = [kv for kv, dv in jumps["up"] if dv > JUMP_VOLUME]
    split = [dv for kv, dv in jumps["up"] if abs(kv - 3.852155213) < 1e-6]
    assert ups[0] == pytest.approx(two["jump_up_kV"], abs=1e-8)
    assert split and split[0] < 0.01  # the split moves the volumes by ~0.3 %: continuous


def test_three_zones_jump_at_the_split(records):
    _, recs = records
    three = recs[1]
    assert three["jump_up_kV"] == pytest.approx(three["spinodal_up_kV"], abs=1e-12)
    assert three["jump_down_kV"] == pytest.approx(three["spinodal_down_kV"], abs=1e-12)
    assert three["jump_up_kV"] == pytest.approx(3.900030858, abs=1e-8)
    assert three["jump_hysteresis_kV"] == pytest.approx(three["hysteresis_kV"], abs=1e-12)


def test_a_fold_within_a_configuration_does_not_leave_it():
    """Two zones: on the way up the 1-of-2 branch folds at 4.106048950 kV onto another 1-of-2 state and is left only at
    its range end, 4.352468013 kV; on the way down it folds at 3.948982644 kV and is left at the merge, 3.852155214
    kV (``coexist ramp``). The sweep's ``loss_up``/``loss_down`` took the first transition out of a state, the folds
    (review, helper-74)."""
    import re

    from coexist.scene import builtin_scene_text, parse_scene
    from coexist.simulation import Simulation
    from coexist.sweep import summarise

    scene = parse_scene(re.sub(r"^count = 3$", "count = 2", builtin_scene_text("tricircle"), flags=re.M))
    sim = Simulation.from_scene(scene)
    rec = summarise(0, sim, sim.ramp())
    up, down = dict(rec["loss_up"]), dict(rec["loss_down"])
    assert up[0] == pytest.approx(3.852155214, abs=2e-8) and up[1] == pytest.approx(4.352468013, abs=2e-8)
    assert down[1] == pytest.approx(3.852155214, abs=2e-8)


def test_no_hysteresis_between_jumps_that_do_not_return():
    """Gent 300: the first jump up leaves the homogeneous state at 1.489 kV, the first jump down is a fold from the
    large bulged branch to the small one at 2.157 kV. Their difference, −0.668 kV, was the sweep's
    ``jump_hysteresis_kV`` (review, helper-82). It is NaN now, the reason names both jumps; the default scene, whose
    jump down returns from the jump up, keeps its hysteresis."""
    spec = make_spec(load_scene("tricircle"), ["membrane.jlim=300,97"], SolverSettings())
    j300, j97 = (evaluate_point(spec, i) for i in range(2))
    assert j300["jump_up_kV"] == pytest.approx(1.489198, abs=1e-5)
    assert j300["jump_down_kV"] == pytest.approx(2.156831, abs=1e-5)
    assert j300["jump_hysteresis_kV"] is None
    assert "no jump_hysteresis_kV: the first jump down" in j300["reason"] and "does not return" in j300["reason"]
    assert j97["jump_hysteresis_kV"] == pytest.approx(j97["jump_up_kV"] - j97["jump_down_kV"], abs=1e-12)
    assert j97["jump_hysteresis_kV"] > 0


def test_a_pressure_controlled_point_counts_its_all_bulged_zones():
    """Three zones at a controlled 20.1 mbar: at 1.458281425 kV all three jump to their bulged branch together (a
    homogeneous state past the pressure maximum, "homogeneous, all bulged"). The sweep said ``top_bulged`` 0 and
    ``bulged_after_jump`` 0 beside that label, and had no ``loss_up`` for the unbulged state (review, helper-82)."""
    from coexist.scene import builtin_scene_text, parse_scene
    from coexist.sweep import summarise

    text = builtin_scene_text("tricircle")
    text = text[: text.index("[chamber]")] + text[text.index("[voltage]") :]
    text = text.replace("count = 3", "count = 3\npressure_mbar = 20.1")
    sim = Simulation.from_scene(parse_scene(text))
    rec = summarise(0, sim, sim.ramp())
    assert rec["top_configuration"] == "homogeneous, all bulged"
    assert rec["top_bulged"] == 3 and rec["bulged_after_jump"] == 3
    assert rec["jump_up_kV"] == pytest.approx(1.458281425, abs=1e-8)
    assert dict(rec["loss_up"])[0] == pytest.approx(1.458281425, abs=1e-8)
