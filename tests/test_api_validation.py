"""Every public entry point checks its arguments: wrong types, shapes, NaN and out-of-range values raise a
SceneError naming the argument, never a bare TypeError/ValueError/AttributeError from deep inside."""

import numpy as np
import pytest

import coexist
from coexist import CoexistError, SceneError
from coexist.coexistence import maxwell_coexistence, phase_diagram
from coexist.curves import pressure_volume_curve, voltage_at_pressure, voltage_charge_curve
from coexist.effects import Breakdown, GasChamber, Gent, PressureReservoir
from coexist.fit import fit_zone_radius, sensitivity, transition_voltage
from coexist.model import MembraneModel, build_model
from coexist.scene import load_scene, parse_scene
from coexist.settings import SolverSettings
from coexist.shooting import solve_states
from coexist.simulation import Simulation, equilibria_on_gas, simulate_ramp

M = MembraneModel()
NAN = float("nan")

CASES = [
    ("MembraneModel(elasticity='gent')", lambda: MembraneModel(elasticity="gent"), "elasticity"),
    ("MembraneModel(prestretch='2')", lambda: MembraneModel(prestretch="2"), "prestretch"),
    ("MembraneModel(prestretch=nan)", lambda: MembraneModel(prestretch=NAN), "prestretch"),
    ("Gent(True)", lambda: Gent(True), "jlim"),
    ("Gent(-1)", lambda: Gent(-1), "jlim"),
    ("GasChamber(True, 1, 1)", lambda: GasChamber(True, 1.0, 1.0), "chamber_volume"),
    ("GasChamber(1, nan, 1)", lambda: GasChamber(1.0, NAN, 1.0), "atmospheric_pressure"),
    ("PressureReservoir(nan)", lambda: PressureReservoir(NAN), "pressure_hat"),
    ("Breakdown(0)", lambda: Breakdown(0.0), "breakdown_field"),
    ("SolverSettings(rtol='a')", lambda: SolverSettings(rtol="a"), "rtol"),
    ("SolverSettings(rtol=nan)", lambda: SolverSettings(rtol=NAN), "rtol"),
    ("SolverSettings(candidate_samples=0)", lambda: SolverSettings(candidate_samples=0), "candidate_samples"),
    ("SolverSettings(curve_points=2.5)", lambda: SolverSettings(curve_points=2.5), "curve_points"),
    ("SolverSettings(error_estimates=1)", lambda: SolverSettings(error_estimates=1), "error_estimates"),
    ("solve_states(None, 2, 0)", lambda: solve_states(None, [2.0], 0.0), "model"),
    ("solve_states(m, 'x', 0)", lambda: solve_states(M, "x", 0.0), "pole_stretch"),
    ("solve_states(m, [2, 3], [.1, .2, .3])", lambda: solve_states(M, [2.0, 3.0], [0.1, 0.2, 0.3]), "pole_stretch"),
    ("solve_states(m, 2, nan)", lambda: solve_states(M, [2.0], NAN), "phi_hat"),
    ("solve_states(m, 2, -0.1)", lambda: solve_states(M, [2.0], -0.1), "phi_hat"),
    ("solve_states(m, [], 0)", lambda: solve_states(M, [], 0.0), "pole_stretch"),
    ("solve_states(m, 2, 0, settings='x')", lambda: solve_states(M, [2.0], 0.0, "x"), "settings"),
    ("pressure_volume_curve(None)", lambda: pressure_volume_curve(None), "model"),
    ("pressure_volume_curve(m, [0.1, 0.2])", lambda: pressure_volume_curve(M, phi_hat=[0.1, 0.2]), "phi_hat"),
    ("pressure_volume_curve(m, nan)", lambda: pressure_volume_curve(M, NAN), "phi_hat"),
    (
        "pressure_volume_curve(m, 0, [1.1, nan, 2])",
        lambda: pressure_volume_curve(M, 0.0, [1.1, NAN, 2]),
        "pole_stretch",
    ),
    ("voltage_charge_curve(m, nan)", lambda: voltage_charge_curve(M, NAN), "p_hat"),
    ("voltage_at_pressure(m, [2], nan)", lambda: voltage_at_pressure(M, [2.0], NAN), "p_hat"),
    ("voltage_at_pressure(m, [2], 0)", lambda: voltage_at_pressure(M, [2.0], 0.0), "p_hat"),
    # second audit: a bad iteration count read as "no voltage holds this pole stretch" (a false reason)
    ("voltage_at_pressure(iterations=0)", lambda: voltage_at_pressure(M, [1.5], 1.0, iterations=0), "iterations"),
    ("voltage_at_pressure(iterations=-1)", lambda: voltage_at_pressure(M, [1.5], 1.0, iterations=-1), "iterations"),
    ("fit_zone_radius(kind='maxwell')", lambda: fit_zone_radius(load_scene("tricircle"), 3900.0, "maxwell"), "kind"),
    ("parse_scene(5)", lambda: parse_scene(5), "text"),
    ("PressureReservoir(-1)", lambda: PressureReservoir(-1.0), "pressure_hat"),
    (
        "GasChamber.closed_at(zones=-0.2)",
        lambda: GasChamber.closed_at(1.0, 1.0, closing_pressure=0.5, zone_volumes_total=-0.2),
        "zone_volumes_total",
    ),
    ("build_model('neo-hookean', jlim=97)", lambda: build_model("neo-hookean", jlim=97.0), "jlim"),
    ("maxwell_coexistence(None)", lambda: maxwell_coexistence(None), "curve"),
    ("phase_diagram(m, 'x', 3)", lambda: phase_diagram(M, "x", 3.0), "phi_values"),
    ("phase_diagram(m, [0.1], nan)", lambda: phase_diagram(M, [0.1], NAN), "pole_stretch_max"),
    ("phase_diagram(m, [0.1], 1.0)", lambda: phase_diagram(M, [0.1], 1.0), "pole_stretch_max"),
    ("load_scene(3)", lambda: load_scene(3), "scene"),
    ("simulate_ramp('tricircle')", lambda: simulate_ramp("tricircle"), "scene"),
    ("Simulation.from_scene(None)", lambda: Simulation.from_scene(None), "scene"),
    ("Simulation.from_scene(sc, 1e-8)", lambda: Simulation.from_scene(load_scene("tricircle"), 1e-8), "settings"),
    (
        "equilibria_on_gas(gas=None)",
        lambda: equilibria_on_gas(M, None, 3, 0.0, SolverSettings(), 4.0),
        "gas",
    ),
    (
        "equilibria_on_gas(zones=0)",
        lambda: equilibria_on_gas(M, PressureReservoir(1.0), 0, 0.0, SolverSettings(), 4.0),
        "zones",
    ),
    ("fit_zone_radius(scene, nan)", lambda: fit_zone_radius(load_scene("tricircle"), NAN), "target_voltage"),
    ("fit_zone_radius('tricircle', 3900)", lambda: fit_zone_radius("tricircle", 3900.0), "scene"),
    ("transition_voltage(None)", lambda: transition_voltage(None), "scene"),
    ("sensitivity(None)", lambda: sensitivity(None), "scene"),
]


