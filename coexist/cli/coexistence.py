"""``coexist coexistence``: the stable range of each number of bulged zones and its equal-free-energy voltages."""

from __future__ import annotations

import click

from .common import (
    accuracy_option,
    format_voltage,
    info,
    library_errors,
    load_scene_arg,
    parse_floats,
    settings_from,
    significant,
    write_json,
)

#: with more zones than this, the configurations to list must be named with --bulged (each is a continuation)
MAX_DEFAULT_CONFIGURATIONS = 12


@click.command()
@click.argument("scene", required=False, metavar="[SCENE]")
@click.option(
    "--bulged",
    default=None,
    metavar="K[,K...]",
    help="Numbers of bulged zones to list (default: all, 1..N-1, for up to 13 zones).",
)
@click.option("--json", "as_json", is_flag=True, help="Print the table as JSON on stdout.")
@accuracy_option
@library_errors
def coexistence(scene, bulged, as_json, accuracy, rtol):
    """For each k bulged zones of SCENE (default: tricircle): the voltages where k bulged zones are
    stable (each range with the events that end it, located on the exact equations; with the bulged zones'
    pole stretch along it where the configuration has several ranges: which branch), and the voltages
    where they have the free energy of the homogeneous state, or two branches each other's, with the
    coexisting states there.

    The same stable segments as `coexist ramp` (one map of the exact equilibria): the ramp's
    transitions are ends of these ranges. A scene without [voltage] lists every equilibrium of its
    zones on the closed gas at 0 V, with its stability.
    """
    from coexist.simulation import Simulation

    from .common import InputError

    sc = load_scene_arg(scene)
    settings = settings_from(accuracy, rtol)
    N = sc.zone_count
    ks = None
    if bulged is not None:
        values = parse_floats(bulged, "--bulged", positive=True)
        if any(k >= N or k != int(k) for k in values):  # checked before rounding: 1.5 is no number of zones
            raise InputError(f"--bulged: each value must be an integer in 1..{N - 1}, got {bulged!r}")
        ks = [int(k) for k in values]
    elif N - 1 > MAX_DEFAULT_CONFIGURATIONS:
        raise InputError(
            f"--bulged: this scene has {N} zones; name the numbers of bulged zones to list "
            f"(e.g. --bulged 1,2): each is a continuation of its own"
        )
    if N == 1:
        info(
            "note: one zone has no configurations of bulged and unbulged zones to list; its own bistability (a jump "
            "and its way back) is in `coexist ramp`, its equal-area pressures in `coexist phase-diagram`"
        )
    info("tracing the stable states of each configuration ...")
    sim = Simulation.from_scene(sc, settings)
    if sc.voltage is None:
        _without_voltage(sc, sim, as_json, ks)
        return
    rows = sim.coexistence(ks)
    kv = lambda phi: float(sc.voltage_of(phi) / 1e3)  # noqa: E731
    out = []

    def state(st):
        return {
            "pressure_mbar": float(sc.pressure(st.p_hat) / 100),
            "unbulged_volume_ml": float(sc.volume(st.v_unbulged) * 1e6),
            "bulged_volume_ml": float(sc.volume(st.v_bulged) * 1e6),
            "unbulged_pole_stretch": st.pole_stretch_unbulged,
            "bulged_pole_stretch": st.pole_stretch_bulged,
        }

    for r in rows:
        ranges = []
        for seg in r.segments:
            lo, hi = seg.low, seg.high
            ends = [seg.points[i].eq.pole_stretch for i in (seg._order[0], seg._order[-1])]
            ranges.append(
                {
                    "configuration": seg.label,
                    "from_kV": kv(seg.end_phi(-1)),
                    "from_error_kV": kv(getattr(lo, "error", 0.0) or 0.0),
                    "from_event": getattr(lo, "kind", "window") if lo is not None else "window",
                    "to_kV": kv(seg.end_phi(+1)),
                    "to_error_kV": kv(getattr(hi, "error", 0.0) or 0.0),
                    "to_event": getattr(hi, "kind", "window") if hi is not None else "window",
                    # the bulged zones' pole stretch at the range's lowest and highest traced state: which branch
                    "bulged_pole_stretch": [float(e[-1]) for e in ends],
                }
            )
        equal = []
        for c in r.crossings:
            where = {"voltage_kV": kv(c.phi_hat), "voltage_error_kV": kv(c.phi_hat_error)}
            if c.from_label == c.to_label:  # two branches of the configuration: both states
                equal.append(
                    where | {"between": "branches"} | state(c.state_after) | {"other_branch": state(c.state_before)}
                )
            else:
                st = c.state_after if c.to_label != "homogeneous" else c.state_before
                equal.append(where | {"between": "homogeneous"} | state(st))
        out.append(
            {
                "bulged_zones": r.k,
                "zones": N,
                "stable_ranges": ranges,
                "equal_free_energy": equal,
                **({"note": r.note} if r.note else {}),
            }
        )
    if as_json:
        write_json({"scene": sc.to_dict(), "relative_tolerance": sim.settings.rtol, "configurations": out})
        return
    for o in out:
        click.echo(f"{o['bulged_zones']} of {o['zones']} bulged:")
        if not o["stable_ranges"]:
            click.echo(f"  never stable: {o.get('note', '')}")
        elif o.get("note"):  # e.g. the ramp over the window stopped at a jump: what was not reached
            click.echo(f"  note: {o['note']}")
        several = len(o["stable_ranges"]) > 1
        for g in o["stable_ranges"]:
            plain = f"{o['bulged_zones']} of {o['zones']} bulged"
            which = "" if g["configuration"] == plain else f" [{g['configuration']}]"
            if several:  # which branch: the bulged zones' pole stretch along it
                which += " (bulged λ0 {:.4f} to {:.4f})".format(*g["bulged_pole_stretch"])
            click.echo(
                f"  stable from {format_voltage(g['from_kV'], g['from_error_kV'])} ({g['from_event']}) "
                f"to {format_voltage(g['to_kV'], g['to_error_kV'])} ({g['to_event']}){which}"
            )
        for e in o["equal_free_energy"]:
            at = format_voltage(e["voltage_kV"], e["voltage_error_kV"])
            if e["between"] == "branches":
                click.echo(
                    f"  equal free energy between two of its branches at {at}: {_described(e['other_branch'])}; "
                    f"and {_described(e)}"
                )
            else:
                click.echo(f"  equal free energy with the homogeneous state at {at}: {_described(e)}")
    click.echo(
        f"(exact equilibria, solver rtol {sim.settings.rtol:.0e}; errors measured by locating each "
        "voltage again at rtol/100)"
    )


