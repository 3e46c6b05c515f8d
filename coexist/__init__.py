"""coexist: inflated dielectric elastomer membranes, their shapes under voltage, and phase coexistence.

The Python API in a few lines::

    from coexist import MembraneModel, pressure_volume_curve
    curve = pressure_volume_curve(MembraneModel(), phi_hat=0.1)
    print(curve.limit_points[0].p_hat)      # the snap-through pressure p̂max

Heavy modules (CasADi, matplotlib) are imported on first use, so ``import coexist`` is cheap.
"""

from __future__ import annotations

import importlib

__version__ = "0.1.0"

_LAZY = {
    "MembraneModel": "coexist.model",
    "build_model": "coexist.model",
    "NeoHookean": "coexist.effects",
    "Gent": "coexist.effects",
    "IdealDielectric": "coexist.effects",
    "NoElectrostatics": "coexist.effects",
    "SolverSettings": "coexist.settings",
    "solve_states": "coexist.shooting",
    "MembraneStates": "coexist.shooting",
    "pressure_volume_curve": "coexist.curves",
    "voltage_charge_curve": "coexist.curves",
    "voltage_at_pressure": "coexist.curves",
    "Curve": "coexist.curves",
    "LimitPoint": "coexist.curves",
    "Scene": "coexist.scene",
    "load_scene": "coexist.scene",
    "parse_scene": "coexist.scene",
    "builtin_scenes": "coexist.scene",
    "Simulation": "coexist.simulation",
    "simulate_ramp": "coexist.simulation",
    "EquilibriumMap": "coexist.continuation",
    "Configuration": "coexist.equilibria",
    "GasChamber": "coexist.effects",
    "PressureReservoir": "coexist.effects",
    "Breakdown": "coexist.effects",
    "fit_zone_radius": "coexist.fit",
    "CoexistError": "coexist.errors",
    "SceneError": "coexist.errors",
    "SolverError": "coexist.errors",
    "ModelRangeError": "coexist.errors",
}

__all__ = sorted(_LAZY) + ["__version__"]


def __getattr__(name):
    if name in _LAZY:
        return getattr(importlib.import_module(_LAZY[name]), name)
    raise AttributeError(f"module 'coexist' has no attribute {name!r}")
