"""The states of one patterned zone along the voltage (coexist.shapes.zone_path, `coexist shape`) do not depend on
which voltages are asked for: a step that finds no state is halved from the last state, a failed pole stretch next
to the root does not end the branch, and a step that lands on another branch is taken for the fold it crosses.

Checked against the ramp (coexist.continuation, an independent path-following code on the same exact states): the
end of the states lies inside the bracket the path reports, whatever the requested voltages.
"""

import numpy as np
import pytest

from coexist.scene import builtin_scene_text, parse_scene
from coexist.settings import SolverSettings
from coexist.shapes import scene_zone_path
from coexist.simulation import Simulation


def _ring_scene():
    """One zone with a ring electrode (R/A 0.3 to 0.8) between two-layer passive regions, closed at 16 mbar: its
    states end where the hoop tension at the ring's inner edge falls to zero (wrinkling), at 6.1275 kV."""
    text = builtin_scene_text("inner-circle")
    for key, val in (
        ("pattern", '"ring"'),
        ("inner_fraction", "0.3\nouter_fraction = 0.8"),
        ("closing_pressure_mbar", "16"),
        ("stop_kV", "6.2"),
    ):
        lines = [f"{key} = {val}" if ln.startswith(f"{key} =") else ln for ln in text.splitlines()]
        text = "\n".join(lines) + "\n"
    assert 'pattern = "ring"' in text and "passive = 2" in text
    return parse_scene(text)


def _end_kV(scene, path):
    return tuple(float(scene.voltage_of(x)) / 1e3 for x in path.end_phi_hat)


@pytest.fixture(scope="module")
def ring():
    sc = _ring_scene()
    ramp = Simulation.from_scene(sc, SolverSettings(error_estimates=False)).ramp()
    (end,) = [t for t in ramp.result.transitions if t.kind == "no_stable_state" and t.direction == "up"]
    return sc, float(sc.voltage_of(end.phi_hat)) / 1e3


@pytest.mark.parametrize("kV", [(0.0, 5.9, 6.0, 6.1, 6.2), tuple(np.arange(0, 6.6, 0.5))])
def test_ring_states_end_where_the_ramp_ends_whatever_the_voltages_asked(ring, kV):
    """Large steps (0 to 5.9 kV at once) or coarse ones (0.5 kV) reach the same end: wrinkling at the ring's edge,
    bracketed to 2e-5 kV around the ramp's end (6.12748 kV; the old path stopped at 5.93 kV, or found no state
    at 5.9 kV, where pole stretches near the state wrinkle)."""
    sc, ramp_end = ring
    path, _ = scene_zone_path(sc, [float(sc.phi_hat(1e3 * v)) for v in kV])
    lo, hi = _end_kV(sc, path)
    assert path.end_kind == "wrinkled"
    assert 0 < hi - lo <= 2e-5 and lo - 1e-6 <= ramp_end <= hi + 1e-6
    assert ramp_end == pytest.approx(6.12748, abs=1e-4)
    assert path.phi_hat.size == sum(v < ramp_end for v in kV)


def test_ring_state_at_six_kV_is_the_same_from_either_path(ring):
    """The state at 6.0 kV reached from 5.9 kV or through 0.5 kV steps: the same pole stretch to 1e-8 (each is the
    gas balance solved to the solver's tolerance)."""
    sc, _ = ring
    a, _ = scene_zone_path(sc, [float(sc.phi_hat(v)) for v in (0.0, 6000.0)])
    b, _ = scene_zone_path(sc, [float(sc.phi_hat(v)) for v in np.arange(0, 6001, 500.0)])
    assert a.pole_stretch[-1] == pytest.approx(b.pole_stretch[-1], rel=1e-8)
    assert a.pole_stretch[-1] == pytest.approx(1.340018, abs=2e-6)


@pytest.mark.parametrize("kV", [(0.0, 4.0, 4.3), (0.0, 4.3)])
def test_inner_circle_ends_at_its_fold_not_on_the_far_branch(kV):
    """The inner-circle lens snaps through at 4.178657 kV (the ramp's fold). A step from 4 kV to 4.3 kV (halved
    towards the fold) ends there as a snap-through, not as a wrinkled state of the far branch (the old path said
    "wrinkled: no state above 4.183975 kV"), and a step from 0 V straight to 4.3 kV the same."""
    sc = parse_scene(builtin_scene_text("inner-circle"))
    path, _ = scene_zone_path(sc, [float(sc.phi_hat(1e3 * v)) for v in kV])
    lo, hi = _end_kV(sc, path)
    assert path.end_kind == "snap-through"
    assert 0 < hi - lo <= 2e-5 and lo - 1e-6 <= 4.178656594 <= hi + 1e-6
    assert path.phi_hat.size == len(kV) - 1
