"""Dimensional scale invariance of patterned scenes, sweeps, fits and CSV outputs (review, helper-104).

As in ``tests/test_scale_invariance.py`` (the uniform tricircle), a scene whose zone radius is times ``k``, thickness
``m``, shear modulus ``q`` and permittivity ``e``, with its chamber times ``k³``, its pressures times ``qm/k``, its
voltages times ``m√(q/e)`` and its breakdown field times ``√(q/e)``, shares every dimensionless group with the
original: it is one experiment, so the JSON of every command agrees once its dimensional numbers are scaled back
(lengths by ``k``, curvatures by ``1/k``, volumes by ``k³``, pressures by ``qm/k``, voltages by ``m√(q/e)``, fields
by ``√(q/e)``). Here on the built-in inner-circle scene (an electrode disc, a two-layer passive annulus) and its
variants: a ring electrode, one to three layers, every region's layers given, wrinkling refused and relaxed
(tension-field states with wrinkled bands), several zones on one gas, a controlled pressure, a breakdown field, a list
of voltages. Tolerances: states (stretches, pressures, volumes, profiles) to 1e-9 relative, the solver's rtol 1e-10
giving ≤ 1e-12 measured; transition voltages within the sum of their stated errors (measured by relocating at
rtol/100; the two runs differ by ≤ 4e-10 of the voltage, ~1e-9 stated).

Measured over 15 variants × 8 scalings (micro k = 1e-3, m = 1e-2; big k = 50, m = 20, q = 1e3; soft q = 1e-3; twice
the permittivity; nano k = 1e-6, m = 1e-5; giant k = m = q = 1e3; q = 1e-6; e = 1e3) with ``ramp`` (also
``--shapes``), ``coexistence``, ``shape``, ``sweep`` (netCDF), ``fit`` (and its sensitivity table) and ``curves
--csv``: every state ≤ 3e-12, every transition within its errors. The one defect was in the text: ``coexist fit``
printed the fitted radius with at most 15 decimals of a mm, 9 of its 11 digits for a 200 nm zone.
"""

import json
import math
import re

import numpy as np
import pytest
from click.testing import CliRunner

from coexist.cli.main import cli

#: the built-in inner-circle scene (Li et al. 2013, Fig. 3(d)) in SI units, ramped in 20 steps up
INNER_CIRCLE = dict(
    mu=45e3,
    eps_r=4.7,
    H=0.5e-3,
    A=32.5e-3,
    jlim=97.0,
    count=1,
    Vc=300e-6,
    p_close=1600.0,
    p_atm=101325.0,
    stop=5000.0,
    step=250.0,
    wrinkling="refuse",
    pattern="inner-circle",
    inner=0.5,
    outer=None,
    passive=2,
    regions=None,
    p_ctrl=None,
    Eb=None,
    values=None,
)
#: a higher closing pressure and voltage where the ring and the three-layer annulus leave their range
HIGHER = dict(p_close=1720.0, stop=8000.0, step=400.0)
VARIANTS = {
    "inner-circle": {},
    "three zones, tension-field, wrinkled states": dict(
        count=3, wrinkling="tension-field", values=[0.0, 3000.0, 4300.0, 4302.0, 3000.0, 0.0]
    ),
    "ring, tension-field": dict(pattern="ring", inner=0.3, outer=0.7, wrinkling="tension-field", **HIGHER),
    "two zones, three layers (a merge)": dict(count=2, passive=3, **HIGHER),
    "ring, layers by region": dict(pattern="ring", inner=0.3, outer=0.7, passive=None, regions=[3, 1, 2], **HIGHER),
    "one layer, pressure controlled": dict(passive=1, p_ctrl=1300.0),
    "breakdown": dict(count=3, Eb=30e6),
}
#: (k, m, q, e)
SCALINGS = {
    "micro": (1e-3, 1e-2, 1.0, 1.0),
    "big": (50.0, 20.0, 1e3, 1.0),
    "soft": (1.0, 1.0, 1e-3, 1.0),
    "permittivity": (1e-3, 1e-2, 1e2, 2.0),
}


