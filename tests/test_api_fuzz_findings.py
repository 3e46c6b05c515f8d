"""What an adversarial sweep of the Python API found (helper-97), each a test that failed before its fix.

1. ``load_scene("/dev/zero")`` read the device until the process was killed for its memory (24 GB); a FIFO hung.
   A scene file must be a regular file of at most ``MAX_SCENE_BYTES``.
2. The Python API had no cost refusal: ``SolverSettings(curve_points=10**7)`` in ``pressure_volume_curve`` ended in
   a raw ``MemoryError`` (or the machine's memory), ``profile(..., points=10**8)`` ran for minutes. Both are now
   refused before any work, as ``coexist curves`` / ``coexist shape`` are.
3. ``coexist.fit.sensitivity(scene, relative_change=1.0)`` raised ``ZeroDivisionError`` (a zero radius), ``2.0`` a
   ``math domain error`` (a negative modulus), and ``nan`` returned rows of NaN values.
4. ``coexist.fit.transition_voltage(scene, shared="x")`` raised ``AttributeError``.
5. ``solve_patterned_states(..., scale_guess=[0, 0, 0])`` for two states raised numpy's broadcast ``ValueError``.
6. ``SolverSettings(curve_points=np.int64(7))`` was refused as "must be an integer of at least 5, got np.int64(7)".
7. ``coexist.sweep.make_spec(scene, {"membrane.zone_radius_mm": 21.2})`` (one bare value) raised ``TypeError``.
8. ``Simulation.discover`` took any ``voltages`` and ``bulged``: numpy errors, and 10**6 voltages ran out of memory.
"""

import os

import numpy as np
import pytest
from conftest import bounded

from coexist import MembraneModel, SolverSettings, load_scene, pressure_volume_curve, voltage_charge_curve
from coexist.errors import SceneError
from coexist.fit import Shared, sensitivity, transition_voltage
from coexist.model import build_model
from coexist.patterned import ZonePattern, solve_patterned_states
from coexist.shapes import profile


@pytest.mark.skipif(not os.path.exists("/dev/null"), reason="no /dev/null here")
def test_load_scene_refuses_a_device_before_reading_it():
    """(/dev/zero was read until the process was killed: /dev/null, empty, shows the same check without that risk
    should it ever go.)"""
    with pytest.raises(SceneError, match="not a regular file"):
        bounded(load_scene, "/dev/null", seconds=10)


def test_load_scene_refuses_a_fifo_without_blocking(tmp_path):
    fifo = tmp_path / "scene.toml"
    os.mkfifo(fifo)
    with pytest.raises(SceneError, match="not a regular file"):
        bounded(load_scene, fifo, seconds=10)  # it blocked (waiting for a writer) before


def test_load_scene_refuses_a_huge_file(tmp_path):
    from coexist import scene as scene_module

    big = tmp_path / "big.toml"
    with open(big, "wb") as f:
        f.truncate(scene_module.MAX_SCENE_BYTES + 1)
    with pytest.raises(SceneError, match="larger than"):
        load_scene(big)


def test_huge_curve_refused_before_work():
    settings = SolverSettings(curve_points=10**7)
    with pytest.raises(SceneError) as info:
        bounded(pressure_volume_curve, MembraneModel(), 0.1, settings=settings, seconds=10)
    assert info.value.field == "pole_stretch"
    with pytest.raises(SceneError):
        bounded(
            voltage_charge_curve, MembraneModel(), 1.0, settings=SolverSettings(charge_curve_points=10**7), seconds=10
        )


def test_huge_profile_refused_before_work():
    with pytest.raises(SceneError) as info:
        bounded(profile, MembraneModel(), 1.5, 0.0, zone_radius=0.02, points=10**8, seconds=10)
    assert info.value.field == "points"


@pytest.mark.parametrize("change", [1.0, 2.0, 0.0, -0.1, float("nan"), "0.1"])
def test_sensitivity_refuses_a_bad_relative_change(change):
    with pytest.raises(SceneError) as info:
        sensitivity(load_scene("tricircle"), change, shared=object.__new__(Shared))
    assert info.value.field == "relative_change"


def test_transition_voltage_refuses_a_bad_shared():
    with pytest.raises(SceneError) as info:
        transition_voltage(load_scene("tricircle"), shared="x")
    assert info.value.field == "shared"


def test_scale_guess_of_the_wrong_length_is_a_scene_error():
    with pytest.raises(SceneError) as info:
        solve_patterned_states(MembraneModel(), ZonePattern.inner_circle(0.5), [1.5, 2.0], 0.1, scale_guess=[0, 0, 0])
    assert info.value.field == "scale_guess"


def test_numpy_integers_are_taken_by_the_settings():
    s = SolverSettings(curve_points=np.int64(7), max_steps=np.int32(100))
    assert s.curve_points == 7 and type(s.curve_points) is int
    assert s.max_steps == 100 and type(s.max_steps) is int


