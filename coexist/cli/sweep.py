"""``coexist sweep``: the scene's ramp at every point of a grid of scene fields (a design map)."""

from __future__ import annotations

import click

from .common import (
    InputError,
    Outputs,
    accuracy_option,
    column_format,
    info,
    library_errors,
    load_scene_arg,
    settings_from,
)

#: significant figures of the table's largest voltage (the tricircle's 3.9 kV: six decimals)
VOLTAGE_DIGITS = 7


@click.command()
@click.argument("scene", required=False, metavar="[SCENE]")
@click.option(
    "--vary",
    "vary",
    multiple=True,
    metavar="KEY=START:STOP:N|KEY=v1,v2,...",
    help="A scene field and its values, units in the key as in a scene file, e.g. "
    "chamber.closing_pressure_mbar=19.5:20.5:5 or membrane.material=gent,neo-hookean (repeat for a grid; a "
    "material other than gent drops the scene's jlim at its points, and is refused with membrane.jlim swept).",
)
@click.option("-o", "--output", "output", default=None, help="Write the sweep to this netCDF file (.nc).")
@click.option("--plot", "plot", default=None, help="Design-map figure (.png/.svg/.pdf) over the last two swept keys.")
@click.option(
    "--map",
    "variable",
    default="spinodal_up_kV",
    show_default=True,
    help="The quantity the design map colours by (e.g. hysteresis_kV, equal_free_energy_kV).",
)
@click.option(
    "--workers",
    type=click.IntRange(1, 256),
    default=None,
    help="Local worker processes. Default: a pool over the machine's cores, as many as give each worker at least "
    "two points (a worker costs about 1.5 s to start, a point about a second); 1 computes in this process.",
)
@click.option("--scheduler", default=None, metavar="ADDRESS", help="Compute on this Dask scheduler (tcp://host:8786).")
@click.option(
    "--resume", is_flag=True, help="Continue an interrupted sweep from OUTPUT.parts (computes only what is missing)."
)
@click.option("--overwrite", is_flag=True, help="Replace existing output files.")
@accuracy_option
@library_errors
def sweep(scene, vary, output, plot, variable, workers, scheduler, resume, overwrite, accuracy, rtol):
    """Run the ramp of SCENE (default: tricircle) at every point of a grid of scene fields.

    Per point: the voltage where the homogeneous zones lose stability up (spinodal) and where they return down, the
    hysteresis, the first jump of the zones' state up and down (where a continuous split is followed by a fold
    inside the bulged configuration, the fold), the voltage of equal
    free energy, breakdown, where each configuration is lost, the configuration at the top of the ramp
    and a status with the reason where a point has no answer. Every voltage is an event of the exact
    continuation, with its measured error. Finished chunks go to OUTPUT.parts as they finish, so an
    interrupted sweep resumes (--resume) with only the missing points.
    """
    from coexist import sweep as sw

    if not vary:
        raise InputError("--vary: give at least one KEY=START:STOP:N or KEY=v1,v2,...")
    if resume and output is None:
        raise InputError("--resume: needs -o FILE.nc (the parts of an interrupted sweep are kept beside it)")
    sc = load_scene_arg(scene)
    settings = settings_from(accuracy, rtol)
    spec = sw.make_spec(sc, list(vary), settings)
    for note in sw.spec_notes(spec):
        info(f"note: {note}")
    if variable not in sw.FLOAT_FIELDS:
        raise InputError(f"--map: unknown quantity {variable!r}; use one of {', '.join(sw.FLOAT_FIELDS)}")
    with Outputs(overwrite) as out:
        out_path = out.data(output, "-o", ".nc")
        if out_path == "-":
            raise InputError("-o: a netCDF file cannot go to stdout; give a file name")
        plot_path = out.figure(plot, "--plot")
        if plot_path is not None and sum(n > 1 for n in spec.shape) < 2:
            raise InputError("--plot: a design map needs two --vary keys with more than one value each")
        folder = sw.parts_folder(out_path) if out_path is not None else None
        if folder is not None:
            sw.check_parts_folder(folder)
        if folder is not None and folder.exists() and any(folder.iterdir()) and not resume and not overwrite:
            raise InputError(
                f"-o: {folder} holds an interrupted sweep: --resume continues it (--overwrite discards it)"
            )
        client = _client(scheduler)
        if workers is None:
            workers = default_workers(spec.size)
        try:
            n_workers = workers if client is None else sum(client.nthreads().values())
            cost = sw.sweep_cost(spec, n_workers)
            cost.check()
            info(f"scene {sc.name or sc.source}: {spec.size} points over {', '.join(a.key for a in spec.axes)}")
            info(f"estimated cost: {cost.describe()}")
            from .common import stderr_progress

            with stderr_progress(spec.size, "sweep") as bar:
                result = sw.sweep(
                    sc,
                    list(spec.axes),
                    settings,
                    workers=workers,
                    client=client,
                    output=out_path,
                    resume=resume,
                    overwrite=overwrite,
                    progress=bar.update,
                )
        except KeyboardInterrupt:
            if folder is not None:
                info(f"interrupted: the finished chunks are in {folder}; run again with --resume to continue")
            raise
        finally:
            if client is not None:
                client.close()
        if out_path is not None:
            info(f"wrote {out_path}")
        if plot_path is not None:
            sw.plot_design_map(result.to_xarray(), out.staged(plot_path), variable, title=_title(sc, result))
    _report(result)


