"""Exact derivatives of relaxed (wrinkled) patterned states (:mod:`coexist.patterned_relaxed`, issue 13).

``solve_patterned_relaxed(..., derivatives=True)`` carries the variational equations to ``(s, λ0, Φ̂)`` through
every region's taut and hoop-wrinkled segments and across every relaxed interface (the Jacobian of
``n⁻T̂1ʳ⁻ = n⁺T̂1ʳ⁺`` on the sides' modes), and eliminates the interface scale ``s`` by the implicit function
theorem. Checked here against Richardson central differences of the converged relaxed solver at rtol 1e-12,
by the Maxwell relation and by ``dΨ̂ = p̂ dV̂ − Q̂ dΦ̂`` integrated along wrinkled states, against the uniform
relaxed derivatives of :func:`coexist.shooting.solve_states` (a one-region pattern, a uniform zone cut into
regions), and in the N-zone layer: a patterned ramp that stopped where its zones wrinkle now follows them.

The cases cover every kind of interface: an electrode disc wrinkled up to its edge, taut beyond (inner circle,
Φ̂ = 0.3), a passive annulus of two layers (a jump in ``n``), an electrode ring wrinkled from edge to edge
(taut → wrinkled and wrinkled → taut across the interfaces) and with two bands that end inside it (switches with
the saltation), and a band that goes on across an interface (the split uniform zone).
"""

from __future__ import annotations

import json

import numpy as np
import pytest
from click.testing import CliRunner

from coexist.cli.main import cli
from coexist.model import MembraneModel
from coexist.patterned import PatternedModel, ZonePattern
from coexist.patterned_relaxed import NO_RELAXED_DERIVATIVES, solve_patterned_relaxed
from coexist.settings import SolverSettings
from coexist.shooting import OK, solve_states

TIGHT = SolverSettings(rtol=1e-12)
FIELDS = ("dp_dl0", "dv_dl0", "dq_dl0", "dp_dphi", "dv_dphi", "dq_dphi")
#: (pattern, pole stretches, Φ̂, the wrinkled intervals' count per state): relaxed states only
CASES = {
    "inner circle": (ZonePattern.inner_circle(0.5), [1.0185, 1.019], 0.3, [1, 1]),
    "ring": (ZonePattern.ring(0.3, 0.7), [1.012, 1.02, 1.03], 0.5, [1, 1, 2]),
    "two-layer passive": (ZonePattern.inner_circle(0.6, passive_layers=2), [1.02], 0.3, [1]),
}


@pytest.fixture(scope="module")
def membrane():
    return MembraneModel(wrinkling="tension-field")


def _stack(st):
    return np.vstack([st.p_hat, st.v_hat, st.q_hat])


# Measured (rtol 1e-12): the exact derivatives against the Richardson differences converge like h⁴ to
# 1.4e-8 (inner circle, λ0, h = 5e-5; 2.2e-7 at h = 1e-4, 3.5e-6 at 2e-4: the differences' own truncation, the
# states' curvature scale being ~3e-3 in λ0 there), 2.7e-9 (ring), 1.4e-9 (two-layer passive); to Φ̂ at
# h = 1e-4: ≤ 6e-9. Every state of every difference is a relaxed state of the same topology.
@pytest.mark.parametrize("name", list(CASES))
def test_relaxed_derivatives_match_richardson_differences(membrane, name):
    pattern, l0, phi, bands = CASES[name]
    l0 = np.array(l0)
    n = l0.size
    st = solve_patterned_relaxed(membrane, pattern, l0, phi, TIGHT, derivatives=True)
    assert np.all(st.status == OK), st.failure_detail
    assert [len(r) for r in st.wrinkled_radii] == bands
    d = st.derivatives
    hl, hp = 5e-5, 1e-4
    # all the differences' states in one call: λ0 ± h, ± h/2 at Φ̂, then Φ̂ ± h, ± h/2 at λ0
    offsets = np.array([hl, -hl, hl / 2, -hl / 2])
    poff = np.array([hp, -hp, hp / 2, -hp / 2])
    x = np.concatenate([np.repeat(offsets, n) + np.tile(l0, 4), np.tile(l0, 4)])
    y = np.concatenate([np.full(4 * n, phi), np.repeat(poff, n) + phi])
    fd = solve_patterned_relaxed(membrane, pattern, x, y, TIGHT)
    assert np.all(fd.status == OK), fd.failure_detail
    assert [len(r) for r in fd.wrinkled_radii] == bands * 8  # the same topology at every offset
    v = _stack(fd).reshape(3, 8, n)
    for k, h, exact in (
        (0, hl, np.vstack([d.dp_dl0, d.dv_dl0, d.dq_dl0])),
        (4, hp, np.vstack([d.dp_dphi, d.dv_dphi, d.dq_dphi])),
    ):
        d1 = (v[:, k] - v[:, k + 1]) / (2 * h)
        d2 = (v[:, k + 2] - v[:, k + 3]) / h
        rich = (4 * d2 - d1) / 3
        rel = np.abs(exact - rich) / np.abs(rich)
        assert rel.max() < 1e-7, (k, rel)