def scene_text(p) -> str:
    material = f'material = "gent"\njlim = {p["jlim"]!r}' if p["jlim"] else 'material = "neo-hookean"'
    breakdown = f"breakdown_field_V_per_m = {p['Eb']!r}" if p["Eb"] else ""
    electrodes = f'[electrodes]\npattern = "{p["pattern"]}"\ninner_fraction = {p["inner"]!r}\n'
    if p["outer"] is not None:
        electrodes += f"outer_fraction = {p['outer']!r}\n"
    electrodes += (
        f"[layers]\nregions = {list(p['regions'])!r}\n" if p["regions"] else f"[layers]\npassive = {p['passive']}\n"
    )
    if p["p_ctrl"]:
        chamber = f"pressure_Pa = {p['p_ctrl']!r}"
    else:
        chamber = (
            f"[chamber]\nvolume_m3 = {p['Vc']!r}\nclosing_pressure_Pa = {p['p_close']!r}\n"
            f"atmospheric_pressure_Pa = {p['p_atm']!r}"
        )
    voltage = (
        f"values_V = {[float(x) for x in p['values']]!r}"
        if p["values"]
        else f"start_V = 0.0\nstop_V = {p['stop']!r}\nstep_V = {p['step']!r}"
    )
    return f"""
[membrane]
{material}
shear_modulus_Pa = {p["mu"]!r}
relative_permittivity = {p["eps_r"]!r}
thickness_m = {p["H"]!r}
zone_radius_m = {p["A"]!r}
wrinkling = "{p["wrinkling"]}"
{breakdown}
{electrodes}
[zones]
count = {p["count"]}
{chamber}
[voltage]
{voltage}
"""


def scaled(p, k=1.0, m=1.0, q=1.0, e=1.0) -> dict:
    """``p`` with the zone radius times ``k``, the thickness ``m``, the shear modulus ``q``, the permittivity ``e``,
    and every other dimensional input scaled so that every dimensionless group stays."""
    pressure, voltage = q * m / k, m * math.sqrt(q / e)
    out = dict(p)
    out.update(
        mu=p["mu"] * q,
        eps_r=p["eps_r"] * e,
        H=p["H"] * m,
        A=p["A"] * k,
        Vc=p["Vc"] * k**3,
        p_close=p["p_close"] * pressure,
        p_atm=p["p_atm"] * pressure,
        stop=p["stop"] * voltage,
        step=p["step"] * voltage,
        p_ctrl=p["p_ctrl"] and p["p_ctrl"] * pressure,
        Eb=p["Eb"] and p["Eb"] * math.sqrt(q / e),
        values=p["values"] and [x * voltage for x in p["values"]],
    )
    return out


def factors(k, m, q, e) -> dict:
    """What each unit suffix of a JSON key scales by."""
    voltage, pressure = m * math.sqrt(q / e), q * m / k
    return {"kV": voltage, "V": voltage, "mbar": pressure, "Pa": pressure, "ml": k**3, "m3": k**3, "mm": k}


def unit_of(key: str):
    if key.endswith("V_per_m"):
        return "field"
    if key.endswith("per_m"):
        return "per_m"
    return next((u for u in ("kV", "mbar", "Pa", "ml", "m3", "mm", "V") if key.endswith("_" + u)), None)


def scale_of(unit, k, m, q, e) -> float:
    if unit == "field":
        return math.sqrt(q / e)
    if unit == "per_m":
        return 1 / k
    return 1.0 if unit is None else factors(k, m, q, e)[unit]


_NUMBER = re.compile(r"[-+]?(\d+\.?\d*|\.\d+)([eE][-+]?\d+)?")


def assert_scaled(a, b, scale, path="", unit=None, rtol=1e-9) -> float:
    """``b`` is ``a`` with its dimensional numbers scaled (``scale(unit)``): the same keys, lengths, labels and flags,
    every number to ``rtol`` (relative; errors and residuals only in their size), texts equal once their numbers are
    set aside. Returns the largest relative difference of a number."""
    worst = 0.0
    if isinstance(a, dict):
        assert isinstance(b, dict) and set(a) == set(b), (path, sorted(set(a) ^ set(b)))
        for key in a:
            if key not in ("scene", "source"):
                worst = max(worst, assert_scaled(a[key], b[key], scale, f"{path}.{key}", unit_of(key) or unit, rtol))
    elif isinstance(a, list):
        assert isinstance(b, list) and len(a) == len(b), (path, len(a), len(b))
        for i, (x, y) in enumerate(zip(a, b)):
            worst = max(worst, assert_scaled(x, y, scale, f"{path}[{i}]", unit, rtol))
    elif isinstance(a, str):
        assert _NUMBER.sub("#", a) == _NUMBER.sub("#", b), (path, a, b)
    elif isinstance(a, bool) or a is None:
        assert a == b, (path, a, b)
    else:
        leaf = path.rsplit(".", 1)[-1].split("[")[0]
        x, y = a * scale(unit), b
        if "residual" in leaf:
            assert abs(a) < 1e-7 and abs(b) < 1e-7, (path, a, b)
        elif "error" in leaf:
            assert (x == 0) == (y == 0) and (x == 0 or 0.05 < y / x < 20), (path, x, y)
        else:
            rel = abs(x - y) / max(abs(x), abs(y)) if x != y else 0.0
            assert rel <= rtol, (path, a, b, rel)
            worst = max(worst, rel)
    return worst


