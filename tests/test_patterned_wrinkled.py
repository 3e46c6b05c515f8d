"""Patterned zones that wrinkle, relaxed by tension-field theory (:mod:`coexist.patterned_relaxed`, issues 12–13).

The low-inflation inner-circle state under voltage that the taut patterned shooting refuses (the hoop tension on
the electrode side of the edge is negative) is relaxed: a hoop-wrinkled band on the electrode side of the edge,
the meridional force continuous across the edge and equal to the cap's vertical balance there. Where no tension
is negative the relaxed solver gives the taut patterned numbers; a uniform zone split into regions gives the
uniform relaxed states of ``solve_states``; ``∫p̂ dV̂ = ΔΨ̂`` along wrinkled states; the IPOPT minimisation of the
discretised relaxed energy, with per-element layers and voltage, converges to the shooting like ``h²``.
"""

from __future__ import annotations

import json

import numpy as np
import pytest
from click.testing import CliRunner
from numpy.polynomial import chebyshev as C

from coexist.cli.main import cli
from coexist.errors import SceneError
from coexist.model import MembraneModel
from coexist.patterned import PatternedModel, ZonePattern, solve_patterned_states
from coexist.patterned_relaxed import describe_wrinkles, solve_patterned_relaxed
from coexist.settings import SolverSettings
from coexist.shooting import OK, WRINKLED, solve_states
from coexist.studies.wrinkled_reference import relaxed_state

TIGHT = SolverSettings(rtol=1e-12)
PHI = 0.3
INNER = ZonePattern.inner_circle(0.5)


@pytest.fixture(scope="module")
def membrane():
    return MembraneModel(wrinkling="tension-field")


def cap_force(st, i, edge, side):
    """``p̂ r̂²/(2 R̂ sin θ)``: the meridional force per reference hoop length that the cap inside ``R̂`` needs for
    its vertical balance (docs/physics.md section 10), from the integrated geometry of the interface's side."""
    R, r, _, theta, _ = st.interfaces[i, edge, side]
    return st.p_hat[i] * r * r / (2 * R * np.sin(theta))


# Measured (rtol 1e-12, neo-Hookean, Φ̂ = 0.3, electrode disc f = 0.5): λ0 = 1.0192 p̂ = 0.00782921295,
# wrinkled 0.491700 ≤ R̂ ≤ 0.5; λ0 = 1.018 p̂ = 0.00426680650, wrinkled 0.392813 ≤ R̂ ≤ 0.5 (the taut shooting
# refuses both: −7.5e-4 μH and −9.4e-3 μH on the electrode side of the edge); n T̂1 continuous to 1e-15 and equal
# to the cap balance to ~1e-12.
def test_low_inflation_state_is_relaxed_on_the_electrode_side_of_the_edge(membrane):
    l0 = [1.018, 1.0192]
    taut = solve_patterned_states(MembraneModel(), INNER, l0, PHI, TIGHT)
    assert np.all(taut.status == WRINKLED)
    assert "region 1 (electrode" in taut.failure_detail[1] and "edge at R/A = 0.5" in taut.failure_detail[1]
    st = solve_patterned_relaxed(membrane, INNER, l0, PHI, TIGHT)
    assert np.all(st.status == OK), st.failure_detail
    assert st.p_hat == pytest.approx([0.0042668065, 0.0078292130], rel=1e-8)
    for i, start in enumerate((0.392813, 0.491700)):
        ((a, b),) = st.wrinkled_radii[i]
        assert a == pytest.approx(start, abs=2e-6) and b == pytest.approx(0.5, abs=1e-9)  # ends at the edge
        words = describe_wrinkles(INNER, st.wrinkled_radii[i])
        assert "in region 1 (electrode, 1 layer), on its side of the edge at R/A = 0.5" in words
        assert st.min_tension[i] == 0.0  # the hoop tension vanishes in the band, is positive elsewhere
        assert 0 < st.wrinkled_stiffness[i] < 1
        # the interface: r̂, θ continuous, the meridional force n T̂1 continuous and the cap's vertical balance
        near, far = st.interfaces[i, 0]
        assert near[:4] == pytest.approx(far[:4], abs=1e-15)
        assert abs(near[4] - far[4]) <= 1e-10 * near[4]
        for side in (0, 1):
            assert abs(st.interfaces[i, 0, side, 4] - cap_force(st, i, 0, side)) <= 1e-10 * near[4]
    # the band widens as the inflation falls
    assert st.wrinkled_fraction[0] > st.wrinkled_fraction[1] > 0


