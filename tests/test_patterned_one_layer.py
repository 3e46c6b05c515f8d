"""Patterned zones whose passive regions have one layer (``layers.passive = 1``), helper-37.

At zero voltage such a zone is ONE layer of one material everywhere: its interfaces carry the identity jump
``λ1⁺ = λ1⁻`` and it is the uniform zone exactly. The interface jump's bracket was doubled from ``λ1⁻`` into the
region where the Gent chains are locked (``1 − (I1 − 3)/Jlim < 0``, the tension formula negative there) and the
jump was refused as "dT1/dλ1 vanishes" from a pole stretch of about 5 on (Jlim = 97): the curve ended early, and
``coexist check`` capped prestretched one-layer scenes at a false pressure maximum (1.67 instead of 5.19 at
prestretch 1.5). A small electrode (5 % of the radius) lost its homogeneous state at a fold 0.002 in ``u`` before
the zone's volume maximum: the ramp's push (a volume step over ``dV̂/du ≈ 0``) left the zone curve and the jump
ended in an error instead of the named end."""

import json

import numpy as np
import pytest
from click.testing import CliRunner

from coexist import SolverSettings, load_scene, pressure_volume_curve
from coexist.cli.main import cli
from coexist.patterned import interface_stretch
from coexist.shooting import LOCKED, OK, solve_states
from coexist.simulation import Simulation

SCENE = """name = "one-layer"
description = "one 65 mm VHB Gent membrane, 300 ml chamber"
[membrane]
material = "gent"
jlim = 97
shear_modulus_kPa = 45
relative_permittivity = 4.7
thickness_mm = 0.5
zone_radius_mm = 32.5
prestretch = {pre}
wrinkling = "{wrinkling}"
{electrodes}[zones]
count = 1
[chamber]
volume_ml = 300
closing_pressure_mbar = {closing}
atmospheric_pressure_kPa = 101.325
[voltage]
start_kV = 0
stop_kV = 7.0
step_kV = {step}
"""


def _scene(tmp_path, name, fraction=None, pre=1.0, closing=13.0, step=0.02, wrinkling="refuse"):
    electrodes = (
        ""
        if fraction is None
        else f'[electrodes]\npattern = "inner-circle"\ninner_fraction = {fraction}\n[layers]\npassive = 1\n'
    )
    path = tmp_path / f"{name}.toml"
    path.write_text(SCENE.format(pre=pre, electrodes=electrodes, closing=closing, step=step, wrinkling=wrinkling))
    return path


def _model(path, settings):
    return Simulation.from_scene(load_scene(str(path)), settings).model


def test_the_identity_jump_near_locking():
    """Equal sides (one layer, no voltage) return ``λ1⁻`` itself, also where twice ``λ1⁻`` is locked."""
    from coexist.model import build_model

    model = build_model(material="gent", jlim=97)
    l1 = np.array([5.2, 6.0, 6.9])
    l2 = np.array([5.2, 4.0, 1.2])
    assert np.all(np.asarray(model.tensions(2 * l1, l2, 0.0)[4]) < 0)  # the first bracket's upper end is locked
    out, ok = interface_stretch(model, l1, l2, 0.0, 1.0, 0.0, 1.0)
    assert ok.all()
    assert np.array_equal(out, l1)
    # a real jump near locking: one layer at Φ̂/1 = 0.1 into a passive layer, root on the stiffening branch
    out, ok = interface_stretch(model, 6.0, 4.0, 0.1, 1.0, 0.0, 1.0)
    target = np.asarray(model.tensions(6.0, 4.0, 0.1)[0])
    assert ok.all() and 0 < float(out) < 6.0
    assert np.asarray(model.tensions(out, 4.0, 0.0)[0]) == pytest.approx(target, rel=1e-13)
    assert np.asarray(model.tensions(out, 4.0, 0.0)[4]) > 0