def run_json(tmp_path, name, params, *args) -> dict:
    path = tmp_path / f"{name}.toml"
    path.write_text(scene_text(params), encoding="utf-8")
    res = CliRunner().invoke(cli, [args[0], str(path), *args[1:]])
    assert res.exit_code == 0, res.output
    return json.loads(res.stdout)


def assert_transitions_agree(ta, tb, voltage):
    """The same transitions, each voltage within the sum of the two stated errors (and to 1e-8 of itself)."""
    assert [(t["kind"], t["event"], t["from"], t["to"]) for t in ta] == [
        (t["kind"], t["event"], t["from"], t["to"]) for t in tb
    ]
    for x, y in zip(ta, tb):
        diff = abs(x["voltage_kV"] * voltage - y["voltage_kV"])
        assert diff <= x["voltage_error_kV"] * voltage + y["voltage_error_kV"], (x, y)
        assert diff <= 1e-8 * y["voltage_kV"]


RAMP_CASES = [
    ("inner-circle", "micro"),
    ("inner-circle", "big"),
    ("three zones, tension-field, wrinkled states", "soft"),
    ("ring, tension-field", "permittivity"),
    ("two zones, three layers (a merge)", "big"),
    ("ring, layers by region", "micro"),
    ("one layer, pressure controlled", "soft"),
    ("breakdown", "permittivity"),
]


@pytest.mark.parametrize("variant, scaling", RAMP_CASES)
def test_patterned_ramp_scales_exactly(tmp_path, variant, scaling):
    """``coexist ramp --json --shapes`` of a patterned scene and of its scaled copy: every state (stretches, pressures,
    volumes, apex heights and curvatures, electrode edges, 41-point profiles, wrinkled bands and area fractions,
    fields) to 1e-9 (measured ≤ 3e-12), the same transitions within their stated errors."""
    k, m, q, e = SCALINGS[scaling]
    base = dict(INNER_CIRCLE, **VARIANTS[variant])
    a = run_json(tmp_path, "a", base, "ramp", "--json", "--shapes")
    b = run_json(tmp_path, "b", scaled(base, k, m, q, e), "ramp", "--json", "--shapes")
    assert_scaled(
        {key: a[key] for key in a if key != "transitions"},
        {key: b[key] for key in b if key != "transitions"},
        lambda u: scale_of(u, k, m, q, e),
    )
    assert_transitions_agree(a["transitions"], b["transitions"], m * math.sqrt(q / e))
    assert len(a["transitions"]) >= 1 and sum(s["pole_stretches"] is not None for s in a["steps"]) >= 4
    if "wrinkled" in variant:  # wrinkled states are among those compared
        assert any(f > 0 for s in a["steps"] for f in (s.get("wrinkled_area_fraction") or []))


@pytest.fixture(scope="module")
def three_zone_coexistence(tmp_path_factory):
    folder = tmp_path_factory.mktemp("coexistence")
    return run_json(folder, "a", dict(INNER_CIRCLE, count=3), "coexistence", "--json", "--bulged", "1")


@pytest.mark.parametrize("k, m, q, e", [(1e-3, 1e-2, 1e-3, 1.0), (50.0, 20.0, 1e3, 2.0)])
def test_patterned_coexistence_scales_exactly(tmp_path, three_zone_coexistence, k, m, q, e):
    """``coexist coexistence --json`` of three inner-circle zones and of a scaled copy (micro and soft; big, stiff,
    twice the permittivity): the ranges' ends and the equal free energy within their stated errors, the coexisting
    states (pressure, volumes, pole stretches) to 1e-9 (measured ≤ 3e-12)."""
    a = three_zone_coexistence
    b = run_json(
        tmp_path, "b", scaled(dict(INNER_CIRCLE, count=3), k, m, q, e), "coexistence", "--json", "--bulged", "1"
    )
    voltage = m * math.sqrt(q / e)
    assert_scaled(a, b, lambda u: scale_of(u, k, m, q, e), rtol=1e-8)
    (ca,), (cb,) = a["configurations"], b["configurations"]
    ends = [
        (x[f"{end}_kV"], x[f"{end}_error_kV"], y[f"{end}_kV"], y[f"{end}_error_kV"])
        for x, y in zip(ca["stable_ranges"], cb["stable_ranges"])
        for end in ("from", "to")
    ]
    crossings = [
        (x["voltage_kV"], x["voltage_error_kV"], y["voltage_kV"], y["voltage_error_kV"])
        for x, y in zip(ca["equal_free_energy"], cb["equal_free_energy"])
    ]
    assert ends and crossings
    for va, ea, vb, eb in ends + crossings:
        assert abs(va * voltage - vb) <= ea * voltage + eb
    for x, y in zip(ca["equal_free_energy"], cb["equal_free_energy"]):
        for key in ("bulged_pole_stretch", "unbulged_pole_stretch"):
            assert y[key] == pytest.approx(x[key], rel=1e-9)


