"""Zone shapes (coexist/shapes.py, docs/physics.md section 11): the dense profile, apex height and curvature.

Each check compares the profile with something computed another way: the shooting's volume and apex height,
a polynomial fit of the profile's points near the pole, the clamp condition, the flat membrane, and, at
small inflation, the Föppl–Hencky membrane solved here from its own equations.
"""

import json
import math

import numpy as np
import pytest
from click.testing import CliRunner
from conftest import TIGHT
from scipy.integrate import solve_ivp
from scipy.interpolate import CubicSpline
from scipy.optimize import brentq

from coexist.cli.main import cli
from coexist.effects import Gent, IdealDielectric, NeoHookean, NoElectrostatics
from coexist.errors import ModelRangeError, SceneError
from coexist.model import MembraneModel
from coexist.settings import SolverSettings
from coexist.shapes import Profile, apex_curvature_hat, profile, profiles
from coexist.shooting import solve_states

#: states across the range: barely inflated, near the pressure maximum, far past it; with and without voltage
STRETCHES = np.array([1.01, 1.5, 3.0, 5.4])


@pytest.fixture(scope="module")
def dense(neo_hookean, gent97):
    """Dense profiles (2001 points, rtol 1e-12) of neo-Hookean and Gent 97 states at Φ̂ = 0.1."""
    return [
        (model, profiles(model, STRETCHES, 0.1, zone_radius=1.0, points=2001, settings=TIGHT))
        for model in (neo_hookean, gent97)
    ]


def _volume(prof: Profile) -> float:
    """``V̂ = ∫ π r̂² dẑ`` along the meridian (pole to clamp, ``ẑ`` falling), from the points alone: cubic
    splines of ``r̂(R̂)`` and ``ẑ(R̂)`` integrated by 8-point Gauss–Legendre on every interval."""
    sr, sz = CubicSpline(prof.R_hat, prof.r_hat), CubicSpline(prof.R_hat, prof.z_hat)
    x, w = np.polynomial.legendre.leggauss(8)
    a, b = prof.R_hat[:-1], prof.R_hat[1:]
    xx = 0.5 * (b - a)[:, None] * x + 0.5 * (a + b)[:, None]
    return float(np.sum(0.5 * (b - a)[:, None] * w * np.pi * sr(xx) ** 2 * (-sz(xx, 1))))


def test_profile_volume_is_the_states_volume(dense):
    """(a) The volume under the profile's points equals the shooting's V̂ to 1e-8 (measured ≤ 3e-12)."""
    for model, profs in dense:
        st = solve_states(model, STRETCHES, 0.1, TIGHT)
        for prof, v in zip(profs, st.v_hat):
            assert _volume(prof) == pytest.approx(v, rel=1e-8, abs=0)
            assert prof.v_hat == v


def test_profile_apex_is_the_states_apex_height(dense):
    """(b) The profile's pole point is at the shooting's apex height to 1e-10 (measured ≤ 3e-13 at rtol 1e-12;
    ≤ 2.5e-11 at the default 1e-10, checked below)."""
    for model, profs in dense:
        st = solve_states(model, STRETCHES, 0.1, TIGHT)
        for prof, h in zip(profs, st.apex_height):
            assert prof.z_hat[0] == pytest.approx(h, abs=1e-10, rel=0)
            assert prof.apex_height_hat == h and prof.r_hat[0] == 0.0 and prof.R_hat[0] == 0.0
    model = dense[0][0]
    default = profiles(model, STRETCHES, 0.1, zone_radius=1.0, points=5)
    st = solve_states(model, STRETCHES, 0.1)
    assert np.max(np.abs([p.z_hat[0] for p in default] - st.apex_height)) < 1e-10


