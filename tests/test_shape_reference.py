"""The shape outputs (``coexist shape --json``) against an integration of the membrane equations written from scratch.

The reference below does not use ``coexist.model`` (its right-hand side or tensions) nor the project's integrator:
the tensions of the Gent / neo-Hookean ideal dielectric and the axisymmetric membrane equations are written here from
docs/physics.md section 1 (normalised: ``T̂i = ∂W*/∂λi``, ``W* = Ws/μ − Φ̂²λ1²λ2²/2``) and integrated by scipy's
``solve_ivp`` (DOP853, rtol 1e-12) in the reference radius ``R̂`` from the pole (leading-order pole solution
``λ1 = λ2 = λ0``, ``θ = cR̂`` at ``R̂0 = 1e-7``) to the clamp ``R̂ = 1``, at the unit membrane's pressure ``p̂`` (the
state's ``pressure_mbar`` over the scene's ``pressure_scale_Pa``) and voltage ``Φ̂`` (kV over ``voltage_scale_V``),
with the pole stretch the output reports. Checked per state and zone group:

(a) the integration lands on the clamp, ``λ2(1) = λpre`` to 1e-8: the reported ``(λ0, p̂)`` is an equilibrium;
(b) the apex height (``z`` at the pole over the clamp) is ``apex_height_mm`` to 1e-7 relative;
(c) the profile points (equally spaced in ``R̂``, pole and clamp included: coexist/shapes.py) are ``(r, z)`` of the
    reference at the same ``R̂`` to 1e-7 of the zone radius;
(d) the apex curvature ``κ0`` is the meridian's ``dθ/ds`` at ``s → 0`` to 1e-6 relative, from a second integration
    that starts at ``R̂ = 1e-9`` with ``θ = 0`` (no Laplace law put in: the equations' regular solution at the pole
    is attracting outward, the start's error decays like ``R̂0²/R̂``), fitted as ``θ/s = κ0 + b s² + c s⁴`` on
    ``1e-4 ≤ R̂ ≤ 1e-3``.

Variations: the default scene at 0, 3.8 and 4.0 kV (both groups of the 1-of-3-bulged state), Gent ``jlim = 40`` (at
the default closing pressure, homogeneous up to 5 kV; closed at 22 mbar it bulges at 4.5 kV), neo-Hookean (closed at
19 mbar: at 20 its zones cannot hold the pressure; at 4.5 kV it has no stable state), prestretch 1.2 (closed at
17 mbar: at 20 the CLI refuses), a zone radius of 10 mm. No state compared here is wrinkled (asserted): the taut
equations do not hold in a tension-field band.
"""

import json
import math
import re

import numpy as np
import pytest
from click.testing import CliRunner
from scipy.integrate import solve_ivp

from coexist.cli.main import cli
from coexist.scene import builtin_scene_text

RTOL = 1e-12
ATOL = 1e-15
#: the reference's series start (leading order; its error O(R̂0²) ≈ 1e-14)
POLE_START = 1e-7
#: start of the curvature integration (θ = 0 there: the curvature is the equations', not the start's)
CURVATURE_START = 1e-9
POINTS = 41

LANDING_TOL = 1e-8
HEIGHT_TOL = 1e-7
PROFILE_TOL = 1e-7
CURVATURE_TOL = 1e-6


# --- the reference, from docs/physics.md section 1 --------------------------------------------------------------
def tensions(l1, l2, phi, jlim):
    """``(T̂1, T̂2, ∂T̂1/∂λ1, ∂T̂1/∂λ2)`` of the ideal dielectric, Gent (``jlim``) or neo-Hookean (``jlim=None``).

    ``W* = −(Jlim/2) ln(1 − I/Jlim) − Φ̂²λ1²λ2²/2`` (``I/2`` for neo-Hookean), ``I = λ1² + λ2² + λ1⁻²λ2⁻² − 3``.
    """
    inv = l1**2 + l2**2 + 1.0 / (l1 * l2) ** 2 - 3.0
    g = 1.0 if jlim is None else 1.0 - inv / jlim
    dg = 0.0 if jlim is None else 1.0 / (jlim * g * g)  # d(1/g)/dI
    a1 = l1 - l1**-3 * l2**-2  # (∂I/∂λ1)/2
    a2 = l2 - l2**-3 * l1**-2
    t1 = a1 / g - phi**2 * l1 * l2**2
    t2 = a2 / g - phi**2 * l2 * l1**2
    t11 = (1.0 + 3.0 * l1**-4 * l2**-2) / g + 2.0 * a1 * a1 * dg - phi**2 * l2**2
    t12 = 2.0 * l1**-3 * l2**-3 / g + 2.0 * a1 * a2 * dg - 2.0 * phi**2 * l1 * l2
    return t1, t2, t11, t12


