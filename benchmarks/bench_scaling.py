"""Benchmark: how the cost (wall time and peak memory) grows with the size of the problem.

Four axes, each case measured in a **fresh subprocess** (so that one case's peak memory is not another's):

1. **curve points** ``n = 50, 200, 1000, 5000``:
   ``pressure_volume_curve(MembraneModel(), 0.1, pole_stretch=np.linspace(1.01, 4, n))`` (neo-Hookean,
   default ``SolverSettings``, ``rtol = 1e-10``), limit points included;
2. **ramp voltages** ``51, 501, 5001, 50001``: the scene pipeline as in ``bench_pipeline.py``
   (``Simulation.from_scene(scene).ramp()``, the whole compute from the parsed scene) on the built-in
   scene ``tricircle`` with ``stop_kV = 4`` and ``step_kV = 0.16, 0.016, 0.0016, 0.00016``. The stop is
   4 kV, not the scene's 5 kV, so that every size has a state at every voltage (above 4.33 kV the bulged
   zone wrinkles); up to 4 kV the ramp meets the same two transitions (split at 3.90 kV, fold at 3.55 kV);
3. **zones** ``count = 1, 3, 10, 100, 1000`` (``tricircle`` otherwise unchanged: 501 voltages);
4. **voltage range** ``stop_kV = 5, 20, 50`` at ``step_kV = 0.02`` (501, 2001, 5001 voltages; above
   4.33 kV no state exists, so the extra voltages are empty steps).

In each subprocess: the imports, one untimed warm-up run of the axis's *smallest* case (it builds the
model, loads or compiles the CasADi attempt function, and sets the memory baseline), then the case
best of N (N from 7 for small cases down to 1 for the 50 001-voltage ramp; the spread is printed),
then one more untimed run under :mod:`tracemalloc`. Memory, two measures:

- **peak RSS**: ``resource.getrusage(RUSAGE_SELF).ru_maxrss`` of the whole subprocess (Python, numpy,
  CasADi and its C++ memory, the interpreter; about 45 MB after the imports), after the timed runs;
  ``ΔRSS`` is its rise over the same process after the warm-up (so ~0 for the smallest case of an
  axis: what the larger case needs beyond the smallest);
- **tracemalloc peak**: the peak of Python allocations (Python objects and numpy buffers, not
  CasADi's own C++ memory) during the extra run. It slows a ramp about 7×, so it is skipped for the
  50 001-voltage ramp (and with ``--quick`` for every ramp above 501 voltages).

Slopes are least-squares fits of ``log(time)`` (and of ``log(memory)``) against ``log(size)`` over the
larger sizes of each axis (the last three; all three for the voltage range), and the time slope between
the two largest sizes; memory slopes only where the memory measure exists and is above 1 MB.

Run: ``.venv/bin/python benchmarks/bench_scaling.py [--quick] [--json] [--figure PATH [--overwrite]]
[--axes AXIS ...] [--tuned-env]`` (``--json``: results with the slopes as JSON on stdout, progress and the
tables on stderr; ``--quick``: one timed run per case, no 50 001-voltage ramp; ``--figure``: a 2×2
log–log figure, time and memory against each axis, slopes in the legends; an existing file is not
overwritten without ``--overwrite`` (one-line error, exit 2); ``--axes``: only these axes;
``--tuned-env``: the workers run with :data:`TUNED_ENV`, one OpenBLAS thread and a glibc malloc that keeps
freed memory, which removes the two machine effects that make very large batches slower per point here;
see ``benchmarks/README.md``). About 1.5 minutes (1 with ``--quick``) on this 2-core machine when idle.
"""

from __future__ import annotations

import argparse
import functools
import json
import math
import os
import platform
import subprocess
import sys
import time
import tracemalloc
from pathlib import Path

import numpy as np