@pytest.fixture(scope="module")
def inner_circle_shapes(tmp_path_factory):
    return run_json(
        tmp_path_factory.mktemp("shape"),
        "a",
        INNER_CIRCLE,
        "shape",
        "--json",
        "--points",
        "9",
        "--voltage-kV",
        "0,1,2,3,4,4.2,4.5",
    )


@pytest.mark.parametrize("scaling", list(SCALINGS))
def test_patterned_zone_shapes_scale_exactly(tmp_path, inner_circle_shapes, scaling):
    """``coexist shape`` of the inner-circle zone (its own path on the gas, up to its snap-through, bisected):
    profiles, apex heights and curvatures, electrode edges, the lens ratio and the end's voltage bracket scaled to
    1e-9 (measured ≤ 1e-14)."""
    k, m, q, e = SCALINGS[scaling]
    voltage = m * math.sqrt(q / e)
    kv = ",".join(repr(x * voltage) for x in (0, 1, 2, 3, 4, 4.2, 4.5))
    b = run_json(
        tmp_path, "b", scaled(INNER_CIRCLE, k, m, q, e), "shape", "--json", "--points", "9", "--voltage-kV", kv
    )
    a = inner_circle_shapes
    assert_scaled(a, b, lambda u: scale_of(u, k, m, q, e))
    assert a["end"]["kind"] == "snap-through" and len(a["voltages"][0]["groups"][0]["profile"]["r_mm"]) == 9


def _sweep(tmp_path, name, params, vary):
    import xarray as xr

    path, out = tmp_path / f"{name}.toml", tmp_path / f"{name}.nc"
    path.write_text(scene_text(params), encoding="utf-8")
    res = CliRunner().invoke(
        cli, ["sweep", str(path), "--workers", "1", "-o", str(out), *sum((["--vary", v] for v in vary), [])]
    )
    assert res.exit_code == 0, res.output
    return xr.load_dataset(out), res.stdout


def test_patterned_sweep_scales_exactly(tmp_path):
    """``coexist sweep`` of three inner-circle zones at 16 mbar (one point, its closing pressure and passive layers
    swept) and of a big, stiff copy (k = 50, m = 20, q = 1e3) at 16 mbar times qm/k: every voltage of the netCDF
    scaled within its stated errors (and to 1e-8), the status and the configurations equal; its table prints seven
    significant figures."""
    k, m, q, e = SCALINGS["big"]
    voltage, pressure = m * math.sqrt(q / e), q * m / k
    base = dict(INNER_CIRCLE, count=3)
    a, _ = _sweep(tmp_path, "a", base, ["chamber.closing_pressure_mbar=16.0", "layers.passive=2"])
    b, table = _sweep(
        tmp_path,
        "b",
        scaled(base, k, m, q, e),
        [f"chamber.closing_pressure_mbar={16.0 * pressure!r}", "layers.passive=2"],
    )
    np.testing.assert_allclose(b["chamber_closing_pressure_mbar"].values, a["chamber_closing_pressure_mbar"] * pressure)
    assert a["status"].values.ravel().tolist() == b["status"].values.ravel().tolist() == ["bulges"]
    checked = 0
    for var in a.data_vars:
        if a[var].dtype.kind != "f":
            assert a[var].values.tolist() == b[var].values.tolist() or var == "reason", var
            continue
        if var.endswith("_error_kV"):  # an error: of the same size
            x, y = a[var].values * voltage, b[var].values
            assert (np.isnan(x) == np.isnan(y)).all() and np.all((np.isnan(x)) | ((y > 0.05 * x) & (y < 20 * x))), var
            continue
        if not var.endswith("_kV"):
            np.testing.assert_allclose(b[var].values, a[var].values, rtol=1e-9, err_msg=var)
            continue
        x, y = a[var].values * voltage, b[var].values
        assert (np.isnan(x) == np.isnan(y)).all(), var
        error = f"{var[:-3]}_error_kV"
        if error in a:  # an event: within the sum of the stated errors
            slack = np.nan_to_num(a[error].values * voltage + b[error].values)
            assert (np.isnan(x) | (np.abs(x - y) <= slack)).all(), (var, x, y, slack)
        assert (np.isnan(x) | (np.abs(x - y) <= 1e-8 * np.abs(y))).all(), (var, x, y)
        checked += int((~np.isnan(x)).sum())
    assert checked >= 6
    row = table.splitlines()[1].split()
    assert float(row[2]) == pytest.approx(float(b["spinodal_up_kV"].values.ravel()[0]), rel=1e-6)


