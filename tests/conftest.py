"""Shared fixtures and helpers (imported by the test modules as ``from conftest import ...``).

Models are built once per session (building one takes ~50 ms).
"""

import re
import signal
import time
from contextlib import contextmanager

import numpy as np
import pytest

from coexist.effects import Gent, IdealDielectric, NeoHookean
from coexist.model import MembraneModel
from coexist.scene import builtin_scene_text, parse_scene
from coexist.settings import SolverSettings

#: the tightest setting the tests compare against (integrator rtol 1e-12)
TIGHT = SolverSettings(rtol=1e-12)
#: wall-clock limit of any single library call under :func:`bounded` (s); the machine is shared, so generous
CALL_LIMIT = 30.0


@contextmanager
def time_limit(seconds: float = CALL_LIMIT):
    """Fail (TimeoutError) if the block runs longer than ``seconds`` of wall-clock time (``SIGALRM``)."""

    def _expired(signum, frame):
        raise TimeoutError(f"call did not return within {seconds:g} s")

    previous = signal.signal(signal.SIGALRM, _expired)
    signal.setitimer(signal.ITIMER_REAL, seconds)
    start = time.perf_counter()
    try:
        yield
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, previous)
    assert time.perf_counter() - start < seconds


def bounded(fn, *args, seconds: float = CALL_LIMIT, **kwargs):
    """``fn(*args, **kwargs)`` under :func:`time_limit`."""
    with time_limit(seconds):
        return fn(*args, **kwargs)


def cheb_nodes(a: float, b: float, n: int) -> np.ndarray:
    """The ``n`` Chebyshev points of the first kind on ``[a, b]``, ascending."""
    k = np.arange(n)
    return np.sort(0.5 * (a + b) + 0.5 * (b - a) * np.cos(np.pi * (k + 0.5) / n))


@pytest.fixture(scope="session")
def neo_hookean():
    return MembraneModel(NeoHookean(), IdealDielectric())


@pytest.fixture(scope="session")
def gent97():
    return MembraneModel(Gent(97.0), IdealDielectric())


# --- scene texts ----------------------------------------------------------------------------------------
#: what every scene must state (the physical fields of [membrane] and [zones].count), as written in a file
REQUIRED_SCENE_KEYS = {
    "membrane": {
        "material": '"neo-hookean"',
        "shear_modulus": "45",
        "relative_permittivity": "4.7",
        "thickness": "0.5",
        "zone_radius": "10",
    },
    "zones": {"count": "1"},
}
_REQUIRED_UNITS = {"shear_modulus": "kPa", "thickness": "mm", "zone_radius": "mm"}
#: the smallest complete scene: a neo-Hookean zone of 10 mm radius, 0.5 mm thick, μ = 45 kPa, εr = 4.7
MINIMAL_SCENE = """\
[membrane]
material = "neo-hookean"
shear_modulus_kPa = 45
relative_permittivity = 4.7
thickness_mm = 0.5
zone_radius_mm = 10
[zones]
count = 1
"""


def _toml_value(value) -> str:
    import datetime
    import json

    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, (int, float)):
        return repr(value)
    if isinstance(value, (datetime.date, datetime.datetime)):
        return value.isoformat()
    if isinstance(value, list):
        return "[" + ", ".join(_toml_value(v) for v in value) + "]"
    return json.dumps(value, ensure_ascii=False)


def complete_scene(text: str) -> str:
    """``text`` with the required scene keys it leaves out added (the values of :data:`MINIMAL_SCENE`), so
    that a test can state only what it is about. Text that is not valid TOML is returned unchanged (the test
    is then about that); a key present under any unit suffix counts as present; a ``material = "gent"``
    without ``jlim`` gets ``jlim = 97``."""
    try:
        import tomllib
    except ImportError:  # Python 3.10
        import tomli as tomllib

    try:
        doc = tomllib.loads(text)
    except tomllib.TOMLDecodeError:
        return text
    for section, keys in REQUIRED_SCENE_KEYS.items():
        table = doc.setdefault(section, {})
        if not isinstance(table, dict):
            return text
        for key, value in keys.items():
            if not any(k == key or k.startswith(key + "_") for k in table):
                name = f"{key}_{_REQUIRED_UNITS[key]}" if key in _REQUIRED_UNITS else key
                table[name] = tomllib.loads(f"x = {value}")["x"]
    membrane = doc["membrane"]
    if str(membrane.get("material", "")).lower() == "gent" and "jlim" not in membrane:
        membrane["jlim"] = 97
    lines = [f"{k} = {_toml_value(v)}" for k, v in doc.items() if not isinstance(v, dict)]
    for section, table in doc.items():
        if isinstance(table, dict):
            lines.append(f"[{section}]")
            lines += [f"{k} = {_toml_value(v)}" for k, v in table.items()]
    return "\n".join(lines) + "\n"