def test_make_spec_takes_one_bare_value():
    from coexist.sweep import make_spec

    spec = make_spec("tricircle", {"membrane.zone_radius_mm": 21.2})
    assert spec.shape == (1,)


@pytest.mark.parametrize(
    ("kw", "field"),
    [
        ({"voltages": -1}, "voltages"),
        ({"voltages": 2.5}, "voltages"),
        ({"voltages": "3"}, "voltages"),
        ({"voltages": 10**6}, "voltages"),
        ({"bulged": 5}, "bulged"),
        ({"bulged": ["a"]}, "bulged"),
    ],
)
def test_discover_checks_its_arguments_before_any_work(kw, field):
    """8. ``Simulation.discover(voltages=-1 | 2.5 | "3")`` raised numpy's errors, ``bulged=5`` / ``["a"]`` a TypeError /
    ValueError, and ``voltages=10**6`` shot 240 million states (minutes, then the memory)."""
    from coexist import Simulation

    sim = Simulation.from_scene(load_scene("tricircle"), SolverSettings(rtol=1e-6))
    with pytest.raises(SceneError) as info:
        bounded(sim.discover, **kw, seconds=10)
    assert info.value.field == field


@pytest.mark.parametrize("voltage", ["no", 1, None])
def test_build_model_takes_voltage_as_a_bool_only(voltage):
    """``build_model(voltage="no")`` gave a model with electrostatics (a truthy string)."""
    with pytest.raises(SceneError) as info:
        build_model(voltage=voltage)
    assert info.value.field == "voltage"
    assert build_model(voltage=np.bool_(False)).describe() == build_model(voltage=False).describe()


@pytest.mark.parametrize(
    ("change", "field"),
    [
        ({"zone_radius": 0.0}, "zone_radius"),
        ({"thickness": float("nan")}, "thickness"),
        ({"shear_modulus": -1.0}, "shear_modulus"),
        ({"relative_permittivity": 0.0}, "relative_permittivity"),
        ({"zone_count": 2.5}, "zone_count"),
    ],
)
def test_a_scene_made_by_replace_is_checked_again(change, field):
    """``dataclasses.replace`` bypasses the scene format: a zero radius was a ZeroDivisionError in
    ``Simulation.from_scene``, a negative modulus a math domain error, 2.5 zones a result."""
    from dataclasses import replace

    from coexist import Simulation

    with pytest.raises(SceneError) as info:
        bounded(Simulation.from_scene, replace(load_scene("tricircle"), **change), seconds=30)
    assert info.value.field == field


def test_first_transition_without_a_voltage_path_says_so():
    """It had answered "the zones stay homogeneous up to 0 kV (the window ends)" for a scene with no [voltage]."""
    from coexist import Simulation

    sim = Simulation.from_scene(load_scene("two-balloons"))
    with pytest.raises(SceneError) as info:
        bounded(sim.first_transition, seconds=30)
    assert info.value.field == "[voltage]"


def test_a_voltage_search_out_of_iterations_says_so():
    """``voltage_at_pressure(iterations=1)`` had called every pole stretch one that no voltage holds (``NO_VOLTAGE``)
    though the default 60 iterations find all of them: a search still open when its iterations run out is
    ``VOLTAGE_ITERATIONS`` (tag ``solver_budget``); a pole stretch below the pressure at zero voltage stays
    ``NO_VOLTAGE`` however few the iterations."""
    from coexist.curves import voltage_at_pressure
    from coexist.shooting import NO_VOLTAGE, OK, VOLTAGE_ITERATIONS, reason_tag

    model = build_model("gent", 97.0)
    l0 = np.array([1.05, 1.5, 2.0, 3.0])  # p̂(1.05, 0) < 1.5: no voltage holds it
    short = bounded(voltage_at_pressure, model, l0, 1.5, iterations=1, seconds=30)
    assert short.status.tolist() == [NO_VOLTAGE] + [VOLTAGE_ITERATIONS] * 3
    assert reason_tag(VOLTAGE_ITERATIONS) == "solver_budget" and np.all(np.isnan(short.p_hat[1:]))
    full = bounded(voltage_at_pressure, model, l0, 1.5, seconds=30)
    assert full.status.tolist() == [NO_VOLTAGE, OK, OK, OK]


def test_an_effect_class_instead_of_an_instance_is_refused():
    """``MembraneModel(elasticity=Gent)`` (the class, not ``Gent(97)``) had passed the Protocol check (the class has
    the methods, unbound) and failed in the symbolic model with a raw TypeError."""
    from coexist.effects import Gent, IdealDielectric

    for kw, field in (({"elasticity": Gent}, "elasticity"), ({"electrostatics": IdealDielectric}, "electrostatics")):
        with pytest.raises(SceneError, match="the class") as info:
            MembraneModel(**kw)
        assert info.value.field == field