def _described(e) -> str:
    """One coexisting state of an equal-free-energy entry: the pressure, each kind of zone's volume (six significant
    figures, at any scale) and pole stretch."""
    return (
        f"{significant(e['pressure_mbar'])} mbar, unbulged {significant(e['unbulged_volume_ml'])} ml "
        f"(λ0 {e['unbulged_pole_stretch']:.4f}), bulged {significant(e['bulged_volume_ml'])} ml "
        f"(λ0 {e['bulged_pole_stretch']:.4f})"
    )


def _without_voltage(sc, sim, as_json, ks):
    """A scene without voltage (e.g. two-balloons): every equilibrium of its zones at 0 V, with stability."""
    eqs = sim.equilibria_at(0.0, ks)
    out = [
        {
            "configuration": e.label,
            "bulged_zones": e.k,
            "stable": e.stable,
            "pressure_mbar": float(sc.pressure(e.p_hat) / 100),
            "zone_volumes_ml": [float(sc.volume(v) * 1e6) for v in e.zone_volumes],
            "pole_stretches": [float(x) for x in e.zone_pole_stretches],
            "free_energy_hat": e.free_energy,
            "hessian_min_eigenvalue": e.min_eigenvalue,
            "zone_index": list(e.zone_index),
        }
        for e in eqs
    ]
    if as_json:
        write_json({"scene": sc.to_dict(), "relative_tolerance": sim.settings.rtol, "equilibria_at_0V": out})
        return
    click.echo(f"{sc.name}: no voltage; the equilibria of {sc.zone_count} zones on the closed gas:")
    for o in out:
        vols = " ".join(significant(v) for v in o["zone_volumes_ml"])
        click.echo(
            f"  {o['configuration']:<16} {'stable' if o['stable'] else 'unstable':<9} "
            f"{significant(o['pressure_mbar'])} mbar  volumes {vols} ml"
        )
    click.echo(f"(states converged on the exact equations, rtol {sim.settings.rtol:.0e})")
