"""Why a voltage–charge curve starts late or stops early names its cause, with numbers that an independent shot
reproduces: the zero-voltage pressure already below ``p̂`` (a voltage only lowers it), or a pressure that stays
above ``p̂`` up to the voltage where the states fail (and how they fail). And ``coexist curves`` can skip either
family (``--phi-hat none`` / ``--p-hat none``), refusing to skip both."""

import json
import re

import numpy as np
import pytest
from click.testing import CliRunner
from conftest import one_line_error

from coexist.cli.main import cli
from coexist.curves import voltage_charge_curve
from coexist.model import build_model
from coexist.shooting import solve_states

GRID = np.linspace(1.01, 4.0, 200)


@pytest.fixture(scope="module")
def model():
    return build_model("neo-hookean", voltage=True)


def _number(text, label):
    m = re.search(re.escape(label) + r"\s*([0-9.eE+-]+[0-9])", text)
    assert m, (label, text)
    return float(m.group(1))


def test_late_start_names_the_zero_voltage_pressure(model):
    """p̂ = 1.5: below the first state, the zero-voltage pressure is already below 1.5, and the value said is
    that of an independent zero-voltage shot (to the 6 digits printed)."""
    c = voltage_charge_curve(model, 1.5, GRID)
    why = c.starts_because
    assert "at zero voltage its pressure is already below" in why
    first = int(np.flatnonzero(np.isclose(GRID, c.pole_stretch[0]))[0])
    p0 = float(solve_states(model, GRID[first - 1 : first], 0.0).p_hat[0])
    assert p0 < 1.5
    assert _number(why, "already below, p̂ =") == pytest.approx(p0, rel=1e-5)


def test_early_stop_names_the_failure_above_the_pressure(model):
    """p̂ = 1.2: beyond the last state the pressure stays above 1.2 up to the voltage where the states fail: an
    independent shot at the last voltage said below it has p̂ > 1.2 (the value said), and one just above the
    failure voltage said fails."""
    c = voltage_charge_curve(model, 1.2, GRID)
    why = c.stopped_because
    assert "stays above it up to" in why and "where its states fail:" in why
    nxt = GRID[int(np.flatnonzero(np.isclose(GRID, c.pole_stretch[-1]))[0]) + 1 : None][:1]
    phi_fail = _number(why, "stays above it up to Φ̂ =")
    phi_lo = _number(why, "at Φ̂ =")
    p_lo = _number(why, "(p̂ =")
    below = solve_states(model, nxt, phi_lo)
    assert below.ok[0] and below.p_hat[0] > 1.2
    assert below.p_hat[0] == pytest.approx(p_lo, rel=1e-5)
    assert not solve_states(model, nxt, phi_fail * (1 + 1e-5)).ok[0]


def test_cli_skips_either_family_but_not_both():
    r = CliRunner().invoke(cli, ["curves", "--phi-hat", "none", "--p-hat", "1.5", "--json"])
    assert r.exit_code == 0, r.output
    families = {c["family"] for c in json.loads(r.stdout)["curves"]}
    assert families == {"voltage_charge"}
    one_line_error(CliRunner().invoke(cli, ["curves", "--phi-hat", "none", "--p-hat", "none"]), "--phi-hat", "none")
