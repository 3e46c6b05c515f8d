"""The equal-area (Maxwell) solver and the phase diagram on a patterned zone (issue 13: "everything
downstream accepts any zone").

The Maxwell solver works on the splines of a zone curve; for a patterned zone the curve's states are shot
region by region (:class:`coexist.patterned.PatternedModel`). The check is made on the exact states: the two
coexisting pole stretches, shot again directly, carry the same pressure and satisfy the equal-area condition
``Ψ̂b − Ψ̂u = p̂ (V̂b − V̂u)`` (``dΨ̂ = p̂ dV̂`` along the curve), to the spline's accuracy.
"""

import json

import numpy as np
import pytest
from click.testing import CliRunner

from coexist.cli.main import cli
from coexist.coexistence import maxwell_coexistence
from coexist.effects import Gent, IdealDielectric
from coexist.model import MembraneModel
from coexist.patterned import PatternedModel, ZonePattern
from coexist.shooting import solve_states
from coexist.zone_curves import ZoneCurve


@pytest.mark.parametrize("phi", [0.0, 0.1, 0.2])
def test_patterned_equal_areas_on_exact_states(phi):
    model = PatternedModel.of(MembraneModel(Gent(97.0), IdealDielectric()), ZonePattern.inner_circle(0.5, 2))
    u = np.linspace(np.sqrt(1e-3), np.sqrt(5.5), 128)
    co = maxwell_coexistence(ZoneCurve.compute(model, phi, 1 + u**2))
    st = solve_states(model, [co.pole_stretch_unbulged, co.pole_stretch_bulged], phi).require_ok()
    P = co.p_hat
    # the spline solution against the exact states: pressures and the equal-area identity to 1e-6 of p̂ (the
    # splines' error; measured ~1e-9), and two distinct states
    assert st.p_hat[0] == pytest.approx(P, rel=1e-6) and st.p_hat[1] == pytest.approx(P, rel=1e-6)
    area = (st.psi_hat[1] - st.psi_hat[0]) - P * (st.v_hat[1] - st.v_hat[0])
    assert abs(area) <= 1e-6 * P * (st.v_hat[1] - st.v_hat[0])
    assert st.v_hat[1] > 1.3 * st.v_hat[0]


def test_phase_diagram_takes_the_scenes_pattern():
    """``coexist phase-diagram --scene inner-circle`` is the patterned zone's diagram (its binodal is not the
    uniform zone's), and its binodal at Φ̂ = 0.1 is the Maxwell pressure of the patterned curve."""
    r = CliRunner().invoke(
        cli, ["phase-diagram", "--scene", "inner-circle", "--points", "3", "--phi-hat", "0,0.2", "--json"]
    )
    assert r.exit_code == 0, r.output
    d = json.loads(r.stdout)
    uniform = CliRunner().invoke(
        cli, ["phase-diagram", "--material", "gent", "--jlim", "97", "--points", "3", "--phi-hat", "0,0.2", "--json"]
    )
    du = json.loads(uniform.stdout)
    assert abs(d["binodal_p_hat"][1] - du["binodal_p_hat"][1]) > 0.1
    model = PatternedModel.of(MembraneModel(Gent(97.0), IdealDielectric()), ZonePattern.inner_circle(0.5, 2))
    u = np.linspace(np.sqrt(1e-3), np.sqrt(5.5), 128)
    co = maxwell_coexistence(ZoneCurve.compute(model, 0.1, 1 + u**2))
    assert d["binodal_p_hat"][1] == pytest.approx(co.p_hat, rel=1e-6)