SCENE = "tricircle"
PHI_HAT = 0.1
#: the axes: name -> (sizes, timed repeats per size, whether tracemalloc runs per size)
AXES = {
    "curve_points": ((50, 200, 1000, 5000), (7, 7, 5, 5), (True, True, True, True)),
    "ramp_voltages": ((51, 501, 5001, 50001), (5, 3, 2, 1), (True, True, True, False)),
    "zones": ((1, 3, 10, 100, 1000), (3, 3, 3, 3, 3), (True,) * 5),
    "voltage_range": ((5, 20, 50), (3, 3, 3), (True, True, True)),
}
#: what the size of each axis is, for the tables and the figure
AXIS_LABELS = {
    "curve_points": "curve points n",
    "ramp_voltages": "ramp voltages (0 → 4 → 0 kV)",
    "zones": "zones N (501 voltages)",
    "voltage_range": "stop_kV (step 0.02 kV)",
}
#: the ramp-voltage axis: 0 -> RAMP_STOP_KV -> 0 with (2 RAMP_STOP_KV / step + 1) voltages
RAMP_STOP_KV = 4
RAMP_STEPS_KV = {51: 0.16, 501: 0.016, 5001: 0.0016, 50001: 0.00016}
RANGE_STEP_KV = 0.02
#: slopes are fitted on this many of the largest sizes of each axis
FIT_LAST = 3
#: a memory measure below this (MB) is noise for a slope
MEMORY_FLOOR_MB = 1.0
#: ``--tuned-env``: the worker processes run with one OpenBLAS thread (the DOP853 stage sums are matrix
#: products that OpenBLAS spreads over threads above a few thousand columns, which on this shared 2-core
#: machine costs up to 7x) and a glibc malloc that keeps freed heap memory (large numpy temporaries are
#: otherwise returned to the system and page-faulted in again on every call)
TUNED_ENV = {
    "OPENBLAS_NUM_THREADS": "1",
    "MALLOC_MMAP_THRESHOLD_": str(32 * 2**20),
    "MALLOC_TRIM_THRESHOLD_": str(2**30),
}


def log(message: str) -> None:
    print(message, file=sys.stderr, flush=True)


# --- the cases --------------------------------------------------------------------------------------------
def scene_variant(**keys):
    """``tricircle`` with some ``key = value`` lines replaced: ``bench_pipeline.scene_variant`` (one home)."""
    sys.path.insert(0, str(Path(__file__).resolve().parent))
    try:
        from bench_pipeline import scene_variant as variant
    finally:
        sys.path.pop(0)
    return variant(**keys)


def ramp_compute(scene):
    """The timed unit of a ramp: the whole compute from the parsed scene."""
    from coexist.simulation import Simulation

    return Simulation.from_scene(scene).ramp()


def case_scene(axis: str, value):
    """The scene of a ramp case."""
    if axis == "ramp_voltages":
        return scene_variant(stop_kV=RAMP_STOP_KV, step_kV=RAMP_STEPS_KV[value])
    if axis == "zones":
        return scene_variant(count=value)
    if axis == "voltage_range":
        return scene_variant(stop_kV=value, step_kV=RANGE_STEP_KV)
    raise ValueError(f"no scene for axis {axis!r}")


def case_function(axis: str, value):
    """``(fn, describe)``: the timed call of a case, and a function of its result giving a few facts."""
    if axis == "curve_points":
        from coexist.curves import pressure_volume_curve
        from coexist.model import MembraneModel

        model = MembraneModel()
        grid = np.linspace(1.01, 4.0, int(value))

        def fn():
            return pressure_volume_curve(model, PHI_HAT, pole_stretch=grid)

        def describe(curve):
            return {"states": int(curve.states.p_hat.size), "limit_points": [lp.kind for lp in curve.limit_points]}

        return fn, describe
    scene = case_scene(axis, value)

    def fn():
        return ramp_compute(scene)

    def describe(report):
        res = report.result
        return {
            "voltages": len(scene.voltage_hat_path),
            "states_printed": sum(s.state is not None for s in res.steps),
            "transitions": [f"{t.kind} ({t.event}) {t.direction}" for t in res.transitions],
        }

    return fn, describe


