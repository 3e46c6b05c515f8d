"""A wrinkled band's pull-in born inside the band: the material's hoop-wrinkled stiffness ``K = dT̂1ʷ/dλ1`` first
vanishes at one stretch (``λ1 ≈ 5.21`` for Gent Jlim 97) at ``Φ̂c``; states whose band spans it are invalid just above
``Φ̂c`` and can be valid again a little higher, so a continuation step crossed them with both ends valid (review,
helper-77: the tricircle zones on a 1e6 ml chamber were listed stable past 3.72295 kV, and a ramp through 3.724 kV
exited 1 on the same scene)."""

import math
import re

import numpy as np
import pytest
from click.testing import CliRunner
from scipy.optimize import brentq

from coexist.cli.main import cli
from coexist.scene import builtin_scene_text, parse_scene
from coexist.wrinkling import band_pull_in_onset, softened_at


def _huge_chamber_text(values=None):
    text = re.sub(r"^volume_ml = .*$", "volume_ml = 1000000", builtin_scene_text("tricircle"), flags=re.M)
    if values is not None:
        text = text.replace("start_kV = 0\nstop_kV = 5\nstep_kV = 0.02", f"values_kV = {values}")
    return text


def _gent_stiffness_min(phi, jlim=97.0):
    """min over λ1 of K/T̂11 of a hoop-wrinkled Gent strip, written independently of coexist: per unit reference
    area ``W = −(Jlim/2) ln(1 − (I1 − 3)/Jlim) − (Φ̂²/2) λ1² λ2²`` (ideal dielectric, ``λ3 = 1/(λ1 λ2)``), ``T̂i =
    ∂W/∂λi``, the natural width ``T̂2 = 0`` by brentq, ``K = T̂11 − T̂12²/T̂22`` by central differences, on a dense grid
    around the dip."""

    def T(l1, l2):
        i1 = l1 * l1 + l2 * l2 + 1.0 / (l1 * l1 * l2 * l2)
        g = 1.0 / (1.0 - (i1 - 3.0) / jlim)
        t1 = g * (l1 - 1.0 / (l1**3 * l2 * l2)) - phi * phi * l1 * l2 * l2
        t2 = g * (l2 - 1.0 / (l1 * l1 * l2**3)) - phi * phi * l1 * l1 * l2
        return t1, t2

    best = math.inf
    for l1 in np.linspace(4.9, 5.5, 1201):
        w = brentq(lambda x, a=l1: T(a, x)[1], l1**-0.5, 5.0, xtol=1e-15, rtol=1e-15)
        d = 1e-6
        t11 = (T(l1 + d, w)[0] - T(l1 - d, w)[0]) / (2 * d)
        t12 = (T(l1, w + d)[0] - T(l1, w - d)[0]) / (2 * d)
        t22 = (T(l1, w + d)[1] - T(l1, w - d)[1]) / (2 * d)
        best = min(best, (t11 - t12 * t12 / t22) / t11)
    return best


def test_the_onset_of_the_wrinkled_pull_in_against_an_independent_strip():
    """Gent Jlim 97: ``Φ̂c = 0.22642983`` (3.722945 kV in the tricircle scene). The independent strip has its stiffness
    positive everywhere 1e-5 below it and negative somewhere 1e-5 above (its grid resolves the dip there)."""
    sc = parse_scene(_huge_chamber_text())
    layer = sc.model()
    phi_c = band_pull_in_onset(layer, float(sc.phi_hat(5e3)))
    assert phi_c == pytest.approx(0.22642983, rel=1e-7)
    assert float(sc.voltage_of(phi_c)) / 1e3 == pytest.approx(3.722945, abs=2e-6)
    assert _gent_stiffness_min(phi_c * (1 - 1e-5)) > 0
    assert _gent_stiffness_min(phi_c * (1 + 1e-5)) < 0
    assert not softened_at(layer, phi_c * (1 - 1e-5)) and softened_at(layer, 0.25)


@pytest.mark.parametrize("values", [None, "[0, 3.724]"])
def test_the_zones_of_a_huge_chamber_end_where_their_bands_pull_in(values):
    """The three zones on a 1e6 ml chamber (all bulged from 2.235 kV) end at the material's onset, 3.7229449 kV; the
    default path had gone on to 5 kV, and the path through 3.724 kV had exited 1 with 'no converged state on its
    stable segment'. Both give the end now, within its measured error of the onset."""
    import tempfile
    from pathlib import Path

    with tempfile.TemporaryDirectory() as d:
        path = Path(d) / "huge.toml"
        path.write_text(_huge_chamber_text(values))
        r = CliRunner().invoke(cli, ["ramp", str(path), "--json"])
    assert r.exit_code == 0, r.output
    import json

    ups = [t for t in json.loads(r.stdout)["transitions"] if t["direction"] == "up"]
    end = next(t for t in ups if t["kind"] == "no_stable_state")
    assert end["from"] == "homogeneous, all bulged"
    assert end["voltage_kV"] == pytest.approx(3.7229449, abs=max(3 * end["voltage_error_kV"], 1e-7))