@pytest.mark.parametrize("name", ["inner circle", "ring"])
def test_maxwell_relation_on_relaxed_states(membrane, name):
    """``∂p̂/∂Φ̂|V̂ = −∂Q̂/∂V̂|Φ̂`` (``dΨ̂ = p̂ dV̂ − Q̂ dΦ̂``, the form of ``tests/test_patterned_derivatives.py``): in
    ``(λ0, Φ̂)``, ``p̂_Φ V̂_λ − p̂_λ V̂_Φ = −Q̂_λ``, on wrinkled states (measured ≤ 6e-10)."""
    pattern, l0, phi, bands = CASES[name]
    st = solve_patterned_relaxed(membrane, pattern, l0, phi, TIGHT, derivatives=True)
    assert np.all(st.status == OK) and [len(r) for r in st.wrinkled_radii] == bands
    d = st.derivatives
    lhs = d.dp_dphi * d.dv_dl0 - d.dp_dl0 * d.dv_dphi
    rel = np.abs(lhs + d.dq_dl0) / np.abs(d.dq_dl0)
    assert rel.max() < 1e-8, rel


def test_free_energy_difference_integrates_the_derivatives(membrane):
    """``Ψ̂(b) − Ψ̂(a) = ∫ p̂ ∂V̂/∂λ0 dλ0`` at fixed Φ̂ and ``= ∫ (p̂ ∂V̂/∂Φ̂ − Q̂) dΦ̂`` at fixed λ0, between wrinkled
    states of the electrode ring wrinkled from edge to edge (Gauss–Legendre, 8 nodes, with the exact derivatives;
    Ψ̂ from the relaxed solver's own energy integral): the equal-area identity of the Maxwell construction on
    relaxed states, 1e-8 (measured 8e-11 in λ0, 1.2e-12 in Φ̂)."""
    pattern = ZonePattern.ring(0.3, 0.7)
    t, w = np.polynomial.legendre.leggauss(8)
    a, b, phi = 1.012, 1.02, 0.5
    nodes = 0.5 * (a + b) + 0.5 * (b - a) * t
    st = solve_patterned_relaxed(membrane, pattern, np.concatenate([nodes, [a, b]]), phi, TIGHT, derivatives=True)
    assert np.all(st.status == OK) and all(len(r) == 1 for r in st.wrinkled_radii)
    integral = 0.5 * (b - a) * np.sum(w * st.p_hat[:8] * st.derivatives.dv_dl0[:8])
    delta = st.psi_hat[9] - st.psi_hat[8]
    assert abs(integral - delta) <= 1e-8 * abs(delta), (integral, delta)
    pa, pb, l0 = 0.47, 0.5, 1.015
    pn = 0.5 * (pa + pb) + 0.5 * (pb - pa) * t
    sp = solve_patterned_relaxed(
        membrane, pattern, np.full(10, l0), np.concatenate([pn, [pa, pb]]), TIGHT, derivatives=True
    )
    assert np.all(sp.status == OK) and all(len(r) == 1 for r in sp.wrinkled_radii)
    d = sp.derivatives
    integral = 0.5 * (pb - pa) * np.sum(w * (sp.p_hat[:8] * d.dv_dphi[:8] - sp.q_hat[:8]))
    delta = sp.psi_hat[9] - sp.psi_hat[8]
    assert abs(integral - delta) <= 1e-8 * abs(delta), (integral, delta)


def test_one_region_and_split_uniform_zone_give_the_uniform_relaxed_derivatives(membrane):
    """A one-region pattern of two layers is the uniform relaxed zone at ``Φ̂/2`` scaled by the chain rule; a
    uniform zone cut at 0.5 and 0.8 (a band from ~0.70 to the clamp crosses the interface at 0.8, wrinkled on
    both sides; nothing jumps, the interfaces still move with ``s``) has the derivatives of
    :func:`solve_states`' relaxed shooting: 1e-9 (measured ≤ 5e-10)."""
    l0 = np.array([1.02, 1.025, 1.03])
    ref = solve_states(membrane, l0, 0.3, TIGHT, derivatives=True)
    assert all(len(r) == 1 and r[0][1] == 1.0 for r in ref.wrinkled_radii)
    split = ZonePattern(((0.5, 1, True), (0.8, 1, True), (1.0, 1, True)))
    st = solve_patterned_relaxed(membrane, split, l0, 0.3, TIGHT, derivatives=True)
    assert np.all(st.status == OK) and st.wrinkled_radii[0][0][0] < 0.8
    for k in FIELDS:
        x, y = getattr(st.derivatives, k), getattr(ref.derivatives, k)
        assert np.max(np.abs(x - y) / np.abs(y)) < 1e-9, k
    one = solve_patterned_relaxed(membrane, ZonePattern.full(2), l0, 0.6, TIGHT, derivatives=True)
    assert np.all(one.status == OK) and all(len(r) == 1 for r in one.wrinkled_radii)
    expected = {
        "dp_dl0": 2 * ref.derivatives.dp_dl0,
        "dv_dl0": ref.derivatives.dv_dl0,
        "dq_dl0": ref.derivatives.dq_dl0,
        "dp_dphi": ref.derivatives.dp_dphi,
        "dv_dphi": ref.derivatives.dv_dphi / 2,
        "dq_dphi": ref.derivatives.dq_dphi / 2,
    }
    for k in FIELDS:
        np.testing.assert_allclose(getattr(one.derivatives, k), expected[k], rtol=1e-9, atol=0, err_msg=k)


