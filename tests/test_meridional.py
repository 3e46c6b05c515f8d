"""Why only the hoop direction wrinkles in a pressurised zone (docs/physics.md, section 10).

The cap of the membrane inside the reference radius ``R̂`` is in vertical equilibrium whatever its
material does: the meridional force on its rim carries the pressure on its projected area,

    2π R̂ T̂1 sin θ = p̂ π r̂²,   so   T̂1 = p̂ r̂² / (2 R̂ sin θ) > 0   for p̂ > 0, 0 < θ < π.

So a pressurised state can be neither meridionally wrinkled nor slack anywhere (slack needs ``p̂ = 0``).
The identity is checked along taut *and* hoop-wrinkled segments of independently shot relaxed states
(scipy, :mod:`coexist.studies.wrinkled_shooting`): it can fail if a segment's equations are wrong.
"""

import numpy as np
import pytest

from coexist.effects import Gent, IdealDielectric, NeoHookean
from coexist.model import MembraneModel
from coexist.studies.wrinkled_shooting import shoot_relaxed
from coexist.wrinkling import natural_width

CASES = [
    # the default scene's bulged zone near its pull-in: an interior wrinkled band
    (Gent(97.0), 5.8275, 0.26375),
    # a barely inflated neo-Hookean zone at high voltage: wrinkled out to the clamp
    (NeoHookean(), 1.03, 0.3),
]


@pytest.mark.parametrize("elasticity,l0,phi", CASES)
def test_meridional_tension_carries_the_cap(elasticity, l0, phi):
    model = MembraneModel(elasticity, IdealDielectric(), 1.0, wrinkling="tension-field")
    s = shoot_relaxed(model, l0, phi, rtol=1e-12)
    assert s.status == "ok" and s.wrinkled_radii, "the case must pass through a wrinkled segment"
    kinds = set()
    for seg in s.segments:
        R0, R1 = seg["R"]
        R = np.linspace(R0, R1, 101)[1:]
        l1, rho, theta = seg["solution"](R)[:3]
        l2 = rho if seg["kind"] == "taut" else natural_width(model, l1, phi)
        T1 = model.tensions(l1, l2, phi)[0]
        cap = s.p_trial * (rho * R) ** 2 / 2  # p̂t r̂²/2 in the trial scaling
        # the identity to the integration's accuracy (rtol 1e-12; measured below 7e-10)
        assert np.max(np.abs(R * T1 * np.sin(theta) - cap) / cap) < 1e-8
        assert np.all(T1 > 0)
        kinds.add(seg["kind"])
    assert kinds == {"taut", "wrinkled"}
