"""``coexist ramp``: the voltage ramp of a scene, up and back down, with its transitions."""

from __future__ import annotations

import click

from .common import (
    accuracy_option,
    check_output_path,
    info,
    library_errors,
    load_scene_arg,
    scene_with_settings,
    stderr_progress,
    write_json,
)


@click.command()
@click.argument("scene", required=False, metavar="[SCENE]")
@click.option("-o", "--plot", "plot", default=None, help="Figure of zone volumes against voltage (.png/.svg/.pdf).")
@click.option("--states-plot", "states_plot", default=None,
              help="Figure of the p̂–V̂ curve at the first voltage with bulged zones, states marked (Fig. 7c).")
@click.option("--json", "as_json", is_flag=True, help="Print the ramp as JSON on stdout instead of the table.")
@click.option("--every", type=click.IntRange(1, 10_000), default=1, show_default=True,
              help="Print every n-th voltage of the table (transitions are always listed).")
@click.option("--overwrite", is_flag=True, help="Replace existing output files.")
@accuracy_option
@library_errors
def ramp(scene, plot, states_plot, as_json, every, overwrite, accuracy, rtol):
    """Ramp the voltage of SCENE (default: tricircle) up and back down, following a slow experiment.

    At each voltage the zones stay in the stable state they are in until it loses stability
    (a spinodal), then jump to the nearest stable state; the table marks the jumps, and the
    voltages where a bulged configuration has the free energy of the homogeneous one.
    """
    from coexist.simulate import prepare, simulate_ramp

    sc = scene_with_settings(load_scene_arg(scene), accuracy, rtol)
    plot_path = check_output_path(plot, overwrite, "--plot")
    states_path = check_output_path(states_plot, overwrite, "--states-plot")
    info(f"scene {sc.name or sc.source}: effects {', '.join(sc.effects())}")
    info("shooting the zone curves for every voltage of the ramp ...")
    prep = prepare(sc)
    n = len(sc.voltage_hat_path) if sc.voltage is not None else 0
    with stderr_progress(n, "ramp") as bar:
        report = simulate_ramp(sc, progress=lambda i: bar.update(1), prep=prep)
    data = report.to_dict()
    if plot_path is not None:
        from coexist.plotting import plot_ramp_volumes

        plot_ramp_volumes(report, plot_path, title=_title(sc))
        info(f"wrote {plot_path}")
    if states_path is not None:
        _states_figure(report, prep, states_path)
    if as_json:
        write_json(data)
        return
    _table(data, every)


def _title(sc):
    mat = sc.material + (f" Jlim={sc.jlim:g}" if sc.jlim else "")
    return (f"{sc.name}: {sc.zone_count} zones, A = {sc.zone_radius * 1e3:.4g} mm, {mat}, "
            f"H = {sc.thickness * 1e3:g} mm, μ = {sc.shear_modulus / 1e3:g} kPa")


def _states_figure(report, prep, path):
    from coexist.plotting import plot_coexisting_states

    for s in report.result.steps:
        if s.state is not None and s.state.k > 0:
            curve = prep.family.curve(s.phi_hat)
            kv = report.voltage_kV(s.phi_hat)
            plot_coexisting_states(curve, s.state, f"{report.scene.name}: coexisting states at {kv:.3g} kV, "
                                   f"{report.pressure_mbar(s.state.p_hat):.4g} mbar", path)
            info(f"wrote {path}")
            return
    info(f"note: no bulged state on the path; {path} not written")


def _table(data, every):
    trans = {}
    for t in data["transitions"]:
        if t["kind"] != "equal_free_energy":
            trans.setdefault((t["direction"], round(t["voltage_kV"], 2)), []).append(t)
    click.echo(f"{'voltage_kV':>10} {'dir':>4} {'pressure_mbar':>13}  {'zone_volumes_ml':<28} "
               f"{'configuration':<18} stable")
    prev = None
    for i, s in enumerate(data["steps"]):
        changed = prev is not None and s["configuration"] != prev
        prev = s["configuration"]
        if i % every and not changed and i != len(data["steps"]) - 1:
            continue
        vols = "-" if s["zone_volumes_ml"] is None else " ".join(f"{v:.3f}" for v in s["zone_volumes_ml"])
        p = "-" if s["pressure_mbar"] is None else f"{s['pressure_mbar']:.4f}"
        mark = "  <- " + s.get("note", "transition") if changed else ""
        click.echo(f"{s['voltage_kV']:>10.3f} {s['direction']:>4} {p:>13}  {vols:<28} {s['configuration']:<18} "
                   f"{'yes' if s['stable'] else 'no'}{mark}")
    click.echo("")
    click.echo("transitions:")
    for t in data["transitions"]:
        click.echo(f"  {t['kind']:<18} {t['direction']:<6} {t['voltage_kV']:.6f} kV  {t['from']} -> {t['to']}")
    err = data["curve_interpolation_error"]
    polished = all(s["polished"] for s in data["steps"] if s["configuration"] != "none")
    how = "re-solved by shooting to" if polished else "NOT all re-solved (see 'polished' in --json); solver"
    click.echo(f"(states {how} rtol {data['relative_tolerance']:.0e}; transitions bisected to 1e-7 in Φ̂ on "
               f"the interpolated curves, whose error is p̂ {err['p_hat']:.1e}, V̂ {err['v_hat']:.1e}, "
               f"Ψ̂ {err['psi_hat']:.1e})")
    for note in data["notes"]:
        click.echo(f"note: {note}")
    if data["fitted_parameters"]:
        for k, v in data["fitted_parameters"].items():
            click.echo(f"fitted: {k}: {v}")
