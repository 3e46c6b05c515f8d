"""``coexist fit``: the zone radius that puts the transition at an observed voltage, and a sensitivity table."""

from __future__ import annotations

from dataclasses import replace

import click

from .common import InputError, accuracy_option, info, library_errors, load_scene_arg, scene_with_settings, write_json


@click.command()
@click.argument("scene", required=False, metavar="[SCENE]")
@click.option("--transition-kV", "target_kv", type=float, default=3.9, show_default=True,
              help="Observed transition voltage (the paper: equal at 3.8 kV, one zone bulged at 4.0 kV).")
@click.option("--kind", type=click.Choice(["spinodal", "equal_free_energy"]), default="spinodal", show_default=True,
              help="Which transition is observed: a slow ramp's jump (spinodal) or the equal-free-energy voltage.")
@click.option("--json", "as_json", is_flag=True, help="Print the fit and the sensitivity table as JSON.")
@accuracy_option
@library_errors
def fit(scene, target_kv, kind, as_json, accuracy, rtol):
    """Fit the zone radius of SCENE (default: tricircle) so that the first transition of its ramp lies
    at --transition-kV, then show how the prediction moves with radius, μ, closing pressure and chamber."""
    from coexist.simulate import fit_zone_radius, prepare, sensitivity, transition_voltage

    if not target_kv > 0:
        raise InputError(f"--transition-kV: must be positive, got {target_kv:g}")
    sc = scene_with_settings(load_scene_arg(scene), accuracy, rtol)
    if sc.chamber is None or sc.voltage is None:
        raise InputError(f"{sc.name}: fitting needs a scene with [chamber] and [voltage]")
    info("shooting the zone curves ...")
    prep = prepare(sc)
    radius = fit_zone_radius(sc, target_kv * 1e3, kind, prep)
    fitted = replace(sc, zone_radius=radius)
    check = transition_voltage(prep, fitted, kind) / 1e3
    info("sensitivity (each input moved by ±1 %) ...")
    rows = sensitivity(fitted)
    data = {"fitted_parameter": "zone_radius_mm", "zone_radius_mm": radius * 1e3, "kind": kind,
            "target_kV": target_kv, "transition_kV_at_fit": check, "sensitivity": rows,
            "relative_tolerance": sc.settings.rtol}
    if as_json:
        write_json(data)
        return
    click.echo(f"fitted zone radius: {radius * 1e3:.6f} mm  ({kind} transition at {check:.6f} kV, "
               f"target {target_kv:g} kV)")
    click.echo("")
    click.echo(f"{'input':<24}{'value':>12}{'spinodal_kV':>14}{'equal_G_kV':>14}")
    for r in rows:
        v = "" if r["value"] is None else f"{r['value']:.5g}"
        s = "-" if r["spinodal"] is None else f"{r['spinodal']:.4f}"
        e = "-" if r["equal_free_energy"] is None else f"{r['equal_free_energy']:.4f}"
        click.echo(f"{r['parameter']:<24}{v:>12}{s:>14}{e:>14}")
    click.echo("('-': no stable start, the zones cannot hold the closing pressure, or no transition in range)")
    click.echo(f"(solver rtol {sc.settings.rtol:.0e}; voltages bisected to 1e-9 kV on interpolated curves whose "
               "error `coexist ramp` reports, ~1e-5 relative)")
