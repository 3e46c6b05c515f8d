"""Benchmark: a design sweep's throughput and parallel efficiency, serial against local workers and Dask.

The sweep: the built-in scene ``tricircle`` (3 zones, ramp 0 → 5 → 0 kV in 0.25 kV steps: the transition
voltages are events of the continuation and do not depend on the step) over a grid of closing pressures
and zone radii around the paper's point (``--points`` of them, default 16 = 4 × 4; a few past the
snap-through get the status ``no_start`` quickly, as a real map has).

1. **Baseline**: ``coexist.sweep.sweep(..., workers=1)``, every point in this process, one after the
   other (after one untimed warm-up point, so the model's code is loaded or compiled here once).
2. **Local process pool** of 1 and 2 ``spawn`` workers (``workers=N``; each worker starts Python, imports
   coexist and loads the model's compiled code: that start-up is inside the time).
3. **Dask LocalCluster** of 2 and 4 worker processes (one thread each; the cluster's start is *not* timed,
   a cluster is started once for many sweeps), ``client=``.

For each: wall time, throughput (points per second), speed-up over the baseline and parallel efficiency
``E = T_serial / (N × T_N)`` with ``N`` the workers (cores used; the machine has ``os.cpu_count()``).
Every run's records are checked bit for bit against the baseline's (the script fails otherwise).
Finally the cost against the number of points (serial, 4 / 8 / 16 points): the slope of time against
points and the time per point, i.e. ``T ≈ T0 + P × t_point / N``.

Run: ``.venv/bin/python benchmarks/bench_sweep.py [--points 16] [--json] [--quick]`` (``--quick``: 4 points,
no scaling series). About 2 minutes on this 2-core machine.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import sys
import time


def grid(points: int) -> dict:
    """``points`` ≈ n × n points around the paper's closing pressure and fitted radius (step 0.25 kV)."""
    n = max(1, round(math.sqrt(points)))
    m = max(1, points // n)
    return {
        "chamber.closing_pressure_mbar": f"19.7:20.3:{n}" if n > 1 else "20",
        "membrane.zone_radius_mm": f"21.2:21.6:{m}" if m > 1 else "21.4165",
        "voltage.step_kV": "0.25",
    }


def timed(fn):
    t0 = time.perf_counter()
    out = fn()
    return out, time.perf_counter() - t0


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--points", type=int, default=16)
    parser.add_argument("--json", action="store_true")
    parser.add_argument("--quick", action="store_true")
    args = parser.parse_args()
    points = 4 if args.quick else args.points
    from coexist.sweep import evaluate_point, make_spec, sweep

    log = sys.stderr if args.json else sys.stdout
    vary = grid(points)
    spec = make_spec("tricircle", vary)
    evaluate_point(spec, 0)  # warm-up: the model's code loaded (or compiled once per machine)
    print(
        f"sweep of {spec.size} points ({', '.join(f'{k}={v}' for k, v in vary.items())}); {os.cpu_count()} cores",
        file=log,
    )
    base, t1 = timed(lambda: sweep("tricircle", vary))
    rows = [("serial (this process)", 1, t1)]
    print(f"  serial: {t1:.2f} s, {spec.size / t1:.2f} points/s", file=log)

    def check(res, name):
        if res.records != base.records:
            raise SystemExit(f"{name}: records differ from the serial sweep")

    for n in (1, 2):
        res, t = timed(lambda n=n: sweep("tricircle", vary, workers=n, chunk_size=1))
        check(res, f"pool of {n}")
        rows.append((f"local pool, {n} process(es)" + (" (= serial: no pool)" if n == 1 else ""), n, t))
        print(f"  pool {n}: {t:.2f} s", file=log)
    try:
        import distributed
    except ImportError:
        distributed = None
    if distributed is not None:
        for n in (2, 4):
            with (
                distributed.LocalCluster(
                    n_workers=n, threads_per_worker=1, processes=True, dashboard_address=None, silence_logs=40
                ) as lc,
                distributed.Client(lc) as client,
            ):
                client.submit(sum, [1]).result()  # the workers are up
                res, t = timed(lambda client=client: sweep("tricircle", vary, client=client, chunk_size=1))
                check(res, f"LocalCluster of {n}")
                rows.append((f"Dask LocalCluster, {n} processes", n, t))
                print(f"  dask {n}: {t:.2f} s", file=log)
    scaling = []
    if not args.quick:
        for p in (4, 8, 16):
            v = grid(p)
            size = make_spec("tricircle", v).size
            _, t = timed(lambda v=v: sweep("tricircle", v))
            scaling.append((size, t))
    results = {
        "points": spec.size,
        "cores": os.cpu_count(),
        "runs": [
            {
                "what": what,
                "workers": n,
                "seconds": t,
                "points_per_second": spec.size / t,
                "speedup": t1 / t,
                "efficiency": t1 / (min(n, os.cpu_count() or 1) * t),
            }
            for what, n, t in rows
        ],
        "scaling": [{"points": p, "seconds": t} for p, t in scaling],
    }
    if len(scaling) >= 2:
        (p0, s0), (p1, s1) = scaling[0], scaling[-1]
        results["seconds_per_point"] = (s1 - s0) / (p1 - p0)
        results["seconds_fixed"] = s0 - results["seconds_per_point"] * p0
        results["log_log_slope"] = math.log(s1 / s0) / math.log(p1 / p0)
    if args.json:
        print(json.dumps(results, indent=1))
        return 0
    print()
    print(f"{'what':<44} {'wall s':>7} {'points/s':>9} {'speed-up':>9} {'efficiency':>10}")
    for r in results["runs"]:
        print(
            f"{r['what']:<44} {r['seconds']:7.2f} {r['points_per_second']:9.2f} {r['speedup']:8.2f}× "
            f"{r['efficiency']:10.2f}"
        )
    print(
        "(speed-up = serial time / time; efficiency = serial time / (cores used × time), cores used = "
        "min(workers, cores); every run's records equal the serial ones bit for bit)"
    )
    if scaling:
        print("cost against points (serial): " + ", ".join(f"{p} points {t:.2f} s" for p, t in scaling))
        print(
            f"  ≈ {results['seconds_fixed']:.2f} s + {results['seconds_per_point']:.3f} s × points "
            f"(log-log slope {results['log_log_slope']:.2f})"
        )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