def test_patterned_fit_radius_scales_exactly():
    """The zone radius fitted (:func:`coexist.fit.fit_zone_radius`, what ``coexist fit`` runs) so that three
    inner-circle zones have their spinodal at 2.8 kV, and so that a micro-scale soft copy (k = 1e-3, m = 1e-2,
    q = 1e-3) has it at 2.8 kV times m√q: the second is the first times k within the two stated errors (and to
    1e-9), as is the transition located there."""
    from dataclasses import replace

    from coexist.fit import Shared, fit_zone_radius, fitted_radius_error, transition_voltage
    from coexist.scene import parse_scene

    k, m, q, e = 1e-3, 1e-2, 1e-3, 1.0
    voltage = m * math.sqrt(q / e)
    out = []
    for params, target in (
        (dict(INNER_CIRCLE, count=3), 2800.0),
        (scaled(dict(INNER_CIRCLE, count=3), k, m, q, e), 2800.0 * voltage),
    ):
        sc = parse_scene(scene_text(params))
        shared = Shared.of(sc)
        fitted = replace(sc, zone_radius=fit_zone_radius(sc, target, "spinodal", shared))
        volts, err = transition_voltage(fitted, "spinodal", shared, measure=True)
        out.append(
            (fitted.zone_radius, fitted_radius_error(fitted, "spinodal", shared, volts, err, target), volts, err)
        )
    (ra, ea, va, da), (rb, eb, vb, db) = out
    assert abs(ra * k - rb) <= ea * k + eb and abs(ra * k - rb) <= 1e-9 * rb
    assert eb == pytest.approx(ea * k, rel=0.5) and 0 < eb < 1e-9 * rb
    assert abs(va * voltage - vb) <= da * voltage + db


def test_fitted_radius_text_keeps_its_digits_at_any_scale():
    """The fitted radius is printed with the decimals its error supports at any scale. They were capped at 15
    decimals of a mm: a 200 nm zone (the tricircle scaled by k = 1e-8, ``coexist fit`` to 4e-7 kV) printed
    ``0.000000213548077 ± 3e-17 mm``, 9 of the 11 digits the 21 mm original shows."""
    from coexist.cli.fit import _radius_text

    assert _radius_text(21.354807707716105, 3.06e-12) == "21.354807708 ± 3e-09 mm"  # unchanged
    assert _radius_text(2.1354807707716105e-7, 3.06e-20) == "0.00000021354807708 ± 3e-17 mm"
    assert _radius_text(2.1354807707716105e5, 3.06e-8) == "213548.07708 ± 3e-05 mm"
    # never more digits than a float holds (17 significant figures)
    assert _radius_text(2.1354807707716105e5, 3.06e-20) == "213548.07707716106 ± 3e-17 mm"
    assert _radius_text(2.1354807707716105e-9, 1e-30) == "0.0000000021354807707716107 ± 1e-27 mm"


def test_patterned_curves_csv_is_scale_free(tmp_path):
    """``coexist curves --scene`` takes only the material and the pattern from a scene, so a scaled copy's CSV is the
    same text, written with every digit (``repr``)."""
    base = dict(INNER_CIRCLE, wrinkling="tension-field")
    texts = []
    for name, params in (("a", base), ("b", scaled(base, *SCALINGS["micro"])), ("c", scaled(base, *SCALINGS["big"]))):
        path = tmp_path / f"{name}.toml"
        path.write_text(scene_text(params), encoding="utf-8")
        res = CliRunner().invoke(
            cli, ["curves", "--scene", str(path), "--points", "9", "--csv", "-", "--phi-hat", "0,0.2", "--p-hat", "1.5"]
        )
        assert res.exit_code == 0, res.output
        texts.append(res.stdout)
    assert texts[0] == texts[1] == texts[2]
    rows = texts[0].splitlines()
    assert len(rows) > 15 and rows[0].startswith("family,fixed_name,fixed_value,pole_stretch")
    assert all(len(x) >= 15 for x in rows[3].split(",")[5:7])  # p̂, V̂ with every digit: 1.7278577947176907, ...