def test_solve_states_of_a_tension_field_patterned_zone_returns_relaxed_derivatives(membrane):
    """Through the dispatch (:func:`coexist.patterned_relaxed.shoot_zone_relaxed`): the wrinkled state is OK with
    the derivatives of :func:`solve_patterned_relaxed`, the taut one beside it keeps the taut solver's."""
    pattern = ZonePattern.inner_circle(0.5)
    zone = PatternedModel.of(membrane, pattern)
    st = solve_states(zone, [1.0185, 1.05], 0.3, TIGHT, derivatives=True)
    assert np.all(st.status == OK), st.failure_detail
    assert st.wrinkled_radii[0] and not st.wrinkled_radii[1]
    assert all(NO_RELAXED_DERIVATIVES not in (x or "") for x in st.failure_detail)
    direct = solve_patterned_relaxed(membrane, pattern, [1.0185], 0.3, TIGHT, derivatives=True)
    for k in FIELDS:
        assert getattr(st.derivatives, k)[0] == getattr(direct.derivatives, k)[0], k
        assert np.isfinite(getattr(st.derivatives, k)[1]), k


#: the tricircle with an electrode disc over the inner half of each zone, closed at 0.2 mbar: its zones wrinkle on
#: the electrode side of the edge above 4.809 kV (where the ramp stopped while relaxed patterned states had no
#: derivatives: "homogeneous leaves the model's range: wrinkling")
LOW_TRICIRCLE = """
name = "tricircle-low"
[membrane]
material = "gent"
jlim = 97
shear_modulus_kPa = 45
relative_permittivity = 4.7
thickness_mm = 0.5
zone_radius_mm = 21.4165
prestretch = 1.0
wrinkling = "tension-field"
[electrodes]
pattern = "inner-circle"
inner_fraction = 0.5
[zones]
count = 3
[chamber]
volume_ml = 300
closing_pressure_mbar = 0.2
atmospheric_pressure_kPa = 101.325
[voltage]
values_kV = [0, 4.5, 5, 6, 5, 0]
"""


def test_cli_ramp_follows_wrinkled_patterned_zones(tmp_path):
    """``coexist ramp`` of the low tricircle goes on past 4.809 kV through wrinkled patterned states (stable,
    wrinkled on the electrode side of the edge) and back, with no end of range; every step's zones, re-shot
    directly (rtol 1e-12), share the chamber's pressure (1e-9; measured ≤ 6e-11 with ``--accuracy high``; at the
    default rtol 1e-10 the equilibria's own residual is 4e-10 in p̂ ≈ 0.007, 6e-8 relative)."""
    from coexist.scene import load_scene
    from coexist.simulation import Simulation

    scene = tmp_path / "low.toml"
    scene.write_text(LOW_TRICIRCLE)
    r = CliRunner().invoke(cli, ["ramp", str(scene), "--json", "--accuracy", "high"])
    assert r.exit_code == 0, r.output
    data = json.loads(r.stdout)
    assert not any(t["kind"] == "no_stable_state" for t in data["transitions"]), data["transitions"]
    assert not any("wrinkl" in n or NO_RELAXED_DERIVATIVES in n for n in data["notes"]), data["notes"]
    steps = data["steps"]
    assert [s["voltage_kV"] for s in steps] == [0, 4.5, 5, 6, 5, 0]
    assert all(s["stable"] and s["configuration"] == "homogeneous" for s in steps)
    wrinkled = [s for s in steps if min(s["wrinkled_area_fraction"]) > 0]
    assert [s["voltage_kV"] for s in wrinkled] == [5, 6, 5]
    assert wrinkled[1]["wrinkled_area_fraction"][0] == pytest.approx(0.1499181708, rel=1e-8)  # measured
    sc = load_scene(str(scene))
    model = Simulation.from_scene(sc).model
    for s in steps:
        st = solve_states(model, s["pole_stretches"], sc.phi_hat(1e3 * s["voltage_kV"]), TIGHT)
        assert np.all(st.status == OK), st.failure_detail
        p = sc.p_hat(100 * s["pressure_mbar"])
        assert np.max(np.abs(st.p_hat - p)) <= 1e-9 * p, (st.p_hat, p)
        assert bool(st.wrinkled_radii[0]) == (min(s["wrinkled_area_fraction"]) > 0)