@pytest.mark.parametrize(
    ("pattern", "l0", "phi"),
    [
        (INNER, [1.0218, 1.05, 1.3, 2.0], PHI),
        (ZonePattern.ring(0.3, 0.7, passive_layers=2), [1.1, 1.5, 1.9], 0.2),
    ],
)
def test_taut_states_are_the_taut_patterned_numbers(membrane, pattern, l0, phi):
    """No tension negative: the relaxed solver's states are the taut patterned shooting's to 1e-9 (measured
    ≤ 1.3e-11 at rtol 1e-12; both integrate the same equations on their own steps)."""
    taut = solve_patterned_states(MembraneModel(), pattern, l0, phi, TIGHT)
    st = solve_patterned_relaxed(membrane, pattern, l0, phi, TIGHT)
    assert np.all(taut.ok) and np.all(st.ok)
    assert all(r == [] for r in st.wrinkled_radii) and np.all(st.wrinkled_stiffness == np.inf)
    for name in ("p_hat", "v_hat", "q_hat", "psi_hat", "apex_height"):
        a, b = getattr(st, name), getattr(taut, name)
        assert np.all(np.abs(a - b) <= 1e-9 * np.maximum(np.abs(b), 1e-3)), (name, a - b)
    assert np.all(st.min_tension > 0)


def test_a_uniform_zone_split_into_regions_is_the_uniform_relaxed_zone(membrane):
    """A uniform zone cut into three regions (edges at 0.5 and 0.9, two layers each at 2Φ̂) has the relaxed
    states of ``solve_states`` (p̂/2, V̂, Q̂, Ψ̂/2 and the band) to 1e-9, the band crossing the edge at 0.9 (a
    wrinkled–wrinkled jump) at λ0 = 1.03 (measured ≤ 2e-13); a one-region pattern is ``solve_states``."""
    l0 = [1.02, 1.03, 1.04]
    uni = solve_states(membrane, l0, PHI, TIGHT)
    assert all(len(r) == 1 for r in uni.wrinkled_radii)
    split = ZonePattern(regions=((0.5, 2, True), (0.9, 2, True), (1.0, 2, True)))
    one = ZonePattern.full(layers=2)
    for pattern in (split, one):
        st = solve_patterned_relaxed(membrane, pattern, l0, 2 * PHI, TIGHT)
        assert np.all(st.ok)
        for name, factor in (("p_hat", 2), ("v_hat", 1), ("q_hat", 1), ("psi_hat", 2), ("apex_height", 1)):
            a, b = getattr(st, name) / factor, getattr(uni, name)
            assert np.all(np.abs(a - b) <= 1e-9 * np.abs(b)), (name, a / b - 1)
        for got, want in zip(st.wrinkled_radii, uni.wrinkled_radii):
            assert len(got) == 1 and np.allclose(got[0], want[0], atol=1e-9)
        assert st.wrinkled_stiffness == pytest.approx(uni.wrinkled_stiffness, rel=1e-8)
    ((start, end),) = uni.wrinkled_radii[1]
    assert start < 0.9 < end  # the band crosses an interface of the split zone


def test_work_equals_the_change_of_potential_through_wrinkled_states(membrane):
    """``dΨ̂ = p̂ dV̂`` at fixed Φ̂: along the inner circle's wrinkled states λ0 ∈ [1.0172, 1.0192] (the band from
    R̂ = 0.33 to 0.49 on the electrode side of the edge) ``∫p̂ dV̂`` (Chebyshev interpolants of p̂ and V̂ on 17
    Lobatto nodes, integrated exactly) equals ``Ψ̂(b) − Ψ̂(a)`` to 1e-8 (measured 9e-11 relative)."""
    a, b, N = 1.0172, 1.0192, 16
    x = np.cos(np.pi * np.arange(N + 1) / N)
    l0 = 0.5 * (a + b) + 0.5 * (b - a) * x
    st = solve_patterned_relaxed(membrane, INNER, l0, PHI, TIGHT)
    assert np.all(st.ok) and all(len(r) == 1 for r in st.wrinkled_radii)
    integrand = C.chebint(C.chebmul(C.chebfit(x, st.p_hat, N), C.chebder(C.chebfit(x, st.v_hat, N))))
    work = C.chebval(1.0, integrand) - C.chebval(-1.0, integrand)
    change = st.psi_hat[0] - st.psi_hat[-1]
    assert abs(work - change) <= 1e-8 * abs(change), (work, change)


# Measured (λ0 = 1.018, n = 100, 200, 400, 800, each mesh started from the last): at the shooting's p̂, V̂ − V̂shoot
# = 2.54e-6, 7.89e-7, 1.32e-7, 2.66e-8 (n²|e| = 0.025, 0.032, 0.021, 0.017); at its V̂, p̂ − p̂shoot = −3.34e-7,
# −1.04e-7, −1.74e-8, −3.51e-9 (n²|e| = 3.3e-3 … 2.2e-3); the band's start − shooting's = 3.8e-4, −4.2e-5, 1.3e-5,
# 3.5e-6 (the formal hoop tension's zero, linearly extrapolated), its end the edge on every mesh; Ψ̂ errors 5.3e-9,
# 1.35e-9, 3.5e-10, 1.0e-10.
def test_ipopt_reference_converges_to_the_relaxed_shooting(membrane):
    """The relaxed energy of the discretised patterned membrane (one layer, electrode disc of half the radius,
    IPOPT): p̂ and V̂ converge to the shooting's like h² (``n²|error|`` within a factor 2.5 over n = 100 … 800: it
    neither grows, as O(h) would, nor vanishes), the band's start within 5h², its end at the edge."""
    st = solve_patterned_relaxed(membrane, INNER, [1.018], PHI, TIGHT)
    p, v = st.p_hat[0], st.v_hat[0]
    ((start, end),) = st.wrinkled_radii[0]
    scaled_v, scaled_p = [], []
    previous = None
    for n in (100, 200, 400, 800):
        at_p = relaxed_state(membrane, p, PHI, n=n, pattern=INNER, height=0.1, initial=previous)
        at_v = relaxed_state(membrane, phi_hat=PHI, volume=v, n=n, pattern=INNER, initial=at_p)
        previous = at_p
        assert at_p["status"] == "ok" and at_v["status"] == "ok"
        assert at_p["meridional_wrinkled_radii"] == [] and at_p["slack_radii"] == []
        ((lo, hi),) = at_p["hoop_wrinkled_radii"]
        assert abs(lo - start) <= 5.0 / n**2 and hi == 0.5 == pytest.approx(end, abs=1e-9)
        scaled_v.append(n * n * abs(at_p["v_hat"] - v))
        scaled_p.append(n * n * abs(at_v["p_hat"] - p))
    for scaled in (scaled_v, scaled_p):
        assert max(scaled) < 2.5 * min(scaled), scaled
    assert scaled_v[-1] < 0.04 and scaled_p[-1] < 0.005