def test_apex_curvature_laplace_law_and_fit(dense):
    """(c) κ0 A = p̂ λ0 / (2 T̂0) (the Laplace law p = 2 t κ0 with t = μH T̂0/λ0) agrees with a fit of the
    dense profile near the pole: ẑ = h − κ0 r̂²/2 + O(r̂⁴), a polynomial of degree 4 in r̂² over the points
    with r̂ < 0.05 r̂clamp, to 1e-5 (measured ≤ 7e-11)."""
    for model, profs in dense:
        for prof in profs:
            T0 = float(model.pole(prof.pole_stretch, prof.phi_hat)[0])
            assert prof.apex_curvature_hat == pytest.approx(prof.p_hat * prof.pole_stretch / (2 * T0), rel=1e-14)
            near = prof.r_hat < 0.05 * prof.r_hat[-1]
            assert near.sum() >= 10
            c = np.polyfit(prof.r_hat[near] ** 2, prof.z_hat[near], 4)
            assert -2 * c[-2] == pytest.approx(prof.apex_curvature_hat, rel=1e-5)
            assert c[-1] == pytest.approx(prof.apex_height_hat, abs=1e-9)
    # a wrong formula (the nominal tension taken as the true one, p̂ / (2 T̂0)) is far off the fit
    model, profs = dense[0]
    prof = profs[2]
    wrong = prof.p_hat / (2 * float(model.pole(prof.pole_stretch, prof.phi_hat)[0]))
    assert abs(wrong / prof.apex_curvature_hat - 1) > 0.5


def test_physical_units(neo_hookean):
    """Metres are the normalised lengths times A; the curvature divides by A."""
    a, b = (profile(neo_hookean, 1.8, 0.05, zone_radius=A, points=21) for A in (1.0, 0.0214165))
    assert np.allclose(b.r, a.r_hat * 0.0214165, rtol=1e-15) and np.allclose(b.z, a.z_hat * 0.0214165, rtol=1e-15)
    assert b.apex_height == pytest.approx(a.apex_height_hat * 0.0214165, rel=1e-15)
    assert b.apex_curvature == pytest.approx(a.apex_curvature_hat / 0.0214165, rel=1e-15)
    assert b.radius_of_curvature == pytest.approx(0.0214165 / a.apex_curvature_hat, rel=1e-15)
    d = b.to_dict(points=True)
    assert d["apex_height_mm"] == pytest.approx(b.apex_height * 1e3) and len(d["profile"]["r_mm"]) == 21
    assert json.dumps(d, allow_nan=False)


def test_flat_membrane_has_no_height_and_no_curvature(neo_hookean):
    """(d) λ0 = λpre is the flat membrane at p̂ = 0: zero height and curvature, r = λpre R; the inflated
    states approach it continuously (h ~ √(λ0 − 1), κ0 ~ h); a slack flat membrane (Φ̂ above
    Φ̂c = √(λpre⁻² − λpre⁻⁸), docs/physics.md section 10) is refused."""
    flat = profile(neo_hookean, 1.0, 0.0, zone_radius=0.02, points=11)  # the stress-free disc
    assert flat.p_hat == 0 and flat.apex_height == 0 and flat.apex_curvature == 0
    assert np.all(flat.z == 0) and np.allclose(flat.r_hat, flat.R_hat, rtol=0, atol=0)
    assert math.isinf(flat.radius_of_curvature) and flat.to_dict()["radius_of_curvature_mm"] is None
    pre = MembraneModel(NeoHookean(), IdealDielectric(), prestretch=2.0)
    flat2 = profile(pre, 2.0, 0.1, zone_radius=1.0, points=5)
    assert np.array_equal(flat2.r_hat, 2.0 * flat2.R_hat) and flat2.electrode_edge_hat == (2.0, 0.0)
    small = profiles(neo_hookean, [1 + 1e-6, 1 + 4e-6], 0.0, zone_radius=1.0, points=5, settings=TIGHT)
    assert small[0].apex_height_hat < 3e-3 and small[0].apex_curvature_hat < 6e-3
    assert small[1].apex_height_hat / small[0].apex_height_hat == pytest.approx(2.0, rel=1e-3)
    with pytest.raises(ModelRangeError, match="not taut"):
        profile(neo_hookean, 1.0, 0.01, zone_radius=1.0)  # without prestretch any voltage compresses it
    phi_c = math.sqrt(2.0**-2 - 2.0**-8)
    with pytest.raises(ModelRangeError, match="not taut"):
        profile(pre, 2.0, 1.01 * phi_c, zone_radius=1.0)
    assert profile(pre, 2.0, 0.99 * phi_c, zone_radius=1.0).apex_height == 0


