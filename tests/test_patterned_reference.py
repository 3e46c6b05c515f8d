"""Patterned single zones against a shooting written from scratch (audit of :mod:`coexist.patterned`).

The reference here uses nothing of coexist's numerics: its own Gent ideal-dielectric tensions (docs/physics.md,
section 1; checked once against ``MembraneModel.tensions``), its own right-hand side, scipy's DOP853 at
rtol 1e-12, region by region in the reference radius of the *unit* membrane (no scaling trick: the interfaces
sit at their fractions, the pressure is the unknown). Region ``k`` of ``nk`` layers obeys the one-layer
equations at ``p̂/nk`` and ``Φ̂/nk`` (0 without electrode, section 12). At an interface ``λ2``, ``θ``, ``ẑ`` and
``V̂`` are continuous and ``λ1`` jumps so that ``n⁻T̂1(λ1⁻, λ2; Φ̂⁻) = n⁺T̂1(λ1⁺, λ2; Φ̂⁺)`` (brentq on the stable
branch, below the first maximum of ``T̂1`` in ``λ1``). The integration starts at ``R̂0 = 1e-6`` with the
leading-order solution of the pole region's stack (``λ1 = λ2 = λ0``, ``θ = c R̂``, ``c = (p̂/n1) λ0² / (2 T̂0)``);
the pressure is found by brentq on ``λ2(1) − λpre``, and ``V̂ = ∫ π r̂² dẑ`` is carried as a quadrature.

Compared: ``p̂``, ``V̂``, the apex height and both sides of every interface ``(R̂, r̂, ẑ, θ, nT̂1)`` of
``solve_patterned_states`` (to 1e-8; measured ≤ 5e-11) for the built-in inner-circle scene's pattern and a ring
0.4–0.9 with two passive layers, at Φ̂ = 0, 0.15, 0.25; and one state of ``coexist shape inner-circle --json``,
its profile points against this integration at the same reference radii.
"""

from __future__ import annotations

import json
import math
import sys

if sys.version_info >= (3, 11):
    import tomllib
else:  # Python 3.10
    import tomli as tomllib

import numpy as np
import pytest
from click.testing import CliRunner
from conftest import TIGHT
from scipy.integrate import solve_ivp
from scipy.optimize import brentq

from coexist.cli.main import cli
from coexist.model import build_model
from coexist.patterned import ZonePattern, solve_patterned_states
from coexist.scene import builtin_scene_text

RTOL = 1e-12
ATOL = 1e-14
#: the series start: the leading order's error is O(R̂0²) (measured: p̂ moves by 2.7e-12 from 1e-6 to 1e-7)
POLE_RADIUS = 1e-6
#: agreement asked of p̂, V̂, the apex height (relative) and the interface points (absolute, units of A)
TOL = 1e-8
VACUUM_PERMITTIVITY = 8.8541878128e-12

SCENE = tomllib.loads(builtin_scene_text("inner-circle"))
JLIM = float(SCENE["membrane"]["jlim"])
PRESTRETCH = float(SCENE["membrane"]["prestretch"])
INNER_CIRCLE = ZonePattern.inner_circle(
    SCENE["electrodes"]["inner_fraction"], passive_layers=SCENE["layers"]["passive"]
)
RING = ZonePattern.ring(0.4, 0.9, passive_layers=2)
PATTERNS = {"inner-circle": INNER_CIRCLE, "ring": RING}
POLE_STRETCHES = {"inner-circle": (1.3, 2.0, 3.0, 4.5), "ring": (1.2, 1.6, 2.2, 3.0)}
VOLTAGES = (0.0, 0.15, 0.25)
#: states the solver reports wrinkled (the hoop tension on the ring's side of its inner edge), with that tension
WRINKLED = {("ring", 3.0, 0.25): -1.259}


# --- the reference: tensions, right-hand side, interface jump, shooting -------------------------------------


