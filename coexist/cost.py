"""What a ramp will cost, known before it starts, and the limits past which it is refused.

The exact continuation traces each stable segment once, to its ends, whatever the voltage range: what
grows with the scene is the number of *path voltages* (each gets a converged state; a voltage with no
state is nearly free) and the *output* (one row per printed voltage, with a volume and a pole stretch
per zone). The cost model (coefficients measured with ``benchmarks/bench_pipeline.py`` and a
``tracemalloc`` run on this 2-core machine, rounded up)::

    time   ≈ 0.5 s + 0.25 ms × voltages + 2.5 µs × numbers printed
    memory ≈ 4 kB × voltages (states, while they are solved) + 80 B × numbers printed
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
#: bytes per number of the output held in memory: the number in the result, in a list, and its JSON text (measured
#: 2026-12-01: 1000 zones, 200 001 voltages, ``--every 45``, ``--json``: 8.98 million numbers, peak RSS 1.56 GB, of
#: which ~0.1 GB the interpreter and libraries and ~0.8 GB the states of the path voltages: 73 B a number)
BYTES_PER_NUMBER = 80
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


# --- coexist curves and coexist shape ---------------------------------------------------------------------------
#
# Measured on this 2-core machine (2026-12-01, shared with other jobs, /usr/bin/time; rounded up):
#
# curves: 40 p̂–V̂ curves × 5000 points (200 000 states) in 6.0 s for the table, 9.1 s with --json (30–45 µs a
# state) and a peak of 320 MB (1.4 kB a state; the audit that asked for this limit measured up to 3.5 kB a state
# with 2000 curves, the value taken); 10 Φ̂–Q̂ curves × 5000 points in 7.1 s (about 140 µs a state, 3× a p̂–V̂
# state). A patterned zone (inner-circle, two-layer annulus): one p̂–V̂ curve of 5000 points in 13–15.6 s (2.6–3.1
# ms a state) and 14 kB a state (1000 → 5000 points: 116 → 171 MB). The JSON carries 8 numbers a state (9 taken:
# a tension-field curve adds its wrinkled fraction).
#
# shape: each zone shape is a meridian integrated again, stopping at every profile point: 0.24–0.40 ms a point
# (tricircle at 4.0 kV, two shapes of 20 001 points, 9.7–10.7 s; at one voltage 201 → 20 001 points 0.9 → 8.9 s;
# inner-circle, two voltages of 20 001 points, 12.9 s, 0.31 ms a point); a base of about 1 s (scene, gas, ramp up).
# Memory with --json: 4 shapes of 100 001 points (800 000 numbers) in 120 s and 193 MB against 60 MB (166 B a
# number, 200 taken); 2 numbers a point (r, z) and about 8 a shape.

#: seconds of ``coexist curves`` whatever its size (imports, model)
CURVES_SECONDS_BASE = 0.3
#: seconds per state of a p̂–V̂ curve of a uniform zone (measured 30–45 µs)
CURVES_SECONDS_PER_PV_STATE = 45e-6
#: seconds per state of a Φ̂–Q̂ curve of a uniform zone (measured about 140 µs)
CURVES_SECONDS_PER_VQ_STATE = 150e-6
#: seconds per state of a curve of a patterned zone (measured 2.6–3.1 ms)
CURVES_SECONDS_PER_PATTERNED_STATE = 3.5e-3
#: bytes per state of a curve held (states, and their output) by a uniform zone (measured 1.4–3.5 kB)
CURVES_BYTES_PER_STATE = 3.5e3
#: bytes per state of a curve of a patterned zone (measured 14 kB)
CURVES_BYTES_PER_PATTERNED_STATE = 15e3
#: numbers of the output per state of a curve (JSON or CSV: 8, a tension-field curve 9)
CURVES_NUMBERS_PER_STATE = 9
#: seconds of ``coexist shape`` whatever its size (scene, gas, the ramp up to the voltages)
SHAPE_SECONDS_BASE = 1.0
#: seconds per profile point of a zone shape (measured 0.24–0.40 ms)
SHAPE_SECONDS_PER_POINT = 0.4e-3
#: numbers of the output per profile point (r and z)
SHAPE_NUMBERS_PER_POINT = 2
#: numbers of the output per zone shape besides its profile (apex, curvature, electrode edge, ...)
SHAPE_NUMBERS_PER_SHAPE = 8
#: bytes per number of a shape's output held in memory (measured 166 B with --json)
SHAPE_BYTES_PER_NUMBER = 200


@dataclass(frozen=True)
class WorkCost:
    """The estimated cost of a ``coexist curves`` or ``coexist shape`` run (:func:`curves_cost`,
    :func:`shape_cost`).

    Attributes
    ----------
    what : str
        What is computed, for people (``"8 curves × 200 points"``).
    numbers : int
        Numbers in the output.
    seconds : float
        Estimated wall time on a machine like the one measured.
    memory_bytes : float
        Estimated peak memory.
    option : str
        The option that sets the size per item (``--points``).
    fits : int
        The largest value of ``option`` that fits the limits with the rest unchanged (0: none does).
    fewer : str
        The options that set the number of items (``--phi-hat, --p-hat``), the other way to fit.
    """

    what: str
    numbers: int
    seconds: float
    memory_bytes: float
    option: str
    fits: int
    fewer: str

    def describe(self) -> str:
        """One line for people: what, numbers, time and memory.

        Returns
        -------
        str
        """
        return f"{self.what}, {self.numbers:,} numbers out; about {_duration(self.seconds)} and " + (
            f"{self.memory_bytes / 1e9:.2g} GB" if self.memory_bytes >= 1e9 else f"{self.memory_bytes / 1e6:.0f} MB"
        )

    def check(self, smallest: int = 3) -> None:
        """Refuse work past the limits (:data:`MAX_OUTPUT_NUMBERS`, :data:`MAX_MEMORY_BYTES`), naming what to change.

        Parameters
        ----------
        smallest : int
            The smallest value ``option`` takes; when not even that fits, the message asks for fewer items.

        Raises
        ------
        SceneError
            If the output would exceed :data:`MAX_OUTPUT_NUMBERS` or the memory :data:`MAX_MEMORY_BYTES`; the
            field is :attr:`option` (with the value that fits), or the first of :attr:`fewer` when none does.
        """
        if self.numbers <= MAX_OUTPUT_NUMBERS and self.memory_bytes <= MAX_MEMORY_BYTES:
            return
        what = (
            f"{self.what} would give {self.numbers:,} numbers and need about {self.memory_bytes / 1e9:.3g} GB; "
            f"the limits are {MAX_OUTPUT_NUMBERS:,} numbers and {MAX_MEMORY_BYTES / 1e9:g} GB"
        )
        if self.fits >= smallest:
            raise SceneError(f"{what}: take {self.option} {self.fits} or fewer, or fewer of {self.fewer}", self.option)
        raise SceneError(f"{what}: give fewer values", self.fewer.split(",")[0].strip())


def _fitting(per_unit_numbers: float, per_unit_bytes: float, fixed_numbers: float = 0.0) -> int:
    """The largest count of units (points) whose numbers and memory stay within 90 % of the limits."""
    by_numbers = (0.9 * MAX_OUTPUT_NUMBERS - fixed_numbers) / per_unit_numbers
    by_memory = (0.9 * MAX_MEMORY_BYTES - fixed_numbers * SHAPE_BYTES_PER_NUMBER) / per_unit_bytes
    return max(0, math.floor(min(by_numbers, by_memory)))


def curves_cost(pressure_volume: int, voltage_charge: int, points: int, patterned: bool = False) -> WorkCost:
    """The estimated cost of ``coexist curves`` (coefficients above, measured): ``states = curves × points``.

    Parameters
    ----------
    pressure_volume : int
        p̂–V̂ curves (values of ``--phi-hat``).
    voltage_charge : int
        Φ̂–Q̂ curves (values of ``--p-hat``).
    points : int
        States per curve (``--points``).
    patterned : bool
        A patterned zone (its states cost :data:`CURVES_SECONDS_PER_PATTERNED_STATE` and
        :data:`CURVES_BYTES_PER_PATTERNED_STATE`).

    Returns
    -------
    WorkCost
        Option ``--points``, the fewer option ``--phi-hat, --p-hat``.

    Raises
    ------
    SceneError
        If a count is not a whole number (curves ≥ 0, points ≥ 1).

    Examples
    --------
    >>> curves_cost(5, 3, 200).numbers
    14400
    >>> curves_cost(2000, 0, 5000).check()
    Traceback (most recent call last):
    ...
    coexist.errors.SceneError: --points: 2000 curves × 5000 points would give 90,000,000 numbers and need about \
