"""``Simulation.coexistence(bulged=...)`` takes whole numbers of bulged zones in 1..N−1, as ``coexist coexistence
--bulged`` does: 0 (the homogeneous state, stable from 0 to 3.9 kV in the tricircle) used to return the false
note "no stable state with 0 of 3 zones bulged", and 5 of 3 a note instead of an error."""

import pytest

from coexist.errors import SceneError
from coexist.scene import load_scene
from coexist.simulation import Simulation


@pytest.fixture(scope="module")
def sim():
    return Simulation.from_scene(load_scene("tricircle"))


@pytest.mark.parametrize(("bulged", "words"), [([0], "at least 1"), ([5], "at most 2"), ([1.5], "whole number")])
def test_a_number_of_bulged_zones_outside_1_to_n_minus_1_is_refused(sim, bulged, words):
    with pytest.raises(SceneError, match=words) as err:
        sim.coexistence(bulged=bulged)
    assert err.value.field == "bulged"


def test_one_bulged_zone_of_three_is_listed(sim):
    (entry,) = sim.coexistence(bulged=[1])
    assert entry.k == 1
