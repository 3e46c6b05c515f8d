"""The phase diagram's critical point: reported only where the pressure maximum and minimum truly merge.

A neo-Hookean zone under voltage has a pressure maximum (λ0 ≈ 2.1) and, far beyond it, a minimum whose
pole stretch falls as Φ̂ rises; the two never merge. Its phase diagram must not call the voltage where
the minimum crosses the end of the pole-stretch range searched a critical point. For Gent Jlim = 40 they
do merge: the reported point is checked on the exact shooting equations (exact ``∂p̂/∂λ0`` from the
variational equations, the second derivative by central differences of it).
"""

from __future__ import annotations

import json

import numpy as np
import pytest
from click.testing import CliRunner

from coexist.cli.main import cli
from coexist.coexistence import phase_diagram
from coexist.model import build_model
from coexist.shooting import solve_states
from coexist.simulation import stretch_range_end


def exact_slope(model, pole_stretch, phi):
    """Exact ``∂p̂/∂λ0`` at the given pole stretches (all states must be valid)."""
    s = solve_states(model, np.asarray(pole_stretch, dtype=float), phi, derivatives=True)
    assert s.ok.all()
    return s.derivatives.dp_dl0, s


def extrema(model, phi, lo, hi, n=600):
    """Pole stretches where the exact ``∂p̂/∂λ0`` changes sign on a grid of ``[lo, hi]``: (λ0, kind)."""
    l0 = np.linspace(lo, hi, n)
    d, _ = exact_slope(model, l0, phi)
    i = np.flatnonzero(np.sign(d[:-1]) != np.sign(d[1:]))
    return [(0.5 * (l0[k] + l0[k + 1]), "max" if d[k] > 0 else "min") for k in i]


@pytest.fixture(scope="module")
def neo():
    return build_model("neo-hookean", voltage=True)


@pytest.fixture(scope="module")
def gent40():
    return build_model("gent", 40.0)


NO_LOOP = "has a pressure maximum followed by a minimum with a stable branch beyond it: no lower spinodal"


@pytest.mark.parametrize("lmax", [6.0, 12.0])
def test_neo_hookean_reports_no_false_critical_point(neo, lmax):
    """No critical point, and no loop at all: every pressure minimum of a neo-Hookean zone under voltage lies past a
    volume fold, on the inward spiral of its ``p̂–V̂`` curve (``∂V̂/∂λ0 < 0`` there, checked on exact states), where no
    state is stable under pressure control. The diagram had taken the first such minimum that entered the searched
    range for the lower spinodal, from a voltage that moved with the range (0.1089 for λ0 ≤ 6, 0.0424 for λ0 ≤ 12),
    and called that voltage "the minimum enters the range" (review, helper-82)."""
    d = phase_diagram(neo, np.linspace(0.0, 0.2, 11), lmax)
    assert d.critical_point is None
    assert d.to_dict()["critical_point"] is None
    assert not any(n.startswith("critical point") for n in d.notes)
    assert any(NO_LOOP in n for n in d.notes), d.notes
    assert np.all(np.isnan(d.spinodal_min)) and np.all(np.isnan(d.binodal))
    # the snap-through is the upper spinodal all the same: the pressure maximum of the p̂–V̂ curve, within both errors
    from coexist.curves import pressure_volume_curve

    for phi, p_max, err in zip(d.phi_hat[::5], d.spinodal_max[::5], d.spinodal_max_error[::5]):
        (lp,) = [
            x
            for x in pressure_volume_curve(neo, phi, np.linspace(1.05, 3.5, 120)).limit_points
            if x.kind == "pressure_max"
        ]
        assert abs(p_max - lp.p_hat) <= err + lp.errors["p_hat"], (phi, p_max, lp.p_hat)
    for phi in (0.11, 0.2):
        l0 = np.linspace(1.5, lmax, 800)
        slope, s = exact_slope(neo, l0[l0 < {0.11: 7.5, 0.2: 4.99}[phi]], phi)
        dv = s.derivatives.dv_dl0
        k = np.flatnonzero((slope[:-1] < 0) & (slope[1:] >= 0))  # the minima of p̂(λ0)
        assert k.size and np.all(dv[k] < 0)


def test_neo_hookean_spinodals_far_apart_at_the_former_critical_point(neo):
    """At Φ̂ = 0.109 (the voltage formerly reported as critical) the exact curve's maximum is at λ0 ≈ 2.116
    (p̂ ≈ 1.8016) and its minimum at λ0 ≈ 5.996 (p̂ ≈ 1.4656): nothing merges there."""
    ext = extrema(neo, 0.109, 1.5, 6.5, n=1000)
    (lam_max, k1), (lam_min, k2) = ext[:2]
    assert (k1, k2) == ("max", "min")
    assert lam_max == pytest.approx(2.116, abs=0.01) and lam_min == pytest.approx(5.996, abs=0.01)
    _, s = exact_slope(neo, [lam_max, lam_min], 0.109)
    assert s.p_hat[0] == pytest.approx(1.8016, abs=2e-4) and s.p_hat[1] == pytest.approx(1.4656, abs=2e-4)