def max_rss_mb() -> float:
    """Peak resident set size of this process so far (``ru_maxrss``, KiB on Linux) in MB (MiB)."""
    import resource

    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0


def tracemalloc_peak_mb(fn) -> tuple[float, float]:
    """``(peak MB, seconds)`` of Python allocations (:mod:`tracemalloc`) during one call of ``fn``."""
    tracemalloc.start()
    try:
        start = time.perf_counter()
        fn()
        seconds = time.perf_counter() - start
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    return peak / 1e6, seconds


def measure(axis: str, value, repeats: int, trace: bool, warmup: bool = True) -> dict:
    """Measure one case in this process: warm-up (the axis's smallest case), best of ``repeats``, then
    optionally a tracemalloc run. Meant to run in a fresh process (:func:`measure_in_subprocess`)."""
    import coexist.curves  # noqa: F401 - the imports (CasADi included) come before the first memory reading
    import coexist.simulation  # noqa: F401

    rss_start = max_rss_mb()
    if warmup:
        warm_fn, _ = case_function(axis, AXES[axis][0][0])
        warm_fn()
        del warm_fn
    rss_warm = max_rss_mb()
    fn, describe = case_function(axis, value)
    times = []
    result = None
    for _ in range(repeats):
        result = None  # the previous result is released before the next run
        start = time.perf_counter()
        result = fn()
        times.append(time.perf_counter() - start)
    facts = describe(result)
    del result
    rss_peak = max_rss_mb()
    tm_peak, tm_seconds = tracemalloc_peak_mb(fn) if trace else (None, None)
    return {
        "axis": axis,
        "size": value,
        "seconds": {"best": min(times), "worst": max(times), "runs": len(times), "all": times},
        "rss_start_MB": rss_start,
        "rss_after_warmup_MB": rss_warm,
        "rss_peak_MB": rss_peak,
        "rss_rise_MB": rss_peak - rss_warm,
        "tracemalloc_peak_MB": tm_peak,
        "tracemalloc_run_seconds": tm_seconds,
        **facts,
    }


def measure_in_subprocess(axis: str, value, repeats: int, trace: bool, env: dict | None = None) -> dict:
    """:func:`measure` in a fresh Python process (this script with ``--worker``); its JSON result. ``env``:
    variables added to the subprocess's environment."""
    spec = json.dumps({"axis": axis, "size": value, "repeats": repeats, "trace": trace})
    proc = subprocess.run(
        [sys.executable, os.path.abspath(__file__), "--worker", spec],
        capture_output=True,
        text=True,
        check=False,
        env={**os.environ, **(env or {})},
    )
    if proc.returncode != 0:
        tail = proc.stderr.strip().splitlines()[-1:] or ["(no output)"]
        raise RuntimeError(f"the measurement of {axis} = {value} failed: {tail[0]}")
    return json.loads(proc.stdout.strip().splitlines()[-1])


# --- slopes -----------------------------------------------------------------------------------------------
def fit_slope(sizes, values) -> float:
    """Least-squares slope of ``log(values)`` against ``log(sizes)`` (the exponent ``k`` of ``values ∝ size^k``).

    Parameters
    ----------
    sizes, values : array_like
        At least two positive numbers each, of the same length.

    Returns
    -------
    float
    """
    x = np.asarray(sizes, dtype=float)
    y = np.asarray(values, dtype=float)
    if x.ndim != 1 or x.size < 2 or x.shape != y.shape or not (np.all(x > 0) and np.all(y > 0)):
        raise ValueError("fit_slope needs at least two positive sizes and values of the same length")
    if not (np.all(np.isfinite(x)) and np.all(np.isfinite(y))):
        raise ValueError("fit_slope needs finite sizes and values")
    return float(np.polyfit(np.log(x), np.log(y), 1)[0])


