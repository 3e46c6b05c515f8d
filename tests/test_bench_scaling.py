"""The scaling benchmark's own pieces (benchmarks/bench_scaling.py), on tiny sizes.

The slope fitter must return the exponent of exact power laws; a ramp's peak of Python allocations
must not grow with its voltage range (the voltages above the last state are empty steps); the figure
must not be overwritten without ``--overwrite``. No wall-time assertions. About 15 s, most of it the
two ramps under tracemalloc (which slows a ramp about 7×).
"""

from __future__ import annotations

import importlib.util
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

SCRIPT = Path(__file__).resolve().parent.parent / "benchmarks" / "bench_scaling.py"
#: the largest allowed ratio of the tracemalloc peaks of the stop_kV = 20 and stop_kV = 5 ramps (same step)
RANGE_MEMORY_FACTOR = 1.5


@pytest.fixture(scope="module")
def bench():
    spec = importlib.util.spec_from_file_location("bench_scaling", SCRIPT)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


@pytest.mark.parametrize("coefficient, exponent", [(3.0, 1.0), (0.5, -0.25), (2e-3, 2.0), (7.0, 0.0)])
def test_fit_slope_of_an_exact_power_law(bench, coefficient, exponent):
    n = np.array([50, 200, 1000, 5000, 50000], dtype=float)
    assert bench.fit_slope(n, coefficient * n**exponent) == pytest.approx(exponent, abs=1e-9)


def test_fit_slope_needs_two_positive_points(bench):
    with pytest.raises(ValueError):
        bench.fit_slope([10], [1.0])
    with pytest.raises(ValueError):
        bench.fit_slope([10, 100], [1.0, 0.0])


def test_axis_slopes_fit_the_largest_sizes_and_skip_small_memory(bench):
    sizes = [1, 10, 100, 1000]
    rows = [
        {
            "size": n,
            # a fixed cost that dominates the smallest size: only the last three follow t = 3 n
            "seconds": {"best": 100.0 if n == 1 else 3.0 * n},
            "tracemalloc_peak_MB": 2.0 * n**0.5,
            "rss_rise_MB": 0.1,  # below the floor: no slope
        }
        for n in sizes
    ]
    slopes = bench.axis_slopes(rows, last=3)
    assert slopes["fitted_sizes"] == [10, 100, 1000]
    assert slopes["time"] == pytest.approx(1.0, abs=1e-9)
    assert slopes["time_last_pair"] == pytest.approx(1.0, abs=1e-9)
    assert slopes["tracemalloc"] == pytest.approx(0.5, abs=1e-9)
    assert slopes["rss_rise"] is None


def test_measure_returns_time_and_both_memories(bench):
    row = bench.measure("curve_points", 50, repeats=1, trace=True, warmup=False)
    assert row["states"] == 50 and row["limit_points"] == ["pressure_max"]
    assert row["seconds"]["runs"] == 1 and row["seconds"]["best"] > 0
    assert row["rss_peak_MB"] >= row["rss_after_warmup_MB"] > 0
    assert row["tracemalloc_peak_MB"] > 0


def test_ramp_memory_does_not_grow_with_the_voltage_range(bench):
    """stop_kV = 20 has 4× the voltages of stop_kV = 5 at the same step, but every voltage above 4.33 kV
    is an empty step (no state exists there): the peak of Python allocations must stay within
    RANGE_MEMORY_FACTOR (measured: 0.83 and 0.84 MB at step 0.1 kV)."""
    bench.ramp_compute(bench.scene_variant(stop_kV=5, step_kV=0.1))  # warm-up: model, attempt function
    peaks = {}
    for stop in (5, 20):
        scene = bench.scene_variant(stop_kV=stop, step_kV=0.1)
        peaks[stop], _ = bench.tracemalloc_peak_mb(lambda scene=scene: bench.ramp_compute(scene))
    assert len(bench.scene_variant(stop_kV=20, step_kV=0.1).voltage_hat_path) == 401
    assert peaks[5] > 0.1  # the ramp was traced at all
    assert peaks[20] <= RANGE_MEMORY_FACTOR * peaks[5], peaks


def test_figure_is_not_overwritten(tmp_path):
    figure = tmp_path / "scaling.png"
    figure.write_bytes(b"not a figure")
    proc = subprocess.run(
        [sys.executable, str(SCRIPT), "--quick", "--figure", str(figure)], capture_output=True, text=True, timeout=60
    )
    assert proc.returncode == 2
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and "--overwrite" in lines[0]
    assert figure.read_bytes() == b"not a figure"
