"""The ramp down from the far bulged branch of a Gent tricircle at Jlim = 200 (helper-39).

At Jlim = 200 the one-of-three-bulged configuration has two stable branches: the near one (bulged zone about
46 ml at 2.64 kV), stable from its fold at 2.269332046 kV to its fold at 2.681287506 kV, and the far one
(bulged zone about 52 ml), stable from its fold at 2.642216633 kV up to the pull-in at 3.048 kV. Coming down
on the far branch, the state is lost at 2.6422166 kV and the zones must land on the near branch (the only
stable state there: the homogeneous one is stable only below 2.638494 kV).

The old code ended the ramp down there with "no stable state" all the way to 0 V: the gradient flow from the
lost state deflates the bulged zone through pole stretch ≈ 5.9, where the zone curve's slope ``dV̂/du`` dips
to 0.004 (between 3 and 850 on the curve) but stays positive. The flow's volume-fold trigger (10 floors of
1e-6 times the curve's largest slope, 0.009) fired there and the dip was taken for a volume fold. Now a trigger
is a fold only if the spline's slope reaches zero before its next minimum (``_volume_fold_ahead``).
"""

import json

import numpy as np
import pytest
from click.testing import CliRunner
from conftest import bounded, variant

from coexist.cli.main import cli
from coexist.ramp import _volume_fold_ahead
from coexist.scene import builtin_scene_text
from coexist.settings import SolverSettings
from coexist.simulation import Simulation
from coexist.zone_curves import ZoneCurve

#: the one-of-three-bulged stable ranges' ends (kV) by ``coexist coexistence`` at rtol 1e-10 (errors ±3e-9 kV)
FAR_FOLD_KV = 2.642216633
NEAR_FOLD_KV = 2.269332046
SPLIT_KV = 2.638493943
#: up to 2.64 kV (onto the near branch past the split), up to 3 kV (onto the far branch past the near branch's
#: fold at 2.681 kV), down to 2.64 kV (past the far branch's fold) and down to 2.2 kV (past the near one's)
PATH_KV = "[2.64, 3.0, 2.64, 2.2]"


@pytest.fixture(scope="module")
def report():
    scene = variant(jlim=200, values_kV=PATH_KV)
    sim = Simulation.from_scene(scene, SolverSettings(rtol=1e-10))
    return sim, bounded(sim.ramp)


def test_the_ramp_down_lands_on_the_near_branch_and_returns_to_homogeneous(report):
    sim, rep = report
    down = [t for t in rep.result.transitions if t.direction == "down" and t.kind != "equal_free_energy"]
    assert [(t.kind, t.event, t.from_label, t.to_label) for t in down] == [
        ("spinodal", "fold", "1 of 3 bulged", "1 of 3 bulged"),
        ("spinodal", "fold", "1 of 3 bulged", "homogeneous"),
    ]
    # the exact folds of the two branches (measured errors 3e-9 kV; 1e-8 kV allowed)
    assert abs(rep.voltage_kV(down[0].phi_hat) - FAR_FOLD_KV) < 1e-8
    assert abs(rep.voltage_kV(down[1].phi_hat) - NEAR_FOLD_KV) < 1e-8
    # the landing, at the far fold's voltage itself: on the near branch, stable, the bulged zone 46.0-46.2 ml
    after = down[0].state_after
    assert after is not None and after.stable
    assert abs(after.phi_hat - down[0].phi_hat) < 1e-12
    assert 46.0 < rep.volume_ml(max(after.zone_volumes)) < 46.2
    before = down[0].state_before
    assert abs(rep.volume_ml(max(before.zone_volumes)) - 51.252) < 0.01  # lost from the far branch (51.25216 ml)


def test_every_down_state_is_the_stable_state_that_exists(report):
    sim, rep = report
    steps = {(round(float(rep.voltage_kV(s.phi_hat)), 6), s.direction): s for s in rep.result.steps}
    up, down = steps[(2.64, "up")].state, steps[(2.64, "down")].state
    assert up is not None and down is not None and down.stable
    # at 2.64 kV the near branch is the only stable state: down there the zones are where the up pass put them
    assert up.label == down.label == "1 of 3 bulged"
    np.testing.assert_allclose(down.zone_volumes, up.zone_volumes, rtol=1e-9)
    assert abs(down.p_hat - up.p_hat) < 1e-9 * abs(up.p_hat)
    # ... and it is the one stable equilibrium the independent search at that voltage finds (volumes to 1e-7)
    stable = [e for e in sim.equilibria_at(steps[(2.64, "down")].phi_hat) if e.stable]
    assert len(stable) == 1 and stable[0].label == "1 of 3 bulged"
    np.testing.assert_allclose(sorted(stable[0].zone_volumes), sorted(down.zone_volumes), rtol=1e-7)
    # below the near branch's fold the zones are equal again
    low = steps[(2.2, "down")].state
    assert low is not None and low.stable and low.label == "homogeneous"
    assert rep.voltage_kV(low.phi_hat) < NEAR_FOLD_KV < SPLIT_KV


def test_the_cli_table_has_a_state_at_every_down_voltage(tmp_path):
    scene = builtin_scene_text("tricircle")
    scene = scene.replace("jlim = 97", "jlim = 200").replace(
        "start_kV = 0\nstop_kV = 5\nstep_kV = 0.02", f"values_kV = {PATH_KV}"
    )
    assert "jlim = 200" in scene and "values_kV" in scene
    path = tmp_path / "jlim200.toml"
    path.write_text(scene)
    result = bounded(CliRunner().invoke, cli, ["ramp", str(path), "--json"])
    assert result.exit_code == 0, result.output
    data = json.loads(result.stdout)
    down = [s for s in data["steps"] if s["direction"] == "down"]
    assert [round(s["voltage_kV"], 6) for s in down] == [2.64, 2.2]
    assert [s["configuration"] for s in down] == ["1 of 3 bulged", "homogeneous"]
    assert all(s["stable"] for s in down)
    # the near branch's bulged zone at 2.64 kV (the up pass's 46.027 ml; 0.01 ml allowed)
    assert abs(max(down[0]["zone_volumes_ml"]) - 46.027) < 0.01
    assert not any(t["kind"] == "no_stable_state" and t["direction"] == "down" for t in data["transitions"])


@pytest.mark.parametrize(
    "eps, fold",
    [(1e-3, False), (1e-8, False), (-1e-3, True)],
)
def test_a_slope_dip_is_a_volume_fold_only_where_the_slope_reaches_zero(eps, fold):
    # V̂(u) = (u − 1)³ + eps (u − 1): a cubic, reproduced exactly by the not-a-knot spline, slope 3(u − 1)² + eps
    u = np.linspace(0.2, 2.0, 19)
    v = (u - 1) ** 3 + eps * (u - 1) + 5.0
    curve = ZoneCurve(1.0 + u**2, np.ones_like(u), v, np.zeros_like(u), np.zeros_like(u), 0.1)
    start = 0.9  # the slope falls from here moving up in u (below the folds at 1 ± 0.018 when eps = −1e-3)
    assert _volume_fold_ahead(curve, start, +1.0) is fold
    assert _volume_fold_ahead(curve, 2.0 - start, -1.0) is fold
    # moving away from the dip, its slope rises: no fold ahead of a falling zone on that side either way
    assert _volume_fold_ahead(curve, 1.5, +1.0) is False
