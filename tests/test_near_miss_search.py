"""The near-miss search of :func:`coexist.candidates._roots` ends on brackets narrower than the floats can halve.

Its golden-section search ran until the bracket was 1e-12 of its first width; where that is below the spacing of the
floats (a bracket of ~3e-6 around a pressure of 1.9) the bracket stops shrinking and the loop never ended: ``coexist fit
--kind equal_free_energy`` on two Gent 60 zones on a 1e6 ml chamber hung at its fourth trial radius (22.0687 mm).
"""

import re
import signal

import numpy as np
import pytest

from coexist.candidates import _roots
from coexist.errors import ModelRangeError
from coexist.scene import builtin_scene_text, parse_scene
from coexist.simulation import Simulation


@pytest.fixture
def deadline():
    """Fail (instead of hanging) after 60 s."""

    def fail(*_):
        raise TimeoutError("did not finish within 60 s")

    old = signal.signal(signal.SIGALRM, fail)
    signal.alarm(60)
    yield
    signal.alarm(0)
    signal.signal(signal.SIGALRM, old)


def test_a_dip_on_a_narrow_bracket_far_from_zero(deadline):
    """``f(x) = (x − c)² + d`` sampled at ``1.9 + 1e-6 k``: a dip without a sign change (a near miss) between samples
    whose spacing is 1e-6, so 1e-12 of the bracket (2e-18) is below the floats' spacing at 1.9 (2.2e-16). The
    extremum is returned, within a few float spacings of ``c`` (the minimum of a parabola is flat: to ``√eps``)."""
    c, d = 1.9 + 1.3e-6, 1e-20
    x = 1.9 + 1e-6 * np.arange(5.0)

    def f(xv, rows):
        return (np.asarray(xv) - c) ** 2 + d

    rows, roots = _roots(f, x, f(x, None)[None, :])
    assert rows.tolist() == [0]
    assert abs(roots[0] - c) < 1e-7  # the golden section on a flat minimum: about √eps · scale


def test_fit_trial_radius_that_hung(deadline):
    """The trial radius that hung: its equal-free-energy transition does not exist up to 5 kV (a named error, in
    about 1.4 s)."""
    text = builtin_scene_text("tricircle")
    for key, value in (("jlim", "60"), ("volume_ml", "1000000"), ("count", "2"), ("zone_radius_mm", "22.0687295264")):
        text = re.sub(rf"^{key} = .*$", f"{key} = {value}", text, flags=re.M)
    sim = Simulation.from_scene(parse_scene(text))
    with pytest.raises(ModelRangeError, match="no voltage up to 5 kV at which 1 of 2 bulged has the free energy"):
        sim.first_transition("equal_free_energy")