def tensions(l1, l2, phi, jlim=JLIM):
    """One layer, over μH: ``T̂1, T̂2, ∂T̂1/∂λ1, ∂T̂1/∂λ2`` of ``W* = −(Jlim/2) ln(1 − I/Jlim) − φ²λ1²λ2²/2``."""
    inv = 1.0 / (l1 * l1 * l2 * l2)
    g = 1.0 - (l1 * l1 + l2 * l2 + inv - 3.0) / jlim
    a1 = l1 - inv / l1
    a2 = l2 - inv / l2
    f2 = phi * phi
    t1 = a1 / g - f2 * l1 * l2 * l2
    t2 = a2 / g - f2 * l1 * l1 * l2
    t11 = (1.0 + 3.0 * inv / (l1 * l1)) / g + 2.0 * a1 * a1 / (jlim * g * g) - f2 * l2 * l2
    t12 = 2.0 * inv / (l1 * l2) / g + 2.0 * a1 * a2 / (jlim * g * g) - 2.0 * f2 * l1 * l2
    return t1, t2, t11, t12


def region_rhs(p, phi):
    """``(λ1, λ2, θ, ẑ, V̂)'`` in ``R̂`` of one layer at pressure ``p`` and voltage ``phi``."""

    def rhs(R, y):
        l1, l2, th = y[0], y[1], y[2]
        t1, t2, t11, t12 = tensions(l1, l2, phi)
        c, s = math.cos(th), math.sin(th)
        dl2 = (l1 * c - l2) / R
        dl1 = (t2 * c - t1 - R * t12 * dl2) / (R * t11)
        dth = (p * l1 * l2 * R - t2 * s) / (R * t1)
        r = l2 * R
        return [dl1, dl2, dth, l1 * s, math.pi * r * r * l1 * s]

    return rhs


def locking_stretch(l2, jlim=JLIM):
    """The ``λ1`` at which the Gent chains lock at hoop stretch ``l2`` (``I = Jlim``)."""
    b = jlim + 3.0 - l2 * l2
    return math.sqrt(0.5 * (b + math.sqrt(b * b - 4.0 / (l2 * l2))))


def jump(l1_in, l2, phi_in, n_in, phi_out, n_out):
    """``λ1⁺`` with ``n_out T̂1(λ1⁺, λ2; φ⁺) = n_in T̂1(λ1⁻, λ2; φ⁻)`` below the first maximum of ``T̂1(·, λ2; φ⁺)``."""
    target = n_in * tensions(l1_in, l2, phi_in)[0] / n_out
    lo, hi = 0.2, locking_stretch(l2) * (1.0 - 1e-9)
    x = np.geomspace(lo, hi, 2000)
    slope = np.array([tensions(v, l2, phi_out)[2] for v in x])
    soft = np.flatnonzero(slope <= 0.0)
    top = hi if soft.size == 0 else brentq(lambda v: tensions(v, l2, phi_out)[2], x[soft[0] - 1], x[soft[0]])
    if tensions(top, l2, phi_out)[0] <= target:
        raise ValueError("no stable outer stretch: pull-in at the interface")
    return brentq(lambda v: tensions(v, l2, phi_out)[0] - target, lo, top, xtol=1e-15, rtol=1e-15)


def region_voltage(region, phi):
    return phi / region.layers if region.electrode else 0.0


def shoot(pattern, l0, phi, p, sample=None):
    """Integrate the unit membrane at pressure ``p`` from the pole to ``R̂ = 1``.

    Returns the state at the clamp ``(λ1, λ2, θ, ẑ, V̂)``, per interface ``(f, state on the pole side, λ1⁺)``, the
    smallest stack tension over the integration nodes and both sides of the interfaces and, with ``sample``
    (reference radii), the states there (an interface radius once, its pole side)."""
    first = pattern.regions[0]
    t0 = tensions(l0, l0, region_voltage(first, phi))[0]
    c = (p / first.layers) * l0 * l0 / (2.0 * t0)
    R0 = POLE_RADIUS
    y = np.array([l0, l0, c * R0, 0.5 * l0 * c * R0 * R0, 0.25 * math.pi * l0**3 * c * R0**4])
    edges, got_R, got_y, least = [], [], [], math.inf
    for k, region in enumerate(pattern.regions):
        phik = region_voltage(region, phi)
        te = None if sample is None else [t for t in sample if R0 <= t <= region.outer and t not in got_R]
        sol = solve_ivp(
            region_rhs(p / region.layers, phik), (R0, region.outer), y, "DOP853", te or None, rtol=RTOL, atol=ATOL
        )
        assert sol.status == 0, sol.message
        if te:
            got_R.extend(sol.t)
            got_y.append(sol.y)
        y = sol.y[:, -1].copy()
        t1, t2, _, _ = tensions(sol.y[0], sol.y[1], phik)
        least = min(least, region.layers * min(t1.min(), t2.min()))
        if k + 1 < len(pattern.regions):
            nxt = pattern.regions[k + 1]
            l1p = jump(y[0], y[1], phik, region.layers, region_voltage(nxt, phi), nxt.layers)
            edges.append((region.outer, y.copy(), l1p))
            least = min(least, nxt.layers * min(tensions(l1p, y[1], region_voltage(nxt, phi))[:2]))
            y[0] = l1p
        R0 = region.outer
    out = {"clamp": y, "edges": edges, "min_tension": least}
    if sample is not None:
        out["R"], out["y"] = np.array(got_R), np.concatenate(got_y, axis=1)
    return out


