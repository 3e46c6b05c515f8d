"""Dimensional scale invariance, and a stiff gas (a large normalised atmospheric pressure).

Two scenes that differ in their dimensional parameters but share every dimensionless group (docs/physics.md: the
normalisation ``p̂ = pA/(μH)``, ``V̂ = V/A³``, ``Φ̂ = (Φ/H)√(ε/μ)``, with ``p̂atm``, ``V̂c``, the closing ``p̂`` and the
voltage path's ``Φ̂`` held) are one experiment: their normalised results agree to the solver's tolerance and their
dimensional ones scale exactly (pressures by ``qm/k``, volumes by ``k³``, voltages by ``m√(q/e)`` for the zone radius
times ``k``, thickness ``m``, shear modulus ``q`` and permittivity ``e``). Any disagreement is a hidden dimensional
constant, a unit conversion, or a tolerance in absolute units (helper-102: the ramp's voltages were rounded to 10
decimals of a kV).

``p̂atm = Patm A/(μH)`` does change the physics: the chamber's gas gets stiffer with it (a very soft, thin membrane
under one atmosphere: ``μ`` = 1 Pa and ``H`` = 10 µm give 2e8). Up to :data:`~coexist.scene_format.
MAX_ATMOSPHERIC_PRESSURE_HAT` the ramp must finish, converged, with its pressures, volumes and transition voltages as
accurate as at the tricircle's 96 (helper-102: its pressure was the gas's, 5e-3 off at 2e8; its gradient flow stalled
at 1e9, for two zones from 1e7, at 3e8 for one inner-circle zone; its equal free energy lost digits to the gas's free
energy); above it the scene is refused, naming the bound and the field.
"""

import math

import numpy as np
import pytest

from coexist.effects import GasChamber, x_minus_log1p
from coexist.errors import SceneError
from coexist.scene import parse_scene
from coexist.scene_format import MAX_ATMOSPHERIC_PRESSURE_HAT
from coexist.simulation import Simulation

#: the tricircle scene (Li et al. 2013) in SI units, with a coarse ramp (20 steps up)
TRICIRCLE = dict(
    mu=45e3,
    eps_r=4.7,
    H=0.5e-3,
    A=21.4165e-3,
    jlim=97.0,
    count=3,
    Vc=300e-6,
    p_close=2000.0,
    p_atm=101325.0,
    stop=5000.0,
    step=250.0,
    pattern="",
)


def scene_text(mu, eps_r, H, A, jlim, count, Vc, p_close, p_atm, stop, step, pattern) -> str:
    material = f'material = "gent"\njlim = {jlim!r}' if jlim else 'material = "neo-hookean"'
    return f"""
[membrane]
{material}
shear_modulus_Pa = {mu!r}
relative_permittivity = {eps_r!r}
thickness_m = {H!r}
zone_radius_m = {A!r}
wrinkling = "tension-field"
[zones]
count = {count}
[chamber]
volume_m3 = {Vc!r}
closing_pressure_Pa = {p_close!r}
atmospheric_pressure_Pa = {p_atm!r}
[voltage]
start_V = 0.0
stop_V = {stop!r}
step_V = {step!r}
{pattern}
"""


def scaled(k=1.0, m=1.0, q=1.0, e=1.0, **changes) -> dict:
    """The tricircle's parameters with the zone radius times ``k``, the thickness ``m``, the shear modulus ``q`` and the
    permittivity ``e``, and everything else scaled so that every dimensionless group stays."""
    p = dict(TRICIRCLE, **changes)
    pressure, voltage = q * m / k, m * math.sqrt(q / e)
    p.update(
        mu=p["mu"] * q,
        eps_r=p["eps_r"] * e,
        H=p["H"] * m,
        A=p["A"] * k,
        Vc=p["Vc"] * k**3,
        p_close=p["p_close"] * pressure,
        p_atm=p["p_atm"] * pressure,
        stop=p["stop"] * voltage,
        step=p["step"] * voltage,
    )
    return p


def ramp_dict(params, rtol=None) -> dict:
    from coexist.settings import SolverSettings

    sim = Simulation.from_scene(parse_scene(scene_text(**params)), SolverSettings(rtol=rtol) if rtol else None)
    return sim.ramp().to_dict()


@pytest.fixture(scope="module")
def base_ramp():
    return ramp_dict(TRICIRCLE)


def _rel(a, b):
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    return float(np.max(np.abs(a - b) / np.maximum(np.abs(b), 1e-300))) if a.size else 0.0


# (k, m, q, e): micro (a 21 µm zone, 5 µm thick), large and stiff (1 m, 1 cm, 45 MPa), soft (45 Pa), stiff and
# micro with twice the permittivity, large and soft
SCALINGS = [
    (1e-3, 1e-2, 1.0, 1.0),
    (50.0, 20.0, 1e3, 1.0),
    (1.0, 1.0, 1e-3, 1.0),
    (1e-3, 1e-2, 1e2, 2.0),
    (50, 20, 1e-3, 1),
]