@pytest.mark.parametrize("call, field", [(c[1], c[2]) for c in CASES], ids=[c[0] for c in CASES])
def test_bad_arguments_are_scene_errors_naming_the_argument(call, field):
    with pytest.raises(SceneError) as info:
        call()
    assert info.value.field is not None and info.value.field.startswith(field), (info.value.field, str(info.value))


def test_numpy_numbers_are_numbers():
    """A numpy integer or float is accepted wherever a number is (Gent(np.int64(97)) was refused)."""
    assert Gent(np.int64(97)).jlim == 97.0
    assert SolverSettings(rtol=np.float64(1e-8)).rtol == 1e-8
    assert PressureReservoir(np.float32(1.5)).pressure_hat == pytest.approx(1.5)


def test_every_name_of_the_package_resolves():
    """``from coexist import *`` works: every name in ``__all__`` imports (GasChamber once pointed at a module
    that no longer holds it)."""
    for name in coexist.__all__:
        assert getattr(coexist, name) is not None, name


def test_successful_states_carry_no_nan():
    """A valid state has no NaN anywhere: its ``fail_radius`` is ``inf`` (it never fails); a flagged state
    has NaN values and a status that says why."""
    s = solve_states(M, [2.0, 1.5], [0.0, 1.0])
    ok = s.ok
    assert ok.tolist() == [True, False]
    for name, value in vars(s).items():
        if isinstance(value, np.ndarray) and value.dtype.kind == "f":
            assert np.all(np.isfinite(value[ok]) | np.isposinf(value[ok])), name
    assert s.fail_radius[0] == np.inf and s.fail_radius[1] >= 0
    with pytest.raises(CoexistError, match="wrinkles"):
        s.require_ok()