def clamped_pressure(pattern, l0, phi, guess):
    """The pressure with ``λ2(1) = λpre`` (brentq; ``guess`` only places the first bracket, widened until the
    sign changes)."""

    def miss(p):
        return shoot(pattern, l0, phi, p)["clamp"][1] - PRESTRETCH

    width = 1e-4
    while True:
        a, b = guess * (1.0 - width), guess * (1.0 + width)
        if miss(a) * miss(b) < 0.0:
            return brentq(miss, a, b, xtol=1e-15, rtol=1e-14)
        width *= 4.0
        assert width < 0.5, "no bracket of the clamp condition"


# --- checks of the reference itself --------------------------------------------------------------------------


@pytest.fixture(scope="module")
def model():
    return build_model(SCENE["membrane"]["material"], JLIM, prestretch=PRESTRETCH)


def test_own_tensions_are_the_models(model):
    """One layer of a stack of ``n`` at ``Φ̂/n``: the hand-written tensions equal ``model.tensions`` to 1e-13."""
    for l1, l2, phi, n in [(1.3, 1.7, 0.0, 1), (2.5, 2.1, 0.15, 1), (4.0, 3.5, 0.25, 2), (1.1, 1.05, 0.25, 2)]:
        mine = tensions(l1, l2, phi / n)
        theirs = model.tensions(l1, l2, phi / n)
        for a, b in zip(mine, theirs[:4]):
            assert a == pytest.approx(float(b), rel=1e-13, abs=1e-13)


# --- states --------------------------------------------------------------------------------------------------


@pytest.fixture(scope="module")
def solver_states(model):
    """The solver's states per (pattern, Φ̂), all pole stretches in one call."""
    return {
        (name, phi): solve_patterned_states(model, PATTERNS[name], np.array(POLE_STRETCHES[name]), phi, TIGHT)
        for name in PATTERNS
        for phi in VOLTAGES
    }


CASES = [
    (name, l0, phi)
    for name in PATTERNS
    for phi in VOLTAGES
    for l0 in POLE_STRETCHES[name]
    if (name, l0, phi) not in WRINKLED  # those: test_wrinkled_states_wrinkle_in_the_reference_too
]


@pytest.mark.parametrize("name, l0, phi", CASES, ids=[f"{n}-l0={l0}-phi={phi}" for n, l0, phi in CASES])
def test_state_equals_the_reference(solver_states, name, l0, phi):
    pattern = PATTERNS[name]
    st = solver_states[name, phi]
    i = POLE_STRETCHES[name].index(l0)
    assert st.ok[i], st.failure_detail[i]
    p = clamped_pressure(pattern, l0, phi, float(st.p_hat[i]))
    grid = list(np.linspace(0.0, 1.0, 101)[1:])
    ref = shoot(pattern, l0, phi, p, sample=grid)
    # the first return to the clamp stretch, and taut everywhere on the reference's own samples
    assert np.all(ref["y"][1][ref["R"] < 1.0] > PRESTRETCH)
    assert ref["clamp"][1] == pytest.approx(PRESTRETCH, abs=1e-12)
    assert ref["min_tension"] > 0.0

    assert st.p_hat[i] == pytest.approx(p, rel=TOL)
    assert st.v_hat[i] == pytest.approx(ref["clamp"][4], rel=TOL)
    assert st.apex_height[i] == pytest.approx(ref["clamp"][3], rel=TOL)
    assert st.interfaces.shape[1] == len(ref["edges"])
    for k, (f, y, l1p) in enumerate(ref["edges"]):
        inner, outer = pattern.regions[k], pattern.regions[k + 1]
        force_in = inner.layers * tensions(y[0], y[1], region_voltage(inner, phi))[0]
        force_out = outer.layers * tensions(l1p, y[1], region_voltage(outer, phi))[0]
        assert force_in == pytest.approx(force_out, rel=1e-13)
        for side, force in ((0, force_in), (1, force_out)):
            R, r, z, theta, nT1 = st.interfaces[i, k, side]
            assert R == pytest.approx(f, abs=1e-10)
            assert abs(r - y[1] * f) <= TOL and abs(z - y[3]) <= TOL and abs(theta - y[2]) <= TOL
            assert nT1 == pytest.approx(force, rel=TOL)