def test_profile_ends_at_the_clamp(dense):
    """(e) The last point is the clamp, (r̂, ẑ) = (λpre, 0), to 1e-10 (also with a prestretch), R̂ = 1; the
    meridian's first point is the pole and the electrode edge of a uniform electrode is the clamp."""
    pre = MembraneModel(Gent(97.0), IdealDielectric(), prestretch=1.5)
    with_pre = profiles(pre, [1.6, 3.0], 0.05, zone_radius=1.0, points=101, settings=TIGHT)
    for prof in [p for _, profs in dense for p in profs] + with_pre:
        lam = prof.prestretch
        assert abs(prof.r_hat[-1] - lam) < 1e-10 and abs(prof.z_hat[-1]) < 1e-10 and prof.R_hat[-1] == 1.0
        assert prof.electrode_edge_hat == (lam, 0.0) and prof.electrode_edge_R_hat == 1.0
        assert np.all(np.diff(prof.R_hat) > 0)


def _foppl_hencky_ratio() -> float:
    """``κ0 / (2h/A²)`` of the Föppl–Hencky clamped membrane (small strain, E = 3μ, ν = 1/2: the neo-Hookean
    membrane linearised), from its own equations: with ``C = EH/(1 − ν²) = q = A = 1``, ``N_r w' = −r/2``,
    ``(r N_r)' = N_θ``, ``u' = N_r − ν u/r − w'²/2``, ``N_θ = (1 − ν²) u/r + ν N_r``, shot from the centre
    (``u = r N0/(1 + ν)``) to ``u(1) = 0``. Then ``κ0 = 1/(2 N0)``, ``h = −w(1)``; the ratio does not depend
    on the load."""
    nu = 0.5

    def shoot(N0):
        def f(r, y):
            u, N, w = y
            wp = -r / (2 * N)
            return [N - nu * u / r - wp**2 / 2, ((1 - nu**2) * u / r + (nu - 1) * N) / r, wp]

        r0 = 1e-7
        y0 = [r0 * N0 / (1 + nu), N0, -(r0**2) / (4 * N0)]
        return solve_ivp(f, (r0, 1.0), y0, method="DOP853", rtol=1e-12, atol=1e-15)

    N0 = brentq(lambda N: shoot(N).y[0, -1], 0.35, 0.5, xtol=1e-15)
    h = -shoot(N0).y[2, -1]
    return 1 / (2 * N0) / (2 * h)


def test_small_inflation_is_the_foppl_hencky_cap():
    """(f) At small inflation a neo-Hookean membrane without prestretch is a cap *close to* the sphere through
    its apex and clamp, κ0 ≈ 2h/(A² + h²), but not equal to it: its pole is flatter, κ0 → C 2h/A² with the
    Föppl–Hencky constant C = 0.91097 (ν = 1/2), and the corrections are O(h²) (measured: C(h) − C =
    −8e-6, −3.2e-5 at h/A = 0.0124, 0.0248). Expected and asserted: within 0.1 (h/A)² of C, the deviation
    growing ~4× when h doubles; and within 10 % of the spherical estimate."""
    C = _foppl_hencky_ratio()
    assert C == pytest.approx(0.91097, abs=1e-5)
    model = MembraneModel(NeoHookean(), NoElectrostatics())
    profs = profiles(model, [1.0001, 1.0004, 1.0016], 0.0, zone_radius=1.0, points=5, settings=TIGHT)
    dev = []
    for prof in profs:
        h = prof.apex_height_hat
        ratio = prof.apex_curvature_hat / (2 * h / (1 + h * h))
        assert abs(ratio - 1) < 0.1
        assert abs(ratio - C) < 0.1 * h * h
        dev.append(abs(ratio - C))
    assert 2.5 < dev[1] / dev[0] < 6 and 2.5 < dev[2] / dev[1] < 6


