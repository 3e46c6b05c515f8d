"""``coexist ramp``: the voltage ramp of a scene, up and back down, with its transitions."""

from __future__ import annotations

import click

from ..settings import SolverSettings, tight_settings
from .common import (
    Outputs,
    accuracy_option,
    column_format,
    format_voltage,
    info,
    library_errors,
    load_scene_arg,
    settings_from,
    stderr_progress,
    voltage_decimals,
    write_json,
)

#: points of each zone's profile in ``--shapes --json`` (sparse: for a plot, not for the numbers)
SHAPE_POINTS = 41


@click.command()
@click.argument("scene", required=False, metavar="[SCENE]")
@click.option("-o", "--plot", "plot", default=None, help="Figure of zone volumes against voltage (.png/.svg/.pdf).")
@click.option(
    "--states-plot",
    "states_plot",
    default=None,
    help="Figure of the p̂–V̂ curve at the first voltage with bulged zones, states marked (Fig. 7c).",
)
@click.option("--json", "as_json", is_flag=True, help="Print the ramp as JSON on stdout instead of the table.")
@click.option(
    "--every",
    type=click.IntRange(1, 10_000),
    default=1,
    show_default=True,
    help="Print (and put in --json) every n-th voltage; the first, the last and every change of configuration always.",
)
@click.option(
    "--shapes",
    is_flag=True,
    help="Add each zone's apex height, apex curvature and electrode edge per step (with --json also its "
    f"profile, {SHAPE_POINTS} points; see `coexist shape`).",
)
@click.option("--overwrite", is_flag=True, help="Replace existing output files.")
@accuracy_option
@library_errors
def ramp(scene, plot, states_plot, as_json, every, shapes, overwrite, accuracy, rtol):
    """Ramp the voltage of SCENE (default: tricircle) up and back down, following a slow experiment.

    The zones stay in the stable state they are in until the voltage reaches the end of its stable
    range (an event located on the exact equilibrium equations: a fold, a symmetric branch point, the
    onset of wrinkling, ...); then they jump to the state a gradient flow of the total potential
    reaches, or leave the model's range. Every printed state is converged on the exact equations;
    every transition voltage carries its measured error (located again at rtol/100).
    """
    from coexist.simulation import Simulation

    sc = load_scene_arg(scene)  # patterned zones too (their shapes region by region)
    settings = settings_from(accuracy, rtol)
    with Outputs(overwrite) as out:
        plot_path = out.figure(plot, "--plot")
        states_path = out.figure(states_plot, "--states-plot")
        info(f"scene {sc.name or sc.source}: effects {', '.join(sc.effects())}")
        from coexist.cost import ramp_cost

        cost = ramp_cost(sc, every)  # a scene without [voltage] is refused here, before any work or progress
        cost.check(every)
        info(f"estimated cost: {cost.describe()}")
        sim = Simulation.from_scene(sc, settings)  # refuses a closing pressure the zones cannot hold, first
        info("following the stable states along the voltage path ...")
        n = len(sc.voltage_hat_path)
        with stderr_progress(n, "ramp") as bar:
            report = sim.ramp(progress=lambda i: bar.update(1))
        if shapes:
            info("computing the zones' shapes ...")
        data = report.to_dict(every, shapes=shapes, shape_points=SHAPE_POINTS if as_json else 0)
        if plot_path is not None:
            from coexist.plotting import plot_ramp_volumes

            info("tracing the visited configurations' branches for the figure ...")
            branches = sim.branches(report.result.segments)
            plot_ramp_volumes(report, out.staged(plot_path), title=_title(sc), branches=branches)
        if states_path is not None:
            _states_figure(report, sim, states_path, out)
    if as_json:
        write_json(data)
        return
    _table(data)


def _title(sc):
    mat = sc.material + (f" Jlim={sc.jlim:g}" if sc.jlim else "")
    return (
        f"{sc.name}: {sc.zone_count} zones, A = {sc.zone_radius * 1e3:.4g} mm, {mat}, "
        f"H = {sc.thickness * 1e3:g} mm, μ = {sc.shear_modulus / 1e3:g} kPa"
    )


def _states_figure(report, sim, path, out):
    from coexist.plotting import plot_coexisting_states
    from coexist.zone_curves import ZoneCurve

    for s in report.result.steps:
        if s.state is not None and s.state.k > 0:
            import numpy as np

            pre = sim.model.prestretch
            u = np.linspace(np.sqrt(1e-3 * pre), np.sqrt(sim.lam_max - pre), sim.settings.zone_curve_points)
            curve = ZoneCurve.compute(sim.model, s.phi_hat, pre + u**2, sim.settings)
            kv = report.voltage_kV(s.phi_hat)
            plot_coexisting_states(
                curve,
                s.state,
                f"{report.scene.name}: coexisting states at {kv:.3g} kV, "
                f"{report.pressure_mbar(s.state.p_hat):.4g} mbar",
                out.staged(path),
            )
            return
    info(f"note: no bulged state on the path; {path} not written")


#: significant figures of the largest value of each of the table's columns: pressure and volume (the tricircle's
#: 20 mbar and 53 ml: the four and three decimals the table always had), apex height and curvature (--shapes: 40 mm
#: with two decimals; 44 /m with two, one more than before: 3 would print a 10 mm zone's 88.1 to 101.9 /m as 88 to 102)
PRESSURE_DIGITS, VOLUME_DIGITS, HEIGHT_DIGITS, CURVATURE_DIGITS = 6, 5, 4, 4