def axis_slopes(rows: list[dict], last: int = FIT_LAST) -> dict:
    """Slopes of time and memory against size over the ``last`` largest sizes of an axis (memory only where
    measured and above :data:`MEMORY_FLOOR_MB`; ``None`` where fewer than two such points remain)."""
    rows = sorted(rows, key=lambda r: r["size"])[-last:]

    def slope(key):
        pts = [(r["size"], r[key]) for r in rows if r.get(key) is not None and r[key] >= MEMORY_FLOOR_MB]
        return fit_slope(*zip(*pts)) if len(pts) >= 2 else None

    sizes = [r["size"] for r in rows]
    times = [r["seconds"]["best"] for r in rows]
    return {
        "fitted_sizes": sizes,
        "time": fit_slope(sizes, times),
        # the local slope between the two largest sizes: a growing cost per unit shows here first
        "time_last_pair": fit_slope(sizes[-2:], times[-2:]),
        "tracemalloc": slope("tracemalloc_peak_MB"),
        "rss_rise": slope("rss_rise_MB"),
    }


# --- output -----------------------------------------------------------------------------------------------
def _fmt_slope(s) -> str:
    return "-" if s is None else f"{s:.2f}"


def _fmt_mb(v) -> str:
    return "-" if v is None else f"{v:.1f}"


def print_tables(out: dict, file=None) -> None:
    emit = functools.partial(print, file=file or sys.stdout)
    emit(f"machine: {out['machine']}; each case in a fresh subprocess; time = best of N after a warm-up")
    env = out.get("worker_environment") or {}
    emit(f"worker environment: {' '.join(f'{k}={v}' for k, v in env.items()) if env else 'as inherited (default)'}")
    starts = [r["rss_start_MB"] for data in out["axes"].values() for r in data["rows"]]
    emit(
        "memory: peak RSS = ru_maxrss of the whole subprocess (incl. CasADi; "
        f"{min(starts):.0f}-{max(starts):.0f} MB after the imports, before any work);"
    )
    emit("        ΔRSS = its rise over the same process after a warm-up run of the axis's smallest case;")
    emit("        tracemalloc = peak of Python allocations in one extra run (not CasADi's C++ memory)")
    for axis, data in out["axes"].items():
        emit(f"\n{axis}: {AXIS_LABELS[axis]}")
        emit(
            f"  {'size':>7} {'best s':>9} {'worst s':>9} {'N':>2} {'peak RSS MB':>11} {'ΔRSS MB':>8} "
            f"{'tracemalloc MB':>14}  facts"
        )
        for r in data["rows"]:
            s = r["seconds"]
            if axis == "curve_points":
                facts = f"{r['states']} states, {', '.join(r['limit_points'])}"
            else:
                kinds = sorted({t.split()[0] for t in r["transitions"]})
                facts = (
                    f"{r['voltages']} voltages, {r['states_printed']} states, transitions: {', '.join(kinds) or '-'}"
                )
            emit(
                f"  {r['size']:>7} {s['best']:>9.4f} {s['worst']:>9.4f} {s['runs']:>2} {r['rss_peak_MB']:>11.1f} "
                f"{r['rss_rise_MB']:>8.1f} {_fmt_mb(r['tracemalloc_peak_MB']):>14}  {facts}"
            )
    emit("\nslopes d log(cost) / d log(size), least squares over the largest sizes")
    emit(f"  {'axis':<14} {'fitted sizes':<18} {'time':>6} {'time, last 2':>12} {'tracemalloc':>11} {'ΔRSS':>6}")
    for axis, data in out["axes"].items():
        sl = data["slopes"]
        sizes = ", ".join(str(v) for v in sl["fitted_sizes"])
        emit(
            f"  {axis:<14} {sizes:<18} {_fmt_slope(sl['time']):>6} {_fmt_slope(sl['time_last_pair']):>12} "
            f"{_fmt_slope(sl['tracemalloc']):>11} {_fmt_slope(sl['rss_rise']):>6}"
        )
    z = out["axes"].get("zones")
    if z:
        best = {r["size"]: r["seconds"]["best"] for r in z["rows"]}
        if 1 in best and 1000 in best:
            emit(f"\nzones: time N = 1000 / N = 1: {best[1000] / best[1]:.2f}; ", end="")
            emit(f"N = 1000 / N = 3: {best[1000] / best[3]:.2f}")
    emit(f"\nscript runtime: {out['script_seconds']:.0f} s")