def test_bad_inputs_are_named(neo_hookean):
    with pytest.raises(SceneError, match="zone_radius"):
        profile(neo_hookean, 1.5, 0.0, zone_radius=-1.0)
    with pytest.raises(SceneError, match="points"):
        profile(neo_hookean, 1.5, 0.0, zone_radius=1.0, points=2)
    with pytest.raises(SceneError, match="pole stretch"):
        profile(neo_hookean, 0.9, 0.0, zone_radius=1.0)
    with pytest.raises(ModelRangeError):
        profile(neo_hookean, 1.5, 0.6, zone_radius=1.0)  # no taut state: the shooting says why


def test_many_states_at_once_equal_one_by_one(gent97):
    """One batch gives the same profiles as one state at a time (the batch shares nothing between states)."""
    settings = SolverSettings(rtol=1e-10)
    many = profile(gent97, np.array([1.3, 4.0]), np.array([0.0, 0.2]), zone_radius=0.02, points=31, settings=settings)
    one = profile(gent97, 4.0, 0.2, zone_radius=0.02, points=31, settings=settings)
    assert isinstance(many, list) and isinstance(one, Profile)
    assert np.allclose(many[1].z, one.z, rtol=0, atol=1e-12 * 0.02)
    assert many[1].apex_curvature == one.apex_curvature
    assert apex_curvature_hat(gent97, 4.0, 0.2, one.p_hat) == one.apex_curvature_hat


# --- the command line ------------------------------------------------------------------------------------


def click_wrap(fn, *args):
    """A click command that calls ``fn(*args)`` (to read a table printer's output through CliRunner)."""
    import click

    return click.command()(lambda: fn(*args))


def test_shape_command_prints_each_zone(tmp_path):
    """`coexist shape`: at 4.0 kV on the ramp up one zone of three is bulged; every number is the library's
    state's (the bulged zone's apex height against a profile computed here from its pole stretch)."""
    png = tmp_path / "side.png"
    r = CliRunner().invoke(cli, ["shape", "--voltage-kV", "0,4.0", "--points", "21", "-o", str(png), "--json"])
    assert r.exit_code == 0, r.output
    data = json.loads(r.stdout)
    at0, at4 = data["voltages"]
    assert at0["configuration"] == "homogeneous" and at4["configuration"] == "1 of 3 bulged"
    assert [g["zones"] for g in at4["groups"]] == [2, 1]
    bulged = at4["groups"][1]
    assert bulged["apex_height_mm"] > 2 * at4["groups"][0]["apex_height_mm"]
    assert bulged["electrode_edge_mm"] == [pytest.approx(21.4165), 0.0]
    assert len(bulged["profile"]["r_mm"]) == 21 and bulged["profile"]["z_mm"][-1] == 0.0
    assert png.stat().st_size > 10_000
    from coexist.cli.shape import _table

    text = CliRunner().invoke(click_wrap(_table, data))
    assert text.exit_code == 0 and "1 of 3 bulged" in text.stdout and "apex_height_mm" in text.stdout
    assert f"{bulged['apex_height_mm']:.6f}" in text.stdout and "(21.4165, 0.0000)" in text.stdout


@pytest.mark.parametrize(
    "value, message", [("-1", "negative"), ("6", "above the scene's stop"), ("abc", "numbers"), ("nan", "finite")]
)
def test_shape_bad_voltages_exit_2(value, message):
    r = CliRunner().invoke(cli, ["shape", "--voltage-kV", value])
    assert r.exit_code == 2 and message in r.output
    assert r.exception is None or isinstance(r.exception, SystemExit)  # no traceback


def test_shape_refuses_to_overwrite(tmp_path):
    png = tmp_path / "side.png"
    png.write_bytes(b"mine")
    r = CliRunner().invoke(cli, ["shape", "--voltage-kV", "0", "-o", str(png)])
    assert r.exit_code == 2 and "--overwrite" in r.output and png.read_bytes() == b"mine"