def variant_text(**changes):
    """The tricircle scene's TOML text with some of its keys changed (``values_kV`` replaces the ramp)."""
    text = builtin_scene_text("tricircle")
    for key, val in changes.items():
        if key == "values_kV":
            text = text.replace("start_kV = 0\nstop_kV = 5\nstep_kV = 0.02", f"values_kV = {val}")
        else:
            text, n = re.subn(rf"^{key} = .*$", f"{key} = {val}", text, flags=re.M)
            assert n == 1, key
    return text


def central_difference_jacobian(rhs, x, h=1e-6):
    """``∂rhs/∂x`` at ``x`` by central differences of step ``h`` (a check of an exact Jacobian; error ~h²)."""
    x = np.asarray(x, dtype=float)
    out = np.empty((x.size, x.size))
    for k in range(x.size):
        e = np.zeros(x.size)
        e[k] = h
        out[:, k] = (rhs(x + e) - rhs(x - e)) / (2 * h)
    return out


def variant(**changes):
    """The tricircle scene with some of its keys changed (``values_kV`` replaces the ramp)."""
    return parse_scene(variant_text(**changes))


def one_line_error(result, *fragments):
    """Exit 2, no traceback, exactly one ``Error:`` line holding every fragment."""
    assert result.exit_code == 2, result.output
    assert "Traceback" not in result.output
    errors = [ln for ln in result.output.splitlines() if ln.startswith("Error:")]
    assert len(errors) == 1, result.output
    for fragment in fragments:
        assert fragment in errors[0], errors[0]
    return errors[0]


RING_SCENE = """
name = "{name}"
[membrane]
material = "gent"
jlim = 97
shear_modulus_kPa = 45
relative_permittivity = 4.7
thickness_mm = 0.5
zone_radius_mm = 21.4165
prestretch = 1.0
wrinkling = "{wrinkling}"
[electrodes]
pattern = "ring"
inner_fraction = {fi}
outer_fraction = {fo}
[layers]
passive = 2
[zones]
count = {count}
[chamber]
volume_ml = 300
closing_pressure_mbar = {mbar}
atmospheric_pressure_kPa = 101.325
[voltage]
values_kV = {path}
"""


def ring_scene(wrinkling, name="ring", fi=0.4, fo=0.9, count=1, mbar=25, path="[0, 6.3, 6.4, 6.3]"):
    """TOML text of the default membrane with a ring electrode (R/A ``fi`` to ``fo``, two-layer passive regions) on
    a 300 ml chamber, on the voltage path ``path`` (the audit scenes of the ring tests)."""
    return RING_SCENE.format(name=name, wrinkling=wrinkling, fi=fi, fo=fo, count=count, mbar=mbar, path=path)


# --- an independent gas (tests/test_efe_variations.py, tests/test_transition_variations.py) ----------------------
class IndependentGas:
    """The chamber's isothermal ideal gas from scratch: ``(V̂c + V̂)(p̂atm + p̂) = n̂`` (nothing of coexist's gas)."""

    def __init__(self, vc, patm, n):
        self.vc, self.patm, self.n = vc, patm, n

    def pressure(self, v):
        return self.n / (self.vc + v) - self.patm

    def stiffness(self, v):
        """``−dp̂gas/dV̂``."""
        return self.n / (self.vc + v) ** 2

    def free_energy_difference(self, v1, v2):
        """``F(v1) − F(v2)``, ``F = −n̂ ln(V̂c + V̂) + p̂atm V̂``, without the rounding of two large numbers."""
        dv = v1 - v2
        return -self.n * np.log1p(dv / (self.vc + v2)) + self.patm * dv


def shoot_ok(model, lam, phi, settings, derivatives=False):
    """Single-zone states at the pole stretches ``lam`` (every one must exist)."""
    from coexist.shooting import solve_states

    lam = np.atleast_1d(np.asarray(lam, dtype=float))
    return solve_states(model, lam, phi, settings, derivatives=derivatives).require_ok()


def independent_gas(scene, model, settings):
    """The gas from the scene's fields: the zones at the closing pressure at 0 V on their rising branch."""
    from scipy.optimize import brentq

    from coexist.shooting import solve_states

    ps, vs = scene.shear_modulus * scene.thickness / scene.zone_radius, scene.zone_radius**3
    vc, patm = scene.chamber.volume / vs, scene.chamber.atmospheric_pressure / ps
    pc = scene.chamber.closing_pressure / ps
    grid = model.prestretch * (1 + np.linspace(1e-3, 1.5, 200))
    s = solve_states(model, grid, 0.0, settings)
    top = grid[int(np.argmax(np.where(s.status == 0, s.p_hat, -np.inf)))]
    lam = brentq(lambda x: shoot_ok(model, x, 0.0, settings).p_hat[0] - pc, grid[0], top, xtol=1e-15)
    v = shoot_ok(model, lam, 0.0, settings).v_hat[0]
    return IndependentGas(vc, patm, (vc + scene.zone_count * v) * (patm + pc))