@pytest.mark.parametrize(
    "fraction, pre, wrinkling",
    [(0.5, 1.0, "refuse"), (0.05, 1.0, "refuse"), (0.5, 1.5, "refuse"), (0.5, 1.0, "tension-field")],
)
def test_zero_voltage_patterned_states_are_the_uniform_ones(tmp_path, fraction, pre, wrinkling):
    """At 0 V every region is one layer of the same material: the patterned states equal the uniform zone's up
    to its Gent locking (rtol 1e-10: measured ≤ 2e-11), and both lock at the same pole stretches (a tension-field
    membrane's relaxed patterned shooting too: at 0 V it is taut)."""
    settings = SolverSettings()
    patterned = _model(_scene(tmp_path, "ic", fraction, pre, wrinkling=wrinkling), settings)
    uniform = _model(_scene(tmp_path, "full", None, pre, wrinkling=wrinkling), settings)
    l0 = np.array([1.6, 3.0, 4.0, 4.6, 5.0, 5.5, 6.0, 6.5, 7.0, 7.2])  # the last past locking (about 7.05)
    a = solve_states(patterned, l0, 0.0, settings=settings)
    b = solve_states(uniform, l0, 0.0, settings=settings)
    assert list(b.status[:-1]) == [OK] * (l0.size - 1) and b.status[-1] == LOCKED
    assert list(a.status) == list(b.status), [a.failure_detail[i] for i in range(l0.size)]
    ok = b.status == OK
    assert np.max(np.abs(a.p_hat[ok] / b.p_hat[ok] - 1)) < 1e-8
    assert np.max(np.abs(a.v_hat[ok] / b.v_hat[ok] - 1)) < 1e-8


def test_zero_voltage_curve_reaches_the_uniform_end(tmp_path):
    """The 0 V ``p̂–V̂`` curve goes on to Gent locking as the uniform one does (it stopped at λ0 ≈ 5.19 with
    "dT1/dλ1 vanishes"); its limit points and last state equal the uniform ones."""
    settings = SolverSettings()
    l0 = np.linspace(1.01, 8.0, 120)
    a = pressure_volume_curve(_model(_scene(tmp_path, "ic", 0.5), settings), 0.0, l0, settings)
    b = pressure_volume_curve(_model(_scene(tmp_path, "full"), settings), 0.0, l0, settings)
    assert b.stopped_because and "gent_locking" in b.stopped_because
    assert a.stopped_because == b.stopped_because
    assert a.pole_stretch.size == b.pole_stretch.size
    assert a.p_hat[-1] == pytest.approx(b.p_hat[-1], rel=1e-8)
    assert [lp.kind for lp in a.limit_points] == [lp.kind for lp in b.limit_points]
    for x, y in zip(a.limit_points, b.limit_points):
        assert x.p_hat == pytest.approx(y.p_hat, rel=1e-8)


def test_check_of_a_prestretched_one_layer_scene_finds_the_uniform_maximum(tmp_path):
    """``coexist check``: the largest pressure of a prestretched (1.5) one-layer inner-circle zone is the uniform
    zone's, whatever the electrode's size (it was 1.67 for a half-radius electrode, 2.09 for 0.99)."""
    found = []
    for name, fraction in (("full", None), ("ic5", 0.5), ("ic99", 0.99)):
        r = CliRunner().invoke(cli, ["check", str(_scene(tmp_path, name, fraction, 1.5, 10.0))])
        assert r.exit_code == 0, r.output
        line = [x for x in r.output.splitlines() if "p̂max" in x]
        assert line, r.output
        found.append(float(line[0].split("p̂max = ")[1].split()[0]))
    assert found[0] > 5.0, found
    assert found[1] == pytest.approx(found[0], rel=1e-5) and found[2] == pytest.approx(found[0], rel=1e-5)


def test_a_small_electrode_ramp_ends_at_its_fold(tmp_path):
    """Electrode disc of 5 % of the radius: the homogeneous state is lost at a fold (Φ̂ = 0.3239178048); the flow
    reaches the zone's volume maximum and no other taut state holds that volume: ``no_stable_state`` [fold] with
    its reason, not an error. The fold is checked on the exact equations: a stable equilibrium 1e-6 below it,
    none 1e-6 above."""
    path = _scene(tmp_path, "ic", 0.05, step=0.5)
    r = CliRunner().invoke(cli, ["ramp", str(path), "--json"])
    assert r.exit_code == 0, r.output
    out = json.loads(r.stdout)
    kinds = [(t["kind"], t["event"]) for t in out["transitions"]]
    assert kinds == [("no_stable_state", "fold"), ("re_entry", "fold")], kinds  # back over the fold it left at
    assert "back over the fold where it was lost" in out["transitions"][1]["reason"]
    up = out["transitions"][0]
    assert up["voltage_kV"] == pytest.approx(5.325835987, abs=5e-8)
    assert "largest volume" in up["reason"], up
    sim = Simulation.from_scene(load_scene(str(path)), SolverSettings())
    phi = 0.3239178048
    below = sim.equilibria_at(phi * (1 - 1e-6))
    # the stable state and its unstable partner of the fold pair (5.4e-3 apart in λ0 at 1e-6 below the fold)
    assert sorted(e.stable for e in below) == [False, True]
    assert sim.equilibria_at(phi * (1 + 1e-6)) == []