@pytest.mark.parametrize("k, m, q, e", SCALINGS)
def test_ramp_scales_exactly(base_ramp, k, m, q, e):
    """Every state and transition of the scaled ramp is the tricircle's, its dimensional numbers scaled: pole stretches,
    pressures and volumes to 1e-9 (the states' tolerance at rtol 1e-10, measured ≤ 1e-12), voltages of the path to
    1e-13 (they had been rounded to 10 decimals of a kV: 5e-8 off for the soft membrane, q = 1e-3), transition voltages
    to 1e-12 and within their stated errors."""
    got = ramp_dict(scaled(k, m, q, e))
    pressure, volume, voltage = q * m / k, k**3, m * math.sqrt(q / e)
    a, b = base_ramp["steps"], got["steps"]
    assert [s["configuration"] for s in a] == [s["configuration"] for s in b]
    assert _rel([s["voltage_kV"] * voltage for s in a], [s["voltage_kV"] for s in b]) < 1e-13
    on = [(x, y) for x, y in zip(a, b) if x["pole_stretches"] is not None]
    assert len(on) > 30
    assert _rel([x["pole_stretches"] for x, _ in on], [y["pole_stretches"] for _, y in on]) < 1e-9
    assert _rel([x["pressure_mbar"] * pressure for x, _ in on], [y["pressure_mbar"] for _, y in on]) < 1e-9
    assert _rel([x["zone_volumes_ml"] for x, _ in on], [np.array(y["zone_volumes_ml"]) / volume for _, y in on]) < 1e-9
    ta, tb = base_ramp["transitions"], got["transitions"]
    assert [t["event"] for t in ta] == [t["event"] for t in tb] and len(ta) == 5
    for x, y in zip(ta, tb):
        diff = abs(x["voltage_kV"] * voltage - y["voltage_kV"])
        assert diff <= 1e-12 * y["voltage_kV"]
        assert diff <= x["voltage_error_kV"] * voltage + y["voltage_error_kV"]
        assert y["voltage_error_kV"] == pytest.approx(x["voltage_error_kV"] * voltage, rel=0.01)


def test_coexistence_and_shapes_scale_exactly():
    """The coexistence table (its ranges' ends and equal-free-energy states) and the zones' shapes of a micro-scale,
    soft copy are the tricircle's, scaled: voltages by m√q, pressures by qm/k, volumes by k³, lengths by k."""
    from coexist.shapes import profile

    k, m, q = 1e-3, 1e-2, 1e-3
    pressure, volume, voltage = q * m / k, k**3, m * math.sqrt(q)
    sims = [Simulation.from_scene(parse_scene(scene_text(**p))) for p in (TRICIRCLE, scaled(k, m, q))]
    entries = [sim.coexistence([1])[0] for sim in sims]
    (ea,), (eb,) = ([c for c in e.crossings if c.from_label != c.to_label] for e in entries)
    assert ea.phi_hat == pytest.approx(eb.phi_hat, rel=1e-12)
    sa, sb = ea.state_after, eb.state_after
    np.testing.assert_allclose(sb.pole_stretch, sa.pole_stretch, rtol=1e-10)
    sc = [s.scene for s in sims]
    assert sc[0].pressure(sa.p_hat) * pressure == pytest.approx(sc[1].pressure(sb.p_hat), rel=1e-10)
    assert sc[0].volume(sa.v_hat[-1]) * volume == pytest.approx(sc[1].volume(sb.v_hat[-1]), rel=1e-10)
    assert sc[0].voltage_of(ea.phi_hat) * voltage == pytest.approx(sc[1].voltage_of(eb.phi_hat), rel=1e-12)
    ranges = [[(seg.phi_range, seg.label) for seg in e.segments] for e in entries]
    assert [x[1] for x in ranges[0]] == [x[1] for x in ranges[1]] and ranges[0]
    np.testing.assert_allclose([x[0] for x in ranges[1]], [x[0] for x in ranges[0]], rtol=1e-12)
    # the bulged zone's profile: lengths in units of A
    pa, pb = (
        profile(sim.model, s.pole_stretch[-1], s.phi_hat, zone_radius=sim.scene.zone_radius, points=11)
        for sim, s in zip(sims, (sa, sb))
    )
    np.testing.assert_allclose(pb.z_hat, pa.z_hat, rtol=1e-10, atol=1e-13)
    assert pa.apex_height_hat == pytest.approx(pb.apex_height_hat, rel=1e-10)