def rhs(R, y, p, phi, jlim):
    """``(λ1, λ2, θ, z, s)'``: ``(RT1)' = T2 cos θ``, ``RT1θ' = pλ1λ2R − T2 sin θ``, ``λ2' = (λ1 cos θ − λ2)/R``,
    ``z' = λ1 sin θ`` (``z`` down from the pole), ``s' = λ1`` (arclength)."""
    l1, l2, th = y[0], y[1], y[2]
    t1, t2, t11, t12 = tensions(l1, l2, phi, jlim)
    dl2 = (l1 * math.cos(th) - l2) / R
    dth = (p * l1 * l2 * R - t2 * math.sin(th)) / (R * t1)
    dl1 = (t2 * math.cos(th) - t1 - R * t12 * dl2) / (R * t11)
    return [dl1, dl2, dth, l1 * math.sin(th), l1]


def meridian(l0, p, phi, jlim, R_out):
    """The reference meridian at the reference radii ``R_out`` (``> 0``, increasing, last 1): rows ``λ1, λ2, θ, z,
    s`` (``z`` and ``s`` from the pole)."""
    t0 = tensions(l0, l0, phi, jlim)[0]
    c = p * l0**2 / (2.0 * t0)  # θ = cR̂ + …
    R0 = POLE_START
    y0 = [l0, l0, c * R0, 0.5 * l0 * c * R0**2, l0 * R0]
    sol = solve_ivp(rhs, (R0, R_out[-1]), y0, method="DOP853", rtol=RTOL, atol=ATOL, t_eval=R_out, args=(p, phi, jlim))
    assert sol.status == 0, sol.message
    return sol.y


def curvature_at_pole(l0, p, phi, jlim):
    """``κ0 A = lim dθ/ds`` at the pole, from the meridian started with ``θ = 0`` (no curvature given)."""
    R = np.linspace(1e-4, 1e-3, 19)
    y0 = [l0, l0, 0.0, 0.0, l0 * CURVATURE_START]
    sol = solve_ivp(
        rhs, (CURVATURE_START, R[-1]), y0, method="DOP853", rtol=RTOL, atol=1e-20, t_eval=R, args=(p, phi, jlim)
    )
    assert sol.status == 0, sol.message
    th, s = sol.y[2], sol.y[4]
    coef = np.linalg.lstsq(np.vstack([np.ones_like(s), s**2, s**4]).T, th / s, rcond=None)[0]
    return coef[0]


def test_reference_tensions_are_the_models(gent97, neo_hookean):
    """Sanity check of the reference's tensions (the only use of coexist.model: conftest's models)."""
    l1 = np.array([1.0, 1.3, 1.9, 1.2, 5.5, 3.0])
    l2 = np.array([1.0, 1.1, 2.3, 1.1, 4.0, 1.2])
    for jlim, model in ((97.0, gent97), (None, neo_hookean)):
        for phi in (0.0, 0.2, 0.3):
            want = model.tensions(l1, l2, phi)[:4]
            got = tensions(l1, l2, phi, jlim)
            for w, g in zip(want, got):
                np.testing.assert_allclose(g, w, rtol=1e-12, atol=1e-13)


# --- the states, from the command line ----------------------------------------------------------------------------
def scene_text(**changes):
    """The tricircle scene's text with keys changed (``None`` removes the key), as conftest's ``variant``."""
    text = builtin_scene_text("tricircle")
    for key, val in changes.items():
        new = "" if val is None else f"{key} = {val}\n"
        text, n = re.subn(rf"^{key} = .*\n", new, text, flags=re.M)
        assert n == 1, key
    return text


def invoke(*args):
    result = CliRunner().invoke(cli, list(args))
    assert result.exit_code == 0, result.output
    return json.loads(result.stdout[result.stdout.index("{") :])


#: name -> (scene changes, voltages in kV)
SCENES = {
    "tricircle": ({}, "0,3.8,4.0"),
    "jlim40": ({"jlim": 40}, "5.0"),
    "jlim40-22mbar": ({"jlim": 40, "closing_pressure_mbar": 22}, "4.5"),
    "neo-hookean": ({"material": '"neo-hookean"', "jlim": None, "closing_pressure_mbar": 19}, "0,4.0"),
    "prestretch1.2": ({"prestretch": 1.2, "closing_pressure_mbar": 17}, "0,4.0"),
    "radius10mm": ({"zone_radius_mm": 10}, "0,5.0"),
}

#: (scene, kV, zones in the group, its pole stretch roughly: identifies the group)
CASES = [
    ("tricircle", 0.0, 3, 1.866),
    ("tricircle", 3.8, 3, 1.990),
    ("tricircle", 4.0, 2, 1.262),
    ("tricircle", 4.0, 1, 5.502),
    ("jlim40", 5.0, 3, 1.836),
    ("jlim40-22mbar", 4.5, 2, 1.738),
    ("jlim40-22mbar", 4.5, 1, 3.196),
    ("neo-hookean", 0.0, 3, 1.741),
    ("neo-hookean", 4.0, 3, 1.851),
    ("prestretch1.2", 0.0, 3, 1.928),
    ("prestretch1.2", 4.0, 3, 2.059),
    ("radius10mm", 0.0, 3, 1.172),
    ("radius10mm", 5.0, 3, 1.217),
]