def _volumes(step, fmt) -> str:
    """The zones' volumes of one row: each zone's for up to six zones, else per group (``999×10.798``)."""
    if step["zone_volumes_ml"] is None:
        return "-"
    if len(step["zone_volumes_ml"]) <= 6:
        return " ".join(fmt(v) for v in step["zone_volumes_ml"])
    return " ".join(f"{g['zones']}×{fmt(g['volume_ml'])}" for g in step["groups"])


def _apex(step, height, curvature) -> str:
    """The zones' apex heights in mm (and curvatures in 1/m) of one row, as :func:`_volumes` lays them out."""
    if not step.get("shapes"):
        return "-"
    per_zone = [g for g in step["shapes"] for _ in range(g["zones"])]
    if len(per_zone) <= 6:
        return " ".join(f"{height(g['apex_height_mm'])}/{curvature(g['apex_curvature_per_m'])}" for g in per_zone)
    return " ".join(
        f"{g['zones']}×{height(g['apex_height_mm'])}/{curvature(g['apex_curvature_per_m'])}" for g in step["shapes"]
    )


def _table(data):
    steps = data["steps"]
    shapes = any("shapes" in s for s in steps)
    # the voltages with the decimals the scene's path needs (its step; 3 for the tricircle's 0.02 kV), the pressures
    # and volumes with a fixed number of significant figures: any scale, from µm zones at volts to metres at 100 kV
    path = ((data.get("scene") or {}).get("voltage") or {}).get("values_V")
    places = voltage_decimals([v / 1e3 for v in path] if path else [s["voltage_kV"] for s in steps])
    pressure = column_format([s["pressure_mbar"] for s in steps], PRESSURE_DIGITS)
    volume = column_format([v for s in steps for v in s["zone_volumes_ml"] or ()], VOLUME_DIGITS)
    shown = [g for s in steps for g in s.get("shapes") or ()]
    height = column_format([g["apex_height_mm"] for g in shown], HEIGHT_DIGITS)
    curvature = column_format([g["apex_curvature_per_m"] for g in shown], CURVATURE_DIGITS)
    # the columns widen for long numbers (and stay lined up)
    kv_width = max([10] + [len(f"{s['voltage_kV']:.{places}f}") for s in steps])
    p_width = max([13] + [len(pressure(s["pressure_mbar"])) for s in steps if s["pressure_mbar"] is not None])
    v_width = max([28] + [len(_volumes(s, volume)) for s in steps])
    extra = f"  {'apex_height_mm/apex_curvature_per_m'}" if shapes else ""
    click.echo(
        f"{'voltage_kV':>{kv_width}} {'dir':>4} {'pressure_mbar':>{p_width}}  {'zone_volumes_ml':<{v_width}} "
        f"{'configuration':<18} stable" + extra
    )
    prev = None
    for s in steps:
        changed = prev is not None and s["configuration"] != prev
        # a jump onto another branch of the same configuration (a fold inside it) changes no label: its note says
        within = prev is not None and not changed and "note" in s and s["configuration"] != "none"
        prev = s["configuration"]
        p = "-" if s["pressure_mbar"] is None else pressure(s["pressure_mbar"])
        mark = "  <- " + s.get("note", "transition") if changed or within else ""
        if within and s.get("note") == "transition":
            mark += f" onto another branch of {s['configuration']}"
        wrinkled = [f"{100 * f:.0f}%" if f > 0 else "taut" for f in s.get("wrinkled_area_fraction") or []]
        if any(w != "taut" for w in wrinkled):  # a tension-field scene: which zones are wrinkled, how much
            mark += "  wrinkled: " + " ".join(wrinkled)
        for note in s.get("state_notes", []):  # what the state itself says (e.g. taken at a branch point)
            mark += f"  [{note}]"
        click.echo(
            f"{s['voltage_kV']:>{kv_width}.{places}f} {s['direction']:>4} {p:>{p_width}}  "
            f"{_volumes(s, volume):<{v_width}} {s['configuration']:<18} "
            f"{'yes' if s['stable'] else 'no'}{mark}" + (f"  {_apex(s, height, curvature)}" if shapes else "")
        )
    click.echo("")
    again = tight_settings(SolverSettings(rtol=data["relative_tolerance"])).rtol
    click.echo(f"transitions (voltage ± its error, measured by locating it again at rtol {again:.0e}):")
    if not data["transitions"]:
        kv = [s["voltage_kV"] for s in data["steps"]]
        click.echo(
            f"  none between {min(kv):g} and {max(kv):g} kV: the zones stay on one stable branch (states the ramp "
            "does not visit, and their equal free energy with it, are listed by `coexist coexistence`)"
            if kv
            else "  none: the path has no voltage"
        )
    for t in data["transitions"]:
        click.echo(
            f"  {t['kind']:<18} {t['direction']:<6} {format_voltage(t['voltage_kV'], t['voltage_error_kV']):<26}"
            f" {t['from']} -> {t['to']}  [{t['event']}]"
            + ("  (another branch of the same configuration)" if t["from"] == t["to"] and t["from"] != "none" else "")
            # an error that could not be measured (the re-location failed) is the location's bracket alone
            + ("" if t.get("error_measured", True) else "  (error not measured: its bracket only)")
        )
    if any(t["kind"] == "re_entry" and t["event"] == "range_end" for t in data["transitions"]):
        # the model's convention, not a prediction (review, helper-77): past a pull-in a real membrane may be damaged
        click.echo(
            "(re_entry: coming back below where the states left the model's range, the ramp takes the state it left; "
            "a membrane that went past a pull-in may have thinned or broken down there, which the model cannot say)"
        )
    click.echo(f"(every state converged on the exact equations, solver rtol {data['relative_tolerance']:.0e})")
    for note in data["notes"]:
        info(f"note: {note}")
    if data["fitted_parameters"]:
        for k, v in data["fitted_parameters"].items():
            info(f"fitted: {k}: {v}")
