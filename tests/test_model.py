"""The symbolic model: generated numpy code equals CasADi, tensions are the energy's derivatives,
and effects that are off contribute no terms."""

import casadi as ca
import numpy as np
import pytest

from coexist.effects import Gent, NeoHookean, NoElectrostatics
from coexist.errors import SceneError
from coexist.model import MembraneModel


@pytest.mark.parametrize("elasticity", [NeoHookean(), Gent(20.0), Gent(97.0)])
def test_generated_numpy_matches_casadi(elasticity):
    model = MembraneModel(elasticity)
    rng = np.random.default_rng(1)
    l1, l2 = rng.uniform(1.0, 2.2, 50), rng.uniform(1.0, 2.2, 50)
    R, th, p, phi = rng.uniform(0.05, 1, 50), rng.uniform(0, 2, 50), rng.uniform(0, 2, 50), rng.uniform(0, 0.3, 50)
    ours = np.array(model.rhs(R, l1, l2, th, p, phi))
    theirs = np.array(
        [np.array(model.casadi_functions["rhs"](R[i], l1[i], l2[i], th[i], p[i], phi[i])).ravel() for i in range(50)]
    ).T
    np.testing.assert_allclose(ours, theirs, rtol=1e-13, atol=1e-13)


@pytest.mark.parametrize("elasticity", [NeoHookean(), Gent(97.0)])
def test_small_batches_take_the_float_code_with_numpys_numbers(elasticity):
    """Batches of up to :data:`~coexist.numerics.codegen.SMALL_BATCH` states run the generated float code state by
    state (:func:`~coexist.numerics.codegen.small_batch`); every generated function of a tension-field model gives
    there what its numpy code gives for the same states in a large batch, including scalar arguments and the
    ``into`` forms; a state where ``math`` raises (a locked Gent state: the logarithm of a negative number; a zero
    stretch: a division by zero) falls back to numpy's NaN and infinities. Measured: equal to 2 ulp (``math`` and
    numpy's exp/log may round differently). Asserted: 1e-14 relative."""
    from coexist.numerics.codegen import SMALL_BATCH

    model = MembraneModel(elasticity, wrinkling="tension-field")
    rng = np.random.default_rng(3)
    n = 64
    l1, l2, w = rng.uniform(1.0, 2.2, n), rng.uniform(1.0, 2.2, n), rng.uniform(0.9, 1.5, n)
    R, th, p, phi = rng.uniform(0.05, 1, n), rng.uniform(0, 2, n), rng.uniform(0, 2, n), rng.uniform(0, 0.3, n)
    s = [rng.uniform(-1, 1, n) for _ in range(6)]
    calls = {
        "tensions": (l1, l2, phi),
        "pole": (l1, phi),
        "rhs": (R, l1, l2, th, p, phi),
        "series_start": (l1, p, phi, R * 1e-3),
        "free_energy": (l1, l2, phi),
        "wrinkled_rhs": (R, l1, l2, th, p, phi, w),
        "wrinkle_aux": (l1, w, phi),
    }
    for name, args in calls.items():
        big = np.array(getattr(model, name)(*args), dtype=float)
        for m in (1, 3, SMALL_BATCH):
            small = np.array(getattr(model, name)(*(a[:m] for a in args)), dtype=float)
            np.testing.assert_allclose(small, big[..., :m], rtol=1e-14, atol=1e-300, err_msg=f"{name} m={m}")
    # a scalar argument beside arrays, and the into form
    got = np.array(model.tensions(l1[:3], l2[:3], 0.2))
    np.testing.assert_allclose(got, np.array(model.tensions(l1, l2, np.full(n, 0.2)))[:, :3], rtol=1e-14)
    big_rhs = model.rhs_into(R, l1, l2, th, p, phi, np.full((9, n), 7.0))
    small_rhs = model.rhs_into(R[:5], l1[:5], l2[:5], th[:5], p[:5], phi[:5], np.full((9, 5), 7.0))
    np.testing.assert_allclose(small_rhs, big_rhs[:, :5], rtol=1e-14, atol=1e-300)  # rows 7, 8 untouched (7.0)
    big_w = np.array(model.wrinkled_rhs_sensitivities(R, l1, l2, th, p, phi, w, s[:3], s[3:]))
    small_w = np.array(
        model.wrinkled_rhs_sensitivities(
            R[:2], l1[:2], l2[:2], th[:2], p[:2], phi[:2], w[:2], [a[:2] for a in s[:3]], [a[:2] for a in s[3:]]
        )
    )
    np.testing.assert_allclose(small_w, big_w[..., :2], rtol=1e-14, atol=1e-300)
    out_big = model.rhs_sensitivities_into(R, l1, l2, th, p, phi, s[:3], s[3:], np.zeros((19, n)))
    out_small = model.rhs_sensitivities_into(
        R[:4], l1[:4], l2[:4], th[:4], p[:4], phi[:4], [a[:4] for a in s[:3]], [a[:4] for a in s[3:]], np.zeros((19, 4))
    )
    np.testing.assert_allclose(out_small, out_big[:, :4], rtol=1e-14, atol=1e-300)
    # a locked state (I1 − 3 > Jlim): math.log of a negative number raises, the batch falls back to numpy's NaN
    with np.errstate(all="ignore"):
        bad = np.asarray(model.free_energy(np.array([20.0, 1.5]), np.array([20.0, 1.5]), 0.1))
        ref = np.asarray(model.free_energy(np.r_[20.0, 1.5, l1], np.r_[20.0, 1.5, l2], 0.1))[:2]
    if isinstance(elasticity, Gent):
        assert np.isnan(bad[0]) and np.isnan(ref[0])
    np.testing.assert_allclose(bad[1:], ref[1:], rtol=1e-14)
    # a zero stretch: the float code divides by zero (ZeroDivisionError), numpy gives infinities and NaN
    with pytest.raises(ZeroDivisionError):
        model._built["aux"].scalar(0.0, 1.0, 0.1)
    with np.errstate(all="ignore"):
        zero = np.asarray(model.tensions(np.array([0.0, 1.5]), np.array([1.0, 1.5]), 0.1), dtype=float)
        zero_ref = np.asarray(model.tensions(np.r_[0.0, 1.5, l1], np.r_[1.0, 1.5, l2], 0.1), dtype=float)[:, :2]
    assert not np.all(np.isfinite(zero[:, 0]))
    np.testing.assert_array_equal(zero[:, 0], zero_ref[:, 0])  # the same infinities and NaN
    np.testing.assert_allclose(zero[:, 1], zero_ref[:, 1], rtol=1e-14)