# --- a stiff gas: the normalised atmospheric pressure -----------------------------------------------------------------
def at_patm_hat(patm_hat, **changes) -> dict:
    """The tricircle (with ``changes``) with every group kept but ``p̂atm``: the shear modulus set so that one
    atmosphere is ``patm_hat`` (``μ`` = 1 Pa, ``H`` = 10 µm is ``p̂atm`` = 2.2e8 at ``A`` = 21 mm)."""
    base = dict(TRICIRCLE, **changes)
    now = base["p_atm"] * base["A"] / (base["mu"] * base["H"])
    p = scaled(q=now / patm_hat, **changes)
    p["p_atm"] = base["p_atm"]
    return p


def _transitions(d):
    """``(event, Φ̂, error in Φ̂)`` of each transition of a ramp's dict."""
    scale = d["scene"]["dimensionless_groups"]["voltage_scale_V"] / 1e3
    return [(t["event"], t["voltage_kV"] / scale, t["voltage_error_kV"] / scale) for t in d["transitions"]]


def test_stiff_gas_pressures_stay_converged():
    """At p̂atm = 2.2e8 (μ = 1 Pa, H = 10 µm under one atmosphere) the ramp's pressures agree with a run at rtol 1e-12
    to 1e-8, as its volumes do. The reported pressure was the gas's, ``n̂/(V̂c + ΣV̂) − p̂atm``, which turns the volumes'
    error into ``c ΣδV̂`` (``c ≈ p̂atm/(V̂c + ΣV̂)``): 5.5e-3 off; the zone's own pressure is accurate."""
    p = at_patm_hat(2.2e8)
    loose, tight = ramp_dict(p), ramp_dict(p, rtol=1e-12)
    pairs = [(x, y) for x, y in zip(loose["steps"], tight["steps"]) if x["pole_stretches"] is not None]
    assert len(pairs) > 30
    assert _rel([x["pressure_mbar"] for x, _ in pairs], [y["pressure_mbar"] for _, y in pairs]) < 1e-8
    assert _rel([x["zone_volumes_ml"] for x, _ in pairs], [y["zone_volumes_ml"] for _, y in pairs]) < 1e-8
    for (ea, xa, da), (eb, xb, db) in zip(_transitions(loose), _transitions(tight)):
        assert ea == eb and abs(xa - xb) <= da + db


def inner_circle_at(patm_hat) -> dict:
    """The built-in inner-circle scene (one patterned zone) with every group kept but ``p̂atm``, as a ramp's dict."""
    from coexist.scene import load_scene

    sc = load_scene("inner-circle")
    q = sc.atmospheric_pressure_hat / patm_hat
    text = builtin_text_scaled("inner-circle", q)
    return Simulation.from_scene(parse_scene(text)).ramp().to_dict()


def builtin_text_scaled(name, q) -> str:
    """A built-in scene's text with the shear modulus times ``q`` and the closing pressure and voltages scaled to keep
    their normalised values (the atmospheric pressure kept: ``p̂atm`` divided by ``q``), the ramp's step 12.5 times
    coarser."""
    import re

    from coexist.scene import builtin_scene_text

    text = builtin_scene_text(name)

    def times(key, factor):
        nonlocal text
        pattern = re.compile(rf"^({key}\s*=\s*)([0-9.eE+-]+)", re.M)
        assert pattern.search(text), key
        text = pattern.sub(lambda m: f"{m.group(1)}{float(m.group(2)) * factor!r}", text)

    times("shear_modulus_kPa", q)
    times("closing_pressure_mbar", q)
    times("stop_kV", math.sqrt(q))
    times("step_kV", math.sqrt(q) * 12.5)  # a coarse ramp: 0.25 kV
    assert "atmospheric_pressure" not in text or "atmospheric_pressure_kPa = 101.325" in text
    return text


@pytest.mark.parametrize("patm_hat, changes", [(1e9, {}), (1e9, {"count": 2}), (3e8, "inner-circle")])
def test_stiff_gas_ramp_lands(patm_hat, changes):
    """The ramp on a stiff gas finishes with the transitions it has on a softer one (p̂atm = 1e7; the same Φ̂ to 2e-6,
    the gas's compressibility apart), each located to 1e-8 of its voltage. Each case stalled before
    ("the gradient flow did not settle"): the flow's tolerance (1e-8 p̂) below the gas pressure's rounding (three zones
    at 1e9); an integration whose long steps damped the slow escape from a saddle (two zones at 1e9 leaving the fold of
    1 of 2 bulged on the way down: numerics.stiff's step cap); the push of a lost state that lies, on the interpolated
    zone curve, past its volume fold (the inner-circle zone at 3e8: it snaps at fixed volume)."""
    if changes == "inner-circle":
        stiff, soft = inner_circle_at(patm_hat), inner_circle_at(1e7)
    else:
        stiff, soft = ramp_dict(at_patm_hat(patm_hat, **changes)), ramp_dict(at_patm_hat(1e7, **changes))
    ts, tf = _transitions(stiff), _transitions(soft)
    assert [t[0] for t in ts] == [t[0] for t in tf] and len(ts) >= 4
    for (_, x, err), (_, y, _) in zip(ts, tf):
        assert x == pytest.approx(y, rel=2e-6)
        assert err < 1e-8 * x