def test_shape_without_voltage_scene():
    r = CliRunner().invoke(cli, ["shape", "two-balloons", "--json", "--points", "5"])
    assert r.exit_code == 0, r.output
    (at0,) = json.loads(r.stdout)["voltages"]
    assert at0["configuration"] == "homogeneous" and at0["groups"][0]["zones"] == 2
    r = CliRunner().invoke(cli, ["shape", "two-balloons", "--voltage-kV", "1"])
    assert r.exit_code == 2 and "[voltage]" in r.output


def test_ramp_shapes_json():
    """`coexist ramp --shapes --json`: per step and group the shape, with 41 profile points; the apex height
    is the shooting's apex height of the step's pole stretch."""
    r = CliRunner().invoke(cli, ["ramp", "--shapes", "--json", "--every", "50"])
    assert r.exit_code == 0, r.output
    data = json.loads(r.stdout)
    for step in data["steps"]:
        if step["groups"] is None:
            assert step["shapes"] is None
            continue
        assert [g["zones"] for g in step["shapes"]] == [g["zones"] for g in step["groups"]]
        for g, s in zip(step["groups"], step["shapes"]):
            assert s["pole_stretch"] == g["pole_stretch"] and len(s["profile"]["z_mm"]) == 41
    step = [s for s in data["steps"] if s["configuration"] == "1 of 3 bulged"][0]
    from coexist.scene import load_scene

    sc = load_scene("tricircle")
    lam = step["shapes"][-1]["pole_stretch"]
    st = solve_states(sc.model(), [lam], float(sc.phi_hat(step["voltage_kV"] * 1e3)))
    assert step["shapes"][-1]["apex_height_mm"] == pytest.approx(st.apex_height[0] * sc.zone_radius * 1e3, rel=1e-9)
    from coexist.cli.ramp import _table

    plain = CliRunner().invoke(click_wrap(_table, data))
    assert plain.exit_code == 0 and "apex_height_mm" in plain.stdout
    assert f"{step['shapes'][-1]['apex_height_mm']:.2f}/" in plain.stdout


def test_wrinkled_states_get_their_profile_too():
    """A hoop-wrinkled state of a tension-field model (neo-Hookean, Φ̂ = 0.3, λ0 = 1.03: a ring at the clamp,
    docs/physics.md section 10) gets its points like the taut state of the same batch (the wrinkled profiles are
    checked in tests/test_shapes_wrinkled.py), with the shooting's apex height and the Laplace-law curvature (the
    pole is taut); ``wrinkled="numbers"`` and ``"raise"``, the values of the time it had none, give the same."""
    model = MembraneModel(NeoHookean(), IdealDielectric(), wrinkling="tension-field")
    st = solve_states(model, [1.03, 1.06], 0.3)
    wr, taut = profiles(model, [1.03, 1.06], 0.3, zone_radius=1.0, points=11)
    assert wr.wrinkled_radii and wr.r_hat.size == 11 and wr.to_dict()["profile"] is not None
    assert wr.apex_height_hat == st.apex_height[0] and wr.z_hat[0] == pytest.approx(st.apex_height[0], abs=1e-9)
    assert wr.apex_curvature_hat == apex_curvature_hat(model, 1.03, 0.3, st.p_hat[0])
    assert not taut.wrinkled_radii and taut.r_hat.size == 11 and taut.z_hat[0] == pytest.approx(st.apex_height[1])
    for value in ("numbers", "raise"):
        again = profiles(model, [1.03, 1.06], 0.3, zone_radius=1.0, points=11, wrinkled=value)[0]
        assert np.array_equal(again.z_hat, wr.z_hat) and np.array_equal(again.r_hat, wr.r_hat)
    with pytest.raises(SceneError, match="wrinkled"):
        profiles(model, 1.03, 0.3, zone_radius=1.0, wrinkled="skip")