def test_tensions_are_derivatives_of_the_energy():
    """T1 = ∂W*/∂λ1 checked against a central difference of W* (error O(h²) ≈ 1e-10)."""
    model = MembraneModel(Gent(50.0))
    l1, l2, phi, h = 1.7, 1.3, 0.15, 1e-5
    T1, T2, T11, T12 = model.tensions(l1, l2, phi)[:4]
    W = model.free_energy
    assert T1 == pytest.approx((W(l1 + h, l2, phi) - W(l1 - h, l2, phi)) / (2 * h), rel=1e-8)
    assert T2 == pytest.approx((W(l1, l2 + h, phi) - W(l1, l2 - h, phi)) / (2 * h), rel=1e-8)
    d = 1e-4
    assert T11 == pytest.approx(
        (model.tensions(l1 + d, l2, phi)[0] - model.tensions(l1 - d, l2, phi)[0]) / (2 * d), rel=1e-6
    )
    assert T12 == pytest.approx(
        (model.tensions(l1, l2 + d, phi)[0] - model.tensions(l1, l2 - d, phi)[0]) / (2 * d), rel=1e-6
    )


def test_neo_hookean_tension_closed_form():
    """T̂1 = λ1 − λ1⁻³λ2⁻² − Φ̂²λ1λ2² (hand-derived from W* of PHYSICS.md)."""
    l1, l2, phi = 1.9, 1.4, 0.2
    T1 = MembraneModel().tensions(l1, l2, phi)[0]
    assert T1 == pytest.approx(l1 - l1**-3 * l2**-2 - phi**2 * l1 * l2**2, rel=1e-14)