@pytest.fixture(scope="module")
def outputs(tmp_path_factory):
    """``coexist check --json`` and ``coexist shape --json`` of every scene, run once (in-process)."""
    folder = tmp_path_factory.mktemp("shape_reference")
    out = {}
    for name, (changes, kv) in SCENES.items():
        if changes:
            path = folder / f"{name}.toml"
            path.write_text(scene_text(**changes))
            source = str(path)
        else:
            source = name
        check = invoke("check", source, "--json", "--no-solve")
        shape = invoke("shape", source, "--voltage-kV", kv, "--json", "--points", str(POINTS))
        out[name] = (check, shape)
    return out


def compare(check, shape, kv, zones):
    """The group of ``zones`` zones at ``kv`` and the reference's numbers for it."""
    groups = check["dimensionless_groups"]
    membrane = check["membrane"]
    mu, H, A = membrane["shear_modulus_Pa"], membrane["thickness_m"], membrane["zone_radius_m"]
    eps = membrane["permittivity_F_per_m"]
    # the scales are the normalisation of docs/physics.md: p̂ = pA/(μH), Φ̂ = (Φ/H)√(ε/μ)
    assert groups["pressure_scale_Pa"] == pytest.approx(mu * H / A, rel=1e-14)
    assert groups["voltage_scale_V"] == pytest.approx(H * math.sqrt(mu / eps), rel=1e-14)
    jlim = membrane["jlim"] if membrane["material"] == "gent" else None
    pre = membrane["prestretch"]
    (entry,) = [v for v in shape["voltages"] if v["voltage_kV"] == kv]
    (group,) = [g for g in entry["groups"] if g["zones"] == zones]
    assert group["wrinkled_radii"] == []
    assert shape["zone_radius_mm"] == pytest.approx(A * 1e3, rel=1e-15)
    A_mm = shape["zone_radius_mm"]
    p = entry["pressure_mbar"] * 100.0 / groups["pressure_scale_Pa"]
    phi = kv * 1e3 / groups["voltage_scale_V"]
    l0 = group["pole_stretch"]
    r_mm = np.array(group["profile"]["r_mm"])
    z_mm = np.array(group["profile"]["z_mm"])
    R = np.linspace(0.0, 1.0, r_mm.size)  # the profile's reference radii (pole and clamp included)
    l1, l2, th, z, s = meridian(l0, p, phi, jlim, R[1:])
    height = z[-1]  # z grows down the meridian: the pole stands z(1) above the clamp
    ref_r = np.concatenate([[0.0], l2 * R[1:]]) * A_mm
    ref_z = np.concatenate([[height], height - z]) * A_mm
    kappa = curvature_at_pole(l0, p, phi, jlim) / (A_mm * 1e-3)
    return {
        "pole_stretch": l0,
        "p_hat": p,
        "phi_hat": phi,
        "landing": l2[-1] - pre,
        "height": (group["apex_height_mm"], height * A_mm),
        "profile_r": np.max(np.abs(r_mm - ref_r)) / A_mm,
        "profile_z": np.max(np.abs(z_mm - ref_z)) / A_mm,
        "curvature": (group["apex_curvature_per_m"], kappa),
        "radius_of_curvature": (group["radius_of_curvature_mm"], 1e3 / group["apex_curvature_per_m"]),
    }


@pytest.mark.parametrize(
    ("scene", "kv", "zones", "stretch"), CASES, ids=[f"{c[0]}-{c[1]}kV-{c[2]}zones" for c in CASES]
)
def test_shape_against_reference(outputs, scene, kv, zones, stretch):
    check, shape = outputs[scene]
    got = compare(check, shape, kv, zones)
    assert got["pole_stretch"] == pytest.approx(stretch, abs=1e-3)  # the group meant (bulged or not)
    # (a) the reported (λ0, p̂) is an equilibrium: the reference lands on the clamp
    assert abs(got["landing"]) <= LANDING_TOL
    # (b) apex height
    coexist_h, ref_h = got["height"]
    assert coexist_h == pytest.approx(ref_h, rel=HEIGHT_TOL)
    # (c) the profile, point by point at the same reference radii
    assert got["profile_r"] <= PROFILE_TOL
    assert got["profile_z"] <= PROFILE_TOL
    # (d) apex curvature: the Laplace law against the meridian's own dθ/ds at the pole
    coexist_k, ref_k = got["curvature"]
    assert coexist_k == pytest.approx(ref_k, rel=CURVATURE_TOL)
    assert got["radius_of_curvature"][0] == pytest.approx(got["radius_of_curvature"][1], rel=1e-14)