35 GB; the limits are 10,000,000 numbers and 2 GB: take --points 257 or fewer, or fewer of --phi-hat, --p-hat
    """
    from .validation import integer

    pv = integer(pressure_volume, "pressure_volume", lo=0)
    vq = integer(voltage_charge, "voltage_charge", lo=0)
    points = integer(points, "points", lo=1)
    curves = pv + vq
    states = curves * points
    if patterned:
        seconds = CURVES_SECONDS_BASE + CURVES_SECONDS_PER_PATTERNED_STATE * states
        per_state_bytes = CURVES_BYTES_PER_PATTERNED_STATE
    else:
        seconds = CURVES_SECONDS_BASE + points * (CURVES_SECONDS_PER_PV_STATE * pv + CURVES_SECONDS_PER_VQ_STATE * vq)
        per_state_bytes = CURVES_BYTES_PER_STATE
    fits = _fitting(CURVES_NUMBERS_PER_STATE * curves, per_state_bytes * curves) if curves else points
    return WorkCost(
        what=f"{curves} curves × {points} points",
        numbers=CURVES_NUMBERS_PER_STATE * states,
        seconds=seconds,
        memory_bytes=per_state_bytes * states,
        option="--points",
        fits=fits,
        fewer="--phi-hat, --p-hat",
    )


def shape_cost(voltages: int, shapes_per_voltage: int, points: int) -> WorkCost:
    """The estimated cost of ``coexist shape`` (coefficients above, measured): ``voltages × shapes`` profiles of
    ``points`` points each.

    Parameters
    ----------
    voltages : int
        Voltages asked for (``--voltage-kV``).
    shapes_per_voltage : int
        Zone shapes computed per voltage, at most: one per group of identical zones (at most :data:`MAX_GROUPS`
        and the number of zones).
    points : int
        Points per profile (``--points``).

    Returns
    -------
    WorkCost
        Option ``--points``, the fewer option ``--voltage-kV``.

    Raises
    ------
    SceneError
        If a count is not a whole number ≥ 1.

    Examples
    --------
    >>> shape_cost(3, 2, 201).numbers
    2460
    >>> shape_cost(1721, 3, 100001).fits
    867
    """
    from .validation import integer

    voltages = integer(voltages, "voltages", lo=1)
    groups = integer(shapes_per_voltage, "shapes_per_voltage", lo=1)
    points = integer(points, "points", lo=1)
    shapes = voltages * groups
    numbers = shapes * (SHAPE_NUMBERS_PER_POINT * points + SHAPE_NUMBERS_PER_SHAPE)
    per_point = SHAPE_NUMBERS_PER_POINT * shapes
    return WorkCost(
        what=f"{voltages} voltages × {groups} zone shape(s) × {points} points",
        numbers=numbers,
        seconds=SHAPE_SECONDS_BASE + SHAPE_SECONDS_PER_POINT * shapes * points,
        memory_bytes=SHAPE_BYTES_PER_NUMBER * numbers,
        option="--points",
        fits=_fitting(per_point, per_point * SHAPE_BYTES_PER_NUMBER, SHAPE_NUMBERS_PER_SHAPE * shapes),
        fewer="--voltage-kV",
    )