def _client(address):
    if address is None:
        return None
    try:
        from distributed import Client
    except ImportError:
        raise InputError("--scheduler: needs dask.distributed: pip install 'coexist[sweep]'") from None
    try:
        return Client(address, timeout="10s")
    except (OSError, TimeoutError, ValueError) as exc:
        raise InputError(f"--scheduler: cannot connect to {address!r} ({exc})") from None


def _title(sc, result):
    counts = ", ".join(f"{k} {v}" for k, v in sorted(result.counts().items()))
    return f"{sc.name or sc.source}: {result.spec.size} points ({counts}); rtol {result.spec.settings.rtol:g}"


def _report(result):
    """A table of the points on stdout: swept values, jump up, return, hysteresis, status."""
    keys = [ax.key for ax in result.spec.axes]
    voltages = ("spinodal_up_kV", "spinodal_down_kV", "jump_up_kV", "jump_down_kV")
    # every voltage (the hysteresis too) with the decimals that give the largest seven significant figures: any scale
    fmt = column_format([r.get(k) for r in result.records for k in voltages], VOLTAGE_DIGITS)

    def cell(x):
        if x is None:
            return "-"
        text = fmt(x)
        # (a hysteresis within rounding of zero, e.g. −7e-10 kV inside its ±4e-9, is printed 0.000000, not −0.000000)
        return fmt(0.0) if float(text) == 0 else text

    rows = [
        [cell(r.get(k)) for k in ("spinodal_up_kV", "spinodal_down_kV", "hysteresis_kV", "jump_up_kV", "jump_down_kV")]
        for r in result.records
    ]
    heads = ("up_kV", "down_kV", "hyst_kV", "jump_up", "jump_dn")
    widths = [max([10 if h != "hyst_kV" else 9] + [len(row[i]) for row in rows]) for i, h in enumerate(heads)]
    click.echo(
        "  ".join(f"{k:>24}" for k in keys) + "  " + " ".join(f"{h:>{w}}" for h, w in zip(heads, widths)) + " status"
    )
    for r, row in zip(result.records, rows):
        values = result.spec.values_at(r["index"])
        cells = "  ".join(f"{v:>24.6g}" if isinstance(v, float) else f"{v!s:>24}" for v in values)
        reason = f"  ({r['reason']})" if r["status"] != "bulges" and r["reason"] else ""
        numbers = " ".join(f"{c:>{w}}" for c, w in zip(row, widths))
        click.echo(f"{cells}  {numbers} {r['status']}{reason}")
    counts = ", ".join(f"{k}: {v}" for k, v in sorted(result.counts().items()))
    info(
        f"{result.spec.size} points ({counts}); computed {result.computed}, reused {result.reused}, "
        f"{result.retried_chunks} chunk(s) retried; {result.seconds:.1f} s on {result.workers} worker(s) "
        f"({result.executor})"
    )


def default_workers(points: int) -> int:
    """The local pool's default size: the machine's cores, but no more workers than half the points.

    Parameters
    ----------
    points : int
        Points of the sweep.

    Returns
    -------
    int
        At least 1.
    """
    import os

    return max(1, min(os.cpu_count() or 1, points // 2))