def _log_limits(values, decades: float):
    """Limits of a log axis around ``values`` spanning at least ``decades`` (so that small changes look small)."""
    lo, hi = min(values), max(values)
    span = max(math.log10(hi / lo), decades)
    mid = 0.5 * (math.log10(lo) + math.log10(hi))
    return 10 ** (mid - 0.6 * span), 10 ** (mid + 0.6 * span)


def draw_figure(out: dict, path: str) -> None:
    """2×2 log–log panels, one per axis: time (left axis) and memory (right axis), slopes in the legends."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.ticker import FuncFormatter, NullFormatter

    plain = FuncFormatter(lambda v, _: f"{v:g}")
    nrows = 1 if len(out["axes"]) <= 2 else 2  # 2x2 for all four axes; one row for --axes with one or two
    fig, axes = plt.subplots(nrows, 2, figsize=(12, 5 * nrows), squeeze=False)
    for ax in axes.ravel()[len(out["axes"]) :]:
        ax.axis("off")
    for ax, (axis, data) in zip(axes.ravel(), out["axes"].items()):
        rows, sl = data["rows"], data["slopes"]
        x = [r["size"] for r in rows]
        t = [r["seconds"]["best"] for r in rows]
        worst = [r["seconds"]["worst"] for r in rows]
        lines = ax.loglog(
            x,
            t,
            "o-",
            color="C0",
            label=f"time, best of N (slope {_fmt_slope(sl['time'])}; last 2: {_fmt_slope(sl['time_last_pair'])})",
        )
        ax.vlines(x, t, worst, color="C0", alpha=0.5, lw=3)  # the spread: best to worst
        ax.set_ylim(*_log_limits(t + worst, 2.0))
        ax.set_xticks(x)
        ax.xaxis.set_major_formatter(plain)
        ax.xaxis.set_minor_formatter(NullFormatter())
        ax.yaxis.set_major_formatter(plain)
        ax.set_xlabel(AXIS_LABELS[axis])
        ax.set_ylabel("wall time (s); bar: best to worst", color="C0")
        ax.grid(True, which="major", alpha=0.3)
        mem = ax.twinx()
        mem.set_yscale("log")
        tm = [(r["size"], r["tracemalloc_peak_MB"]) for r in rows if r["tracemalloc_peak_MB"] is not None]
        values = [r["rss_peak_MB"] for r in rows]
        if tm:
            values += [v for _, v in tm]
            lines += mem.plot(
                *zip(*tm), "s--", color="C1", label=f"tracemalloc peak (slope {_fmt_slope(sl['tracemalloc'])})"
            )
        lines += mem.plot(x, [r["rss_peak_MB"] for r in rows], "^:", color="C2", label="peak RSS, whole process")
        rise = [(r["size"], r["rss_rise_MB"]) for r in rows if r["rss_rise_MB"] >= MEMORY_FLOOR_MB]
        if rise:
            values += [v for _, v in rise]
            lines += mem.plot(
                *zip(*rise), "v-.", color="C3", label=f"ΔRSS over warm-up (slope {_fmt_slope(sl['rss_rise'])})"
            )
        mem.set_ylim(*_log_limits(values, 2.0))
        mem.yaxis.set_major_formatter(plain)
        mem.set_ylabel("memory (MB)")
        fitted = sl["fitted_sizes"]
        ax.set_title(f"{axis.replace('_', ' ')} (slopes over {fitted[0]}–{fitted[-1]})", fontsize=10)
        ax.legend(
            lines,
            [ln.get_label() for ln in lines],
            fontsize=8,
            loc="upper center",
            bbox_to_anchor=(0.5, -0.14),
            ncol=2,
            frameon=False,
        )
    env = out.get("worker_environment") or {}
    fig.suptitle(
        "coexist: cost against problem size (each case in a fresh process, best of N after a warm-up)"
        + ("\nworkers run with " + " ".join(f"{k}={v}" for k, v in env.items()) if env else ""),
        fontsize=11,
    )
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


# --- main -------------------------------------------------------------------------------------------------
def run(quick: bool, axes=None, env: dict | None = None) -> dict:
    t_start = time.perf_counter()
    out = {
        "machine": f"{platform.machine()}, Python {platform.python_version()}, numpy {np.__version__}",
        "worker_environment": dict(env or {}),
        "axes": {},
    }
    for axis, (sizes, repeats, traces) in AXES.items():
        if axes and axis not in axes:
            continue
        rows = []
        for size, n, trace in zip(sizes, repeats, traces):
            if quick and axis == "ramp_voltages" and size > 5001:
                continue
            if quick:
                n, trace = 1, trace and not (axis == "ramp_voltages" and size > 501)
            log(f"{axis} = {size}: best of {n}{', tracemalloc' if trace else ''} (fresh process) ...")
            row = measure_in_subprocess(axis, size, n, trace, env)
            log(
                f"    {row['seconds']['best']:.4f} s (worst {row['seconds']['worst']:.4f}), peak RSS "
                f"{row['rss_peak_MB']:.1f} MB (Δ {row['rss_rise_MB']:.1f}), "
                f"tracemalloc {_fmt_mb(row['tracemalloc_peak_MB'])} MB"
            )
            rows.append(row)
        out["axes"][axis] = {"rows": rows, "slopes": axis_slopes(rows)}
    out["script_seconds"] = time.perf_counter() - t_start
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--json", action="store_true", help="results as JSON on stdout (progress, tables on stderr)")
    ap.add_argument("--quick", action="store_true", help="one timed run per case, no 50 001-voltage ramp")
    ap.add_argument("--figure", metavar="PATH", help="draw a 2x2 log-log figure of time and memory to PATH")
    ap.add_argument("--overwrite", action="store_true", help="replace an existing --figure file")
    ap.add_argument("--axes", nargs="+", choices=list(AXES), help="measure only these axes (default: all)")
    ap.add_argument(
        "--tuned-env",
        action="store_true",
        help="run the workers with " + " ".join(f"{k}={v}" for k, v in TUNED_ENV.items()),
    )
    ap.add_argument("--worker", metavar="SPEC", help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    if args.worker:
        spec = json.loads(args.worker)
        print(json.dumps(measure(spec["axis"], spec["size"], spec["repeats"], spec["trace"])))
        return 0
    if args.figure:
        if os.path.exists(args.figure) and not args.overwrite:
            print(f"error: {args.figure} exists; pass --overwrite to replace it", file=sys.stderr)
            return 2
        parent = os.path.dirname(os.path.abspath(args.figure))
        if not os.path.isdir(parent):
            print(f"error: the directory {parent} does not exist", file=sys.stderr)
            return 2
    out = run(args.quick, args.axes, TUNED_ENV if args.tuned_env else None)
    if args.figure:
        draw_figure(out, args.figure)
        log(f"figure written to {args.figure}")
    if args.json:
        print_tables(out, file=sys.stderr)
        print(json.dumps(out, indent=1, sort_keys=True))
    else:
        print_tables(out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