@pytest.fixture(scope="module")
def gent40_critical(gent40):
    d = phase_diagram(gent40, np.linspace(0.2, 0.26, 4), stretch_range_end(gent40.elasticity, 1.0))
    assert d.critical_point is not None, d.notes
    return d


def test_gent40_critical_point_merges_on_the_exact_equations(gent40, gent40_critical):
    """At the reported (Φ̂c, λc): exact ∂p̂/∂λ0 = 0 to 1e-8 (measured 4e-12), ∂²p̂/∂λ0² = 0 to 1e-6 by
    central differences of the exact derivative with h = 1e-3 (measured 4e-9) while ∂³p̂/∂λ0³ ≈ 0.675 ≠ 0
    (a true cusp); p̂c is the exact state's pressure there (to 1e-12). Values: Φ̂c = 0.232074086,
    p̂c = 1.73944454, λc = 2.5728475 (the curve-level bisection formerly gave 0.23207387, 1.7394454, 2.57279)."""
    phic, pc, lc = gent40_critical.critical_point
    assert phic == pytest.approx(0.232074086, abs=2e-9)
    assert pc == pytest.approx(1.73944454, abs=2e-8)
    assert lc == pytest.approx(2.5728475, abs=2e-6)
    h = 1e-3
    d, s = exact_slope(gent40, [lc - h, lc, lc + h], phic)
    assert abs(d[1]) < 1e-8
    second = (d[2] - d[0]) / (2 * h)
    third = (d[2] - 2 * d[1] + d[0]) / h**2
    assert abs(second) < 1e-6
    assert third == pytest.approx(0.675, rel=0.01)
    assert s.p_hat[1] == pytest.approx(pc, abs=1e-12)
    (note,) = [n for n in gent40_critical.notes if n.startswith("critical point at Φ̂ = 0.23207409")]
    # the loop opens there as the voltage rises: the note said "coexistence ends there"
    assert note.endswith("coexist above this voltage, not below (the loop opens there)")


def test_gent40_loop_opens_at_the_critical_point(gent40, gent40_critical):
    """1e-5 below Φ̂c the exact p̂(λ0) rises throughout [2.4, 2.75]; 1e-5 above it a maximum and a minimum
    appear, both within 0.01 of λc."""
    phic, _, lc = gent40_critical.critical_point
    assert extrema(gent40, phic - 1e-5, 2.4, 2.75, n=351) == []
    above = extrema(gent40, phic + 1e-5, 2.4, 2.75, n=351)
    assert [k for _, k in above] == ["max", "min"]
    assert all(abs(x - lc) < 0.01 for x, _ in above)


def test_gent40_critical_point_does_not_depend_on_the_voltage_grid(gent40, gent40_critical):
    """Another grid of voltages (another bracket) gives the same converged point to 1e-8 in Φ̂."""
    d = phase_diagram(gent40, np.linspace(0.22, 0.25, 3), stretch_range_end(gent40.elasticity, 1.0))
    np.testing.assert_allclose(d.critical_point, gent40_critical.critical_point, atol=1e-8)


@pytest.mark.parametrize(
    "args",
    [
        ["--material", "neo-hookean", "--jlim", "40"],
        ["--scene", "tricircle", "--material", "neo-hookean", "--jlim", "40"],
    ],
)
def test_phase_diagram_refuses_jlim_for_a_material_without_it(args):
    """As `coexist curves`: exit 2 and one line naming --jlim (a neo-Hookean material, given or over a scene's)."""
    r = CliRunner().invoke(cli, ["phase-diagram", *args, "--json"])
    assert r.exit_code == 2, r.output
    errors = [ln for ln in r.output.splitlines() if ln.startswith("Error:")]
    assert errors == ["Error: --jlim: only the gent material takes jlim"]
    assert "Traceback" not in r.output


def test_phase_diagram_cli_neo_hookean_json():
    """The default neo-Hookean diagram: critical_point null, the note says why."""
    r = CliRunner().invoke(
        cli, ["phase-diagram", "--material", "neo-hookean", "--phi-hat", "0.1,0.12", "--points", "3", "--json"]
    )
    assert r.exit_code == 0, r.output
    data = json.loads(r.stdout)
    assert data["critical_point"] is None
    assert any(NO_LOOP in n for n in data["notes"])