def test_patterned_model_with_tension_field_relaxes_through_solve_states(membrane):
    """``PatternedModel.of`` takes a tension-field membrane; ``solve_states`` relaxes its WRINKLED states (the
    numbers of ``solve_patterned_relaxed``) and, with derivatives, returns them OK with their exact derivatives
    (those of ``solve_patterned_relaxed``, tests/test_patterned_relaxed_derivatives.py); ``solve_patterned_relaxed``
    refuses a membrane that refuses wrinkling, by name."""
    zone = PatternedModel.of(membrane, INNER)
    st = solve_states(zone, [1.018, 1.05], PHI, TIGHT)
    direct = solve_patterned_relaxed(membrane, INNER, [1.018], PHI, TIGHT)
    assert np.all(st.ok) and st.p_hat[0] == direct.p_hat[0] and st.wrinkled_radii[0] == direct.wrinkled_radii[0]
    assert st.wrinkled_radii[1] == [] and st.wrinkled_stiffness[1] == np.inf
    with_d = solve_states(zone, [1.018, 1.05], PHI, TIGHT, derivatives=True)
    assert np.all(with_d.status == OK) and with_d.failure_detail[0] is None
    assert with_d.p_hat[0] == direct.p_hat[0] and with_d.wrinkled_radii[0] == direct.wrinkled_radii[0]
    assert np.isfinite(with_d.derivatives.dp_dl0).all() and with_d.derivatives.dp_dl0[0] > 0
    d = solve_patterned_relaxed(membrane, INNER, [1.018], PHI, TIGHT, derivatives=True).derivatives
    assert d is not None and d.dv_dl0[0] == with_d.derivatives.dv_dl0[0]
    with pytest.raises(SceneError, match="tension-field") as bad:
        solve_patterned_relaxed(MembraneModel(), INNER, [1.018], PHI)
    assert bad.value.field == "wrinkling"


def test_cli_curves_of_a_tension_field_patterned_scene_go_through_wrinkled_states(tmp_path):
    """``coexist curves --scene`` of the inner-circle scene with ``wrinkling = "tension-field"``: the p̂–V̂ curve
    starts at the first pole stretch asked for (wrinkled states, min tension 0) instead of at the onset of
    wrinkling, and p̂ rises along it."""
    from coexist.scenes import __file__ as scenes_init

    text = (__import__("pathlib").Path(scenes_init).parent / "inner-circle.toml").read_text()
    assert 'wrinkling = "refuse"' in text
    scene = tmp_path / "wrinkling-circle.toml"
    scene.write_text(text.replace('wrinkling = "refuse"', 'wrinkling = "tension-field"'))
    runner = CliRunner()
    args = [
        "curves",
        "--scene",
        str(scene),
        "--phi-hat",
        "0.3",
        "--pole-stretch",
        "1.017,1.1",
        "--points",
        "12",
        "--p-hat",
        "none",
    ]
    relaxed = runner.invoke(cli, [*args, "--json"])
    assert relaxed.exit_code == 0, relaxed.output
    curve = json.loads(relaxed.stdout)["curves"][0]
    assert curve["pole_stretch"][0] == 1.017 and "starts_because" not in curve
    assert curve["min_tension_hat"][0] == 0.0 and curve["min_tension_hat"][-1] > 0
    assert np.all(np.diff(curve["p_hat"]) > 0)
    # each state's wrinkled band travels with it through the curve (inside the electrode disc, R̂ < 0.5)
    bands = curve["wrinkled_radii"]
    assert len(bands) == len(curve["p_hat"]) and bands[0] and not bands[-1]
    assert all(0 < a < b <= 0.5 + 1e-9 for ws in bands for a, b in ws)
    taut = runner.invoke(cli, [*args[:2], "inner-circle", *args[3:], "--json"])
    assert taut.exit_code == 0
    assert json.loads(taut.stdout)["curves"][0]["starts_because"].startswith("wrinkling")