def test_stiff_gas_equal_free_energy_keeps_its_digits():
    """At p̂atm = 1e9 the equal-free-energy voltage keeps the accuracy it has at the tricircle's 96: its error under
    5e-9 of it, and it agrees with a run at rtol 1e-12 within the errors. The gas's free energy, ``−n̂ ln(1 + ΣV̂/V̂c) +
    p̂atm ΣV̂``, was a difference of two numbers of the size ``p̂atm ΣV̂``: its rounding had made that error 1e-5, and
    the tight run did not converge ("equal free energy did not converge")."""
    p = at_patm_hat(1e9)
    loose, tight = ramp_dict(p), ramp_dict(p, rtol=1e-12)
    (a,) = [t for t in _transitions(loose) if t[0] == "equal_free_energy"]
    (b,) = [t for t in _transitions(tight) if t[0] == "equal_free_energy"]
    assert a[2] < 5e-9 * a[1]
    assert abs(a[1] - b[1]) <= a[2] + b[2]


def test_gas_free_energy_without_cancellation():
    """``y − log1p(y)`` to a few ulps against 60-digit decimals, and the gas's free energy a potential of its pressure
    (``dG/dΣV̂ = −p̂``) that is small where the gas is stiff (``≈ T p̂²/(2(p̂atm + p̂))``, not ``p̂atm ΣV̂``)."""
    from decimal import Decimal, getcontext

    getcontext().prec = 60
    ys = np.concatenate([np.linspace(-0.99, 3.0, 401), np.geomspace(1e-12, 0.3, 60), -np.geomspace(1e-12, 0.3, 60)])
    exact = np.array([float(Decimal(float(y)) - (1 + Decimal(float(y))).ln()) for y in ys])
    assert _rel(x_minus_log1p(ys), exact) < 1e-14
    assert isinstance(x_minus_log1p(0.1), float)
    for patm in (96.4, 1e9):
        gas = GasChamber.closed_at(30.5, patm, 1.9, 6.9)
        h = 1e-6  # the old form's rounding, ~1e-6 at 1e9, is then ~1 in the slope
        slope = (gas.free_energy(6.9 + h) - gas.free_energy(6.9 - h)) / (2 * h)
        assert slope == pytest.approx(-float(gas.pressure(6.9)), rel=1e-6)
    total = 37.4
    assert gas.free_energy(6.9) == pytest.approx(total * 1.9**2 / (2 * (1e9 + 1.9)), rel=1e-6)


def test_too_large_a_normalised_atmospheric_pressure_is_refused():
    """Above :data:`MAX_ATMOSPHERIC_PRESSURE_HAT` (1e10) the scene is refused up front, naming the field, the value and
    the bound; at it the scene loads."""
    ok = at_patm_hat(0.999 * MAX_ATMOSPHERIC_PRESSURE_HAT)
    assert parse_scene(scene_text(**ok)).atmospheric_pressure_hat == pytest.approx(0.999e10)
    with pytest.raises(SceneError) as info:
        parse_scene(scene_text(**at_patm_hat(3e10)))
    text = str(info.value)
    assert "[chamber].atmospheric_pressure_Pa" in text and "3e+10" in text and "1e+10" in text


def test_cli_refuses_it_with_exit_2(tmp_path):
    from click.testing import CliRunner

    from coexist.cli.main import cli

    path = tmp_path / "soft.toml"
    path.write_text(scene_text(**at_patm_hat(2e10)))  # μ = 0.5 mPa: p̂atm = 2e10 at one atmosphere
    result = CliRunner().invoke(cli, ["ramp", str(path), "--json"])
    assert result.exit_code == 2 and "Traceback" not in result.output
    (line,) = [x for x in result.output.splitlines() if x.startswith("Error:")]
    assert "[chamber].atmospheric_pressure_Pa" in line and "p̂atm" in line and "1e+10" in line


def test_micro_scale_table_keeps_its_digits():
    """The ramp's table and transition voltages keep four digits of a scene 1000 times smaller (voltages of 1e-3 kV,
    volumes of 1e-8 ml): they had all been ``0.000``."""
    from coexist.cli.common import column_format, format_voltage

    assert column_format([0.0, 2.25e-8, 4.9e-8], 4)(2.25e-8) == "2.250e-08"
    assert column_format([0.0, 20.0, 49.1], 6)(20.0) == "20.0000"
    assert format_voltage(3.9000308580, 4.6e-9) == "3.900030858 kV ± 5e-09"
    assert format_voltage(1.2332980e-3, 1.4e-12).startswith("0.001233298000")
