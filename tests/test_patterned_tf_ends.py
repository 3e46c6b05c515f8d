"""Where a ring electrode's tension-field branch ends at the onset of wrinkling (audit helper-51).

A ring electrode (one layer) between two-layer passive regions: at the ring's inner edge the meridional force of the
passive disc puts the ring's side at a large ``λ1``. When its hoop tension reaches zero there, its wrinkled stiffness
``K = T̂11 − T̂12²/T̂22`` is already negative (past the maximum of ``T̂1ʷ``): no tension-field state continues the
branch (the relaxed states at the next pole stretches are a far, Gent-stiffened state of about 7.5 times the volume).
The ramp's end is then the onset itself, located like the refused scene's (the root of the formally continued
states' smallest tension), and named so: before, it was named by a failed corrector iterate (``out_of_range``, one
zone of ring 0.4/0.9) or by a bisection on validity as a pull-in with an error of 2e-7 kV (three zones of ring
0.2/0.8), where the refused scenes end at the same voltage to 1e-8 kV.
"""

import json

import numpy as np
from click.testing import CliRunner
from conftest import ring_scene
from scipy.optimize import brentq

from coexist.cli.main import cli

ONE_RING = dict(name="one_ring", fi=0.4, fo=0.9, count=1, mbar=25, path="[0, 6.3, 6.4, 6.3]")
RING_28 = dict(name="r28_p23", fi=0.2, fo=0.8, count=3, mbar=23, path="[0, 3.2, 4.1, 3.2]")


def _end(tmp_path, scene, wrinkling):
    path = tmp_path / f"{scene['name']}_{wrinkling}.toml"
    path.write_text(ring_scene(wrinkling, **scene))
    r = CliRunner().invoke(cli, ["ramp", str(path), "--json"])
    assert r.exit_code == 0, r.output
    (t,) = [t for t in json.loads(r.stdout)["transitions"] if t["kind"] == "no_stable_state"]
    return t


def test_one_ring_ends_at_its_onset_named_so(tmp_path):
    # the refused scene: 6.36497247 kV ± 1e-8 (tests/test_ring_tension_field_end.py)
    t = _end(tmp_path, ONE_RING, "tension-field")
    assert "wrinkling_pull_in" in t["reason"] and "out_of_range" not in t["reason"], t["reason"]
    assert abs(t["voltage_kV"] - 6.36497247) <= 2e-8 and t["voltage_error_kV"] <= 2e-8


def test_three_rings_end_at_the_refused_scenes_onset(tmp_path):
    tf, refused = _end(tmp_path, RING_28, "tension-field"), _end(tmp_path, RING_28, "refuse")
    assert "wrinkling_pull_in" in tf["reason"] and "no natural width" not in tf["reason"], tf["reason"]
    assert tf["voltage_error_kV"] <= 2e-8  # was 2e-7: a validity bisection's bracket, not the onset's error
    err = tf["voltage_error_kV"] + refused["voltage_error_kV"]
    assert abs(tf["voltage_kV"] - refused["voltage_kV"]) <= err and abs(tf["voltage_kV"] - 4.040074554) <= 2e-8


def test_the_ring_side_of_the_inner_edge_is_past_its_pull_in_at_the_onset(tmp_path):
    """The reason printed: at the onset (Φ̂ = 0.3871181757, one zone of ring 0.4/0.9) the ring's side of its inner
    edge has ``T̂2 ≈ 0`` and ``K < 0``, and the tension-field state at a pole stretch just past the onset is far from
    the taut branch (no continuation)."""
    from coexist.patterned import PatternedModel
    from coexist.scene import load_scene
    from coexist.shooting import solve_states

    path = tmp_path / "one_ring.toml"
    path.write_text(ring_scene("tension-field", **ONE_RING))
    scene = load_scene(path)
    model, phi = scene.model(), 0.3871181757
    zone = PatternedModel.of(model, scene.zone_pattern())
    taut = solve_states(zone, np.array([1.30785]), phi, formal=True)  # onset at λ0 ≈ 1.30788
    assert taut.status[0] == 0 and 0 < taut.min_tension[0] < 1e-4
    (pole_side, ring_side) = taut.interfaces[0, 0]
    rho, force = pole_side[1] / pole_side[0], ring_side[4]

    def T(a, b, k):
        return float(np.asarray(model.tensions(a, b, phi)[k]))

    l1 = brentq(lambda a: T(a, rho, 0) - force, 2.3, 2.8)
    h = 1e-6
    T11 = (T(l1 + h, rho, 0) - T(l1 - h, rho, 0)) / (2 * h)
    T12 = (T(l1, rho + h, 0) - T(l1, rho - h, 0)) / (2 * h)
    T22 = (T(l1, rho + h, 1) - T(l1, rho - h, 1)) / (2 * h)
    assert T11 > 0.5 and abs(T(l1, rho, 1)) < 1e-4  # taut-stable, its hoop tension vanishing
    assert T11 - T12**2 / T22 < -1.0  # measured -1.85: the wrinkled meridian is past its pull-in
    past = solve_states(zone, np.array([1.3079, 1.3080]), phi)
    assert np.all(past.status == 0) and np.all(past.v_hat > 5 * taut.v_hat[0])  # measured 18.02 against 2.42