def test_no_electrostatics_builds_no_field_terms():
    model = MembraneModel(NeoHookean(), NoElectrostatics())
    sym = model.symbols
    for name in ("W", "T1", "T2", "rhs"):
        assert not ca.depends_on(sym[name], sym["phi"]), name
    assert "electrostatics:ideal-dielectric" not in model.effects
    with_voltage = MembraneModel()
    assert ca.depends_on(with_voltage.symbols["W"], with_voltage.symbols["phi"])


def test_neo_hookean_builds_no_gent_terms():
    """The neo-Hookean energy is exactly ``(λ1² + λ2² + λ1⁻²λ2⁻² − 3)/2`` (no logarithm in its graph, so
    no locking term), and the Gent energy differs from it by its locking term."""
    nh, gent = MembraneModel(NeoHookean(), NoElectrostatics()), MembraneModel(Gent(97.0), NoElectrostatics())
    for model, has_log in ((nh, False), (gent, True)):
        W = model.symbols["W"]
        graph = ca.Function("W", [model.symbols["l1"], model.symbols["l2"]], [W])
        ops = {graph.instruction_id(k) for k in range(graph.n_instructions())}
        assert bool(ops & {ca.OP_LOG, ca.OP_LOG1P}) == has_log
    rng = np.random.default_rng(2)
    l1, l2 = rng.uniform(1.0, 3.0, 20), rng.uniform(1.0, 3.0, 20)
    exact = 0.5 * (l1**2 + l2**2 + 1 / (l1 * l2) ** 2 - 3)
    np.testing.assert_allclose([nh.free_energy(a, b) for a, b in zip(l1, l2)], exact, rtol=1e-14)
    I1 = l1**2 + l2**2 + 1 / (l1 * l2) ** 2
    gent_exact = -97 / 2 * np.log(1 - (I1 - 3) / 97)
    np.testing.assert_allclose([gent.free_energy(a, b) for a, b in zip(l1, l2)], gent_exact, rtol=1e-13)


@pytest.mark.parametrize("bad", [0.5, -1.0, float("nan")])
def test_bad_prestretch(bad):
    with pytest.raises(SceneError, match="prestretch"):
        MembraneModel(prestretch=bad)


@pytest.mark.parametrize("bad", [0.0, -3.0, float("inf")])
def test_bad_jlim(bad):
    with pytest.raises(SceneError) as info:
        Gent(bad)
    assert info.value.field == "jlim"


def test_closed_form_invariant_derivatives_match_casadi():
    from coexist.effects import area_invariant, area_invariant_derivatives, first_invariant, first_invariant_derivatives

    l1, l2 = ca.SX.sym("l1"), ca.SX.sym("l2")
    for inv, closed in ((first_invariant, first_invariant_derivatives), (area_invariant, area_invariant_derivatives)):
        e = inv(l1, l2)
        d1, d2 = ca.gradient(e, l1), ca.gradient(e, l2)
        auto = ca.Function("a", [l1, l2], [d1, d2, ca.gradient(d1, l1), ca.gradient(d1, l2)])
        mine = ca.Function("m", [l1, l2], [2 * x for x in closed(l1, l2)])  # they are half-derivatives
        for a, b in ((1.3, 2.1), (3.7, 1.01), (1.0, 1.0)):
            np.testing.assert_allclose([float(x) for x in auto(a, b)], [float(x) for x in mine(a, b)], rtol=1e-13)


def test_first_invariant_is_the_textbook_one_without_cancellation():
    from fractions import Fraction

    from coexist.effects import first_invariant

    for l1, l2 in ((1.3, 2.1), (3.7, 1.01), (1 + 1e-7, 1 + 2e-7), (1.0, 1.0)):
        exact = Fraction(l1) ** 2 + Fraction(l2) ** 2 + 1 / (Fraction(l1) ** 2 * Fraction(l2) ** 2) - 3
        assert first_invariant(l1, l2) == pytest.approx(float(exact), rel=1e-14, abs=1e-300)
