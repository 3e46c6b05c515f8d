"""``coexist coexistence``: coexistence voltages and states of a scene, for each number of bulged zones."""

from __future__ import annotations

import click

from .common import accuracy_option, info, library_errors, load_scene_arg, scene_with_settings, write_json


@click.command()
@click.argument("scene", required=False, metavar="[SCENE]")
@click.option("--json", "as_json", is_flag=True, help="Print the table as JSON on stdout.")
@accuracy_option
@library_errors
def coexistence(scene, as_json, accuracy, rtol):
    """For each k = 1..N−1 bulged zones of SCENE (default: tricircle): where they are stable, the
    voltage at which they have the free energy of the homogeneous state, and the coexisting states."""
    from coexist.simulate import coexistence_table, prepare

    sc = scene_with_settings(load_scene_arg(scene), accuracy, rtol)
    info("shooting the zone curves ...")
    prep = prepare(sc)
    if sc.voltage is None:
        _without_voltage(sc, prep, as_json)
        return
    rows = coexistence_table(prep, sc)
    out = []
    for r in rows:
        st = r.state
        out.append({
            "bulged_zones": r.k,
            "zones": sc.zone_count,
            "stable_range_kV": r.stable_range_kV,
            "equal_free_energy_voltage_kV": r.equal_free_energy_kV,
            "pressure_mbar": None if st is None else sc.pressure(st.p_hat) / 100,
            "unbulged_volume_ml": None if st is None else sc.volume(st.v_unbulged) * 1e6,
            "bulged_volume_ml": None if st is None else sc.volume(st.v_bulged) * 1e6,
            "unbulged_pole_stretch": None if st is None else st.pole_stretch_unbulged,
            "bulged_pole_stretch": None if st is None else st.pole_stretch_bulged,
            **({"note": r.note} if r.note else {}),
        })
    if as_json:
        write_json({"scene": sc.to_dict(), "relative_tolerance": sc.settings.rtol, "configurations": out})
        return
    for o in out:
        rng = ", ".join(f"{a:.3f}–{b:.3f}" for a, b in o["stable_range_kV"]) or "none"
        click.echo(f"{o['bulged_zones']} of {o['zones']} bulged: stable at {rng} kV")
        if o["equal_free_energy_voltage_kV"] is None:
            click.echo(f"  no equal-free-energy voltage: {o.get('note', '')}")
        else:
            click.echo(f"  equal free energy with the homogeneous state at {o['equal_free_energy_voltage_kV']:.6f} kV:"
                       f" {o['pressure_mbar']:.4f} mbar, unbulged {o['unbulged_volume_ml']:.4f} ml "
                       f"(λ0 {o['unbulged_pole_stretch']:.4f}), bulged {o['bulged_volume_ml']:.4f} ml "
                       f"(λ0 {o['bulged_pole_stretch']:.4f})")
    click.echo(f"(solver rtol {sc.settings.rtol:.0e}; voltages bisected to 1e-9 kV on the interpolated curves)")


def _without_voltage(sc, prep, as_json):
    """A scene without voltage (e.g. two-balloons): every equilibrium of its zones at 0 V, with stability."""
    from coexist.simulate import closed_gas
    from coexist.zones import equilibria, polish

    gas = closed_gas(prep, sc)
    eqs = polish(prep.model, gas, equilibria(prep.family.curve(0.0), gas, sc.zone_count), sc.settings)
    out = [{"configuration": e.label, "bulged_zones": e.k, "stable": e.stable,
            "pressure_mbar": sc.pressure(e.p_hat) / 100,
            "zone_volumes_ml": [sc.volume(v) * 1e6 for v in e.zone_volumes],
            "free_energy_hat": e.free_energy} for e in sorted(eqs, key=lambda e: (e.k, e.free_energy))]
    if as_json:
        write_json({"scene": sc.to_dict(), "relative_tolerance": sc.settings.rtol, "equilibria_at_0V": out})
        return
    click.echo(f"{sc.name}: no voltage; the equilibria of {sc.zone_count} zones on the closed gas:")
    for o in out:
        vols = " ".join(f"{v:.4f}" for v in o["zone_volumes_ml"])
        click.echo(f"  {o['configuration']:<16} {'stable' if o['stable'] else 'unstable':<9} "
                   f"{o['pressure_mbar']:.4f} mbar  volumes {vols} ml")
    click.echo(f"(states re-solved by shooting to rtol {sc.settings.rtol:.0e})")
