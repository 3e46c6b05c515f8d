"""What a ramp will cost, known before it starts, and the limits past which it is refused.

The exact continuation traces each stable segment once, to its ends, whatever the voltage range: what
grows with the scene is the number of *path voltages* (each gets a converged state; a voltage with no
state is nearly free) and the *output* (one row per printed voltage, with a volume and a pole stretch
per zone). The cost model (coefficients measured with ``benchmarks/bench_pipeline.py`` and a
``tracemalloc`` run on this 2-core machine, rounded up)::

    time   ≈ 0.5 s + 0.25 ms × voltages + 2.5 µs × numbers printed
    memory ≈ 4 kB × voltages (states, while they are solved) + 32 B × numbers printed
    numbers printed = rows × (2 N + 3 groups + 8),  rows = voltages / every (+ changes)

A scene with patterned zones (:mod:`coexist.patterned`: every state a Newton iteration on the interface scale,
each iterate a shooting region by region) costs :data:`PATTERNED_TIME_FACTOR` times the time of the solving
part (``0.5 s + 0.25 ms × voltages``); measured with ``benchmarks/bench_patterned.py``: the tricircle with
inner-circle electrodes (0.8 of the radius, ``wrinkling = "refuse"``, 501 voltages) ramps in 2.4–2.9 s against
0.46–0.51 s for the same scene with full electrodes, a factor 5.3–5.7 (rounded up to 6).

Limits (:data:`MAX_OUTPUT_NUMBERS`, :data:`MAX_MEMORY_BYTES`): a run that would print more than 10 million
numbers (about 200 MB of JSON) or hold more than 2 GB is refused before it starts, with the field to
change and the ``--every`` that would fit. The scene format itself bounds the path to 100 000 steps and
the zones to 1000 (:mod:`coexist.scene_format`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from .errors import SceneError

#: seconds of a ramp that does not depend on its size (model, closing state, continuation, errors; the default
#: ramp of 501 voltages, 434 of them with a state, computes in 0.52–0.58 s)
SECONDS_BASE = 0.5
#: seconds per path voltage (a converged state, batched; measured on the idle machine, 2026-12-01: 5001 voltages
#: with 4338 states in 1.28–1.43 s, 50 001 voltages in 11.9–12.4 s, i.e. 0.22–0.24 ms each)
SECONDS_PER_VOLTAGE = 0.25e-3
#: seconds per number of the output (building and printing it)
SECONDS_PER_NUMBER = 2.5e-6
#: bytes held per path voltage while the states are solved
BYTES_PER_VOLTAGE = 4e3
#: bytes per number of the output held in memory
BYTES_PER_NUMBER = 32
#: a ramp printing more numbers than this is refused (about 200 MB of JSON)
MAX_OUTPUT_NUMBERS = 10_000_000
#: a ramp needing more memory than this is refused
MAX_MEMORY_BYTES = 2e9
#: groups of identical zones a state has at most on a ramp (homogeneous, one or two bulged groups)
MAX_GROUPS = 3
#: the solving part of a ramp of patterned zones costs this many times a uniform scene's (measured 5.3–5.7)
PATTERNED_TIME_FACTOR = 6.0


@dataclass(frozen=True)
class RampCost:
    """The estimated cost of a ramp.

    Attributes
    ----------
    voltages : int
        Voltages of the path (up and down).
    zones : int
        ``N``.
    rows : int
        Voltages printed (every ``every``-th, plus the changes of configuration, bounded by ``voltages``).
    numbers : int
        Numbers in the output.
    seconds : float
        Estimated wall time on a machine like the one measured.
    memory_bytes : float
        Estimated peak memory of the computation and its output.
    """

    voltages: int
    zones: int
    rows: int
    numbers: int
    seconds: float
    memory_bytes: float

    def describe(self) -> str:
        """One line for people: voltages, rows, numbers, time and memory.

        Returns
        -------
        str
        """
        return (
            f"{self.voltages} voltages, {self.rows} rows of {self.zones} zone(s), {self.numbers:,} numbers out; "
            f"about {_duration(self.seconds)} and {self.memory_bytes / 1e6:.0f} MB"
        )

    def check(self, every: int = 1) -> None:
        """Refuse work past the limits, naming what to change.

        Parameters
        ----------
        every : int
            The ``--every`` the cost was estimated for (the message suggests a larger one that fits).

        Raises
        ------
        SceneError
            If the output would exceed :data:`MAX_OUTPUT_NUMBERS` or the memory :data:`MAX_MEMORY_BYTES`;
            the field is ``[voltage].step_kV`` (or ``[zones].count`` when one row alone is too large).
        """
        per_row = self.numbers / max(self.rows, 1)
        if self.numbers > MAX_OUTPUT_NUMBERS or self.memory_bytes > MAX_MEMORY_BYTES:
            fits = math.ceil(every * self.numbers / (0.9 * MAX_OUTPUT_NUMBERS))
            what = (
                f"the ramp would print {self.numbers:,} numbers ({self.rows} voltages × {self.zones} zones) and "
                f"need about {self.memory_bytes / 1e9:.2g} GB; the limits are {MAX_OUTPUT_NUMBERS:,} numbers and "
                f"{MAX_MEMORY_BYTES / 1e9:g} GB"
            )
            if self.voltages * BYTES_PER_VOLTAGE > MAX_MEMORY_BYTES:
                raise SceneError(f"{what}: take a larger step", "[voltage].step_kV")
            if per_row > MAX_OUTPUT_NUMBERS:
                raise SceneError(f"{what}: fewer zones", "[zones].count")
            raise SceneError(
                f"{what}: take a larger step, or print every {fits}-th voltage (--every {fits})", "[voltage].step_kV"
            )


def _duration(seconds: float) -> str:
    if seconds < 90:
        return f"{seconds:.0f} s" if seconds >= 2 else f"{seconds:.1f} s"
    if seconds < 5400:
        return f"{seconds / 60:.0f} min"
    return f"{seconds / 3600:.1f} h"


def ramp_solving_seconds(scene) -> float:
    """The estimated solving time of ``scene``'s ramp, its output aside: ``SECONDS_BASE + SECONDS_PER_VOLTAGE ·
    voltages``, times :data:`PATTERNED_TIME_FACTOR` for patterned zones (the ramp's and a sweep point's estimate).

    Parameters
    ----------
    scene : Scene
        A scene with a ``[voltage]`` path.

    Returns
    -------
    float
        Seconds.
    """
    solving = SECONDS_BASE + SECONDS_PER_VOLTAGE * len(scene.voltage_hat_path)
    return solving * (PATTERNED_TIME_FACTOR if getattr(scene, "patterned", False) else 1.0)


def ramp_cost(scene, every: int = 1) -> RampCost:
    """The estimated cost of ramping ``scene`` (see the module for the model and its coefficients; patterned
    zones: the solving part times :data:`PATTERNED_TIME_FACTOR`).

    Parameters
    ----------
    scene : Scene
        A scene with a ``[voltage]`` path.
    every : int, optional
        Print every ``every``-th voltage.

    Returns
    -------
    RampCost

    Raises
    ------
    SceneError
        If the scene has no voltage path, or ``every`` is not a positive whole number.
    """
    from .validation import integer
    from .validation import scene as check_scene

    check_scene(scene)
    every = integer(every, "every", lo=1)
    if scene.voltage is None:
        raise SceneError("this scene has no [voltage]: nothing to ramp", "[voltage]")
    voltages = len(scene.voltage_hat_path)
    zones = scene.zone_count
    groups = min(MAX_GROUPS, zones)
    rows = min(voltages, math.ceil(voltages / every) + 8)  # + a few changes of configuration
    numbers = rows * (2 * zones + 3 * groups + 8)
    seconds = ramp_solving_seconds(scene) + SECONDS_PER_NUMBER * numbers
    memory = BYTES_PER_VOLTAGE * voltages + BYTES_PER_NUMBER * numbers
    return RampCost(voltages, zones, rows, numbers, seconds, memory)