@pytest.mark.parametrize("name, l0, phi", sorted(WRINKLED))
def test_wrinkled_states_wrinkle_in_the_reference_too(solver_states, model, name, l0, phi):
    """A state the solver reports wrinkled (left out of the comparison above): the reference's state at the same
    (λ0, Φ̂) has a negative hoop tension on the electrode side of the ring's inner edge, the value the solver names
    (its formally continued state's smallest tension to 1e-8)."""
    st = solver_states[name, phi]
    i = POLE_STRETCHES[name].index(l0)
    assert not st.ok[i] and "wrinkles" in st.failure_detail[i], st.failure_detail[i]
    pattern = PATTERNS[name]
    formal = solve_patterned_states(model, pattern, [l0], phi, TIGHT, formal=True)
    p = clamped_pressure(pattern, l0, phi, float(formal.p_hat[0]))
    assert formal.p_hat[0] == pytest.approx(p, rel=TOL)
    f, y, l1p = shoot(pattern, l0, phi, p)["edges"][0]
    hoop = tensions(l1p, y[1], region_voltage(pattern.regions[1], phi))[1]
    assert hoop == pytest.approx(WRINKLED[name, l0, phi], abs=1e-3)
    assert hoop == pytest.approx(formal.min_tension[0], rel=TOL)


# --- a profile of the shape command --------------------------------------------------------------------------


def test_shape_command_profile_equals_the_reference():
    """``coexist shape inner-circle --voltage-kV 3 --json`` (rtol 1e-12): its pole stretch and voltage shot here
    (Φ̂ from the scene's own numbers) land on its pressure, and every profile point ``(r̂, ẑ)`` at
    ``R̂ = k/40`` (the electrode edge at ``R̂ = 0.5`` among them) is the reference's to 1e-8."""
    args = ["shape", "inner-circle", "--voltage-kV", "3", "--points", "41", "--accuracy", "high", "--json"]
    r = CliRunner().invoke(cli, args)
    assert r.exit_code == 0, r.output
    out = json.loads(r.stdout)
    (entry,) = out["voltages"]
    (group,) = entry["groups"]
    mem = SCENE["membrane"]
    A = mem["zone_radius_mm"] * 1e-3
    H = mem["thickness_mm"] * 1e-3
    mu = mem["shear_modulus_kPa"] * 1e3
    eps = mem["relative_permittivity"] * VACUUM_PERMITTIVITY
    assert out["zone_radius_mm"] == mem["zone_radius_mm"]
    phi = entry["voltage_kV"] * 1e3 / H * math.sqrt(eps / mu)
    p_cli = entry["pressure_mbar"] * 100.0 / (mu * H / A)
    l0 = group["pole_stretch"]

    p = clamped_pressure(INNER_CIRCLE, l0, phi, p_cli)
    assert p_cli == pytest.approx(p, rel=TOL)
    R = np.linspace(0.0, 1.0, 41)
    ref = shoot(INNER_CIRCLE, l0, phi, p, sample=list(R[1:]))
    assert np.allclose(ref["R"], R[1:], rtol=0, atol=1e-15)
    height = ref["clamp"][3]
    r_ref = np.concatenate([[0.0], ref["y"][1] * ref["R"]])
    z_ref = np.concatenate([[height], height - ref["y"][3]])
    r_cli = np.array(group["profile"]["r_mm"]) * 1e-3 / A
    z_cli = np.array(group["profile"]["z_mm"]) * 1e-3 / A
    assert r_cli.shape == r_ref.shape
    assert np.max(np.abs(r_cli - r_ref)) <= TOL
    assert np.max(np.abs(z_cli - z_ref)) <= TOL
    assert group["apex_height_mm"] * 1e-3 / A == pytest.approx(height, rel=TOL)
    edge = np.array(group["electrode_edge_mm"]) * 1e-3 / A
    f, y, _ = ref["edges"][0]
    assert np.max(np.abs(edge - [y[1] * f, height - y[3]])) <= TOL
