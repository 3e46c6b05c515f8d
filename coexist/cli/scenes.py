"""``coexist scenes`` (list and show the built-in scenes) and ``coexist check`` (validate a scene)."""

from __future__ import annotations

import click

from .common import InputError, info, library_errors, load_scene_arg, printable, write_json


@click.group(invoke_without_command=True)
@click.pass_context
@library_errors
def scenes(ctx):
    """List the built-in scenes, one line each; 'coexist scenes show NAME' prints one."""
    if ctx.invoked_subcommand is not None:
        return
    from coexist.scene import DEFAULT_SCENE, builtin_scenes

    found = builtin_scenes()
    width = max(map(len, found))
    for name, description in found.items():
        mark = " (default)" if name == DEFAULT_SCENE else ""
        click.echo(f"{name:<{width}}  {description}{mark}")


@scenes.command()
@click.argument("name")
@library_errors
def show(name):
    """Print the TOML text of the built-in scene NAME (a starting point for your own)."""
    from coexist.scene import builtin_scene_text

    click.echo(builtin_scene_text(name), nl=False)


@click.command()
@click.argument("scene", metavar="FILE_OR_NAME")
@click.option("--json", "as_json", is_flag=True, help="Print the validated scene as JSON on stdout.")
@click.option("--no-solve", is_flag=True, help="Skip the one quick solve that checks the closing pressure.")
@library_errors
def check(scene, as_json, no_solve):
    """Validate a scene (a .toml file, a built-in name, or - for stdin).

    Besides the fields, one quick solve (the zero-voltage pressure–volume curve, ~0.1 s; ~1 s for a
    patterned zone) checks that the zones can hold the closing pressure (it must lie below their
    snap-through pressure).

    Prints the effects the scene selects and its dimensionless groups (docs/physics.md):
    p̂ = pA/(μH), V̂ = V/A³, Φ̂ = (Φ/H)√(ε/μ), Q̂ = Q/(A²√(εμ)), Ψ̂ = Ψ/(μHA²).
    Units are part of every key name: thickness_mm = 0.5, volume_ml = 300, stop_kV = 5.
    Suffixes: length _m _mm _um; shear modulus _Pa _kPa _MPa; pressure _Pa _kPa _mbar _bar;
    volume _m3 _l _ml; voltage _V _kV; field _V_per_m _MV_per_m.
    """
    from coexist.errors import SceneError

    loaded = load_scene_arg(scene)
    p_max = None
    name = "snap-through"
    held = loaded.chamber is not None or loaded.controlled_pressure is not None
    if held and not no_solve:
        from coexist.simulation import snap_through_pressure

        snap = _patterned_snap_through(loaded) if loaded.patterned else snap_through_pressure(loaded)
        p_max, is_max = snap.p_hat, snap.maximum
        name = "snap-through" if is_max else "largest pressure within the model's range (no snap-through)"
        try:
            loaded.check_closing_pressure(p_max, is_max)
        except SceneError as exc:
            raise InputError(f"{scene}: {exc}") from None
        if loaded.controlled_pressure is not None and not loaded.p_hat(loaded.controlled_pressure) < p_max:
            raise InputError(
                f"{scene}: {loaded.controlled_pressure_field}: the zones cannot hold "
                f"{loaded.controlled_pressure / 100:.4g} mbar: it is at or above their {name} "
                f"pressure ({loaded.pressure(p_max) / 100:.4g} mbar)"
            )
        # the closing state itself, as `coexist ramp` builds it (e.g. a pressure below the smallest computed state)
        from coexist.simulation import Simulation

        try:
            Simulation.from_scene(loaded)
        except SceneError as exc:
            raise InputError(f"{scene}: {exc}") from None
    cost = None
    if loaded.patterned:  # no ramp cost printed here; say what works (every command takes them)
        info(
            f'note: patterned zones (pattern "{loaded.electrode_pattern}"): `coexist curves --scene {scene}` computes '
            "their curves, `coexist ramp`, `coexist coexistence` and `coexist shape` their equilibria (several "
            "times a uniform scene's time); `coexist fit` fits their zone radius and `coexist sweep` sweeps them, "
            "[electrodes] and [layers] keys included"
        )
    elif not held:  # nothing holds a pressure: no equilibrium to follow, so no ramp cost (ramp refuses it)
        info(
            "note: no [chamber] and no [zones].pressure_mbar: `coexist ramp`, `coexistence`, `phase-diagram` and "
            "`shape` need one (a gas the zones share, or a controlled pressure), `coexist fit` a [chamber]; "
            "`coexist curves --scene` computes the zone's curves"
        )
    elif loaded.voltage is not None:
        from coexist.cost import ramp_cost

        cost = ramp_cost(loaded)
        try:
            cost.check()
        except SceneError as exc:
            raise InputError(f"{scene}: {exc}") from None
    if as_json:
        data = loaded.to_dict()
        if p_max is not None:
            data["snap_through_pressure_hat"] = p_max
            data["snap_through_is_maximum"] = name == "snap-through"
        if cost is not None:
            data["ramp_cost"] = {
                "voltages": cost.voltages,
                "rows": cost.rows,
                "numbers": cost.numbers,
                "seconds_estimate": cost.seconds,
                "memory_bytes_estimate": cost.memory_bytes,
            }
        write_json(data)
        return
    _print_scene(loaded)
    if cost is not None:
        click.echo(f"ramp cost (estimate): {cost.describe()}")
    if p_max is not None:
        held_hat = (
            loaded.closing_pressure_hat if loaded.chamber is not None else loaded.p_hat(loaded.controlled_pressure)
        )
        what = "closing pressure" if loaded.chamber is not None else "controlled pressure"
        click.echo(
            f"{what}: p̂ = {held_hat:.6g}, below the zones' {name} "
            f"p̂max = {p_max:.6g} ({loaded.pressure(p_max) / 100:.4g} mbar): a stable start"
        )


def _patterned_snap_through(scene):
    """The largest pressure one patterned zone of ``scene`` holds at zero voltage (a
    :class:`~coexist.simulation.Snap`): its first pressure maximum on the grid :func:`snap_through` uses, from
    :func:`~coexist.patterned.patterned_pressure_volume_curve` (exact states, the limit point refined), or the
    largest pressure of the curve if it has no maximum. About 1 s (a uniform zone: 0.1 s)."""
    import numpy as np

    from coexist.effects import NoElectrostatics
    from coexist.model import MembraneModel
    from coexist.patterned import patterned_pressure_volume_curve
    from coexist.settings import SolverSettings
    from coexist.simulation import Snap, pole_stretch_max

    settings = SolverSettings()
    base = scene.model()
    model = MembraneModel(base.elasticity, NoElectrostatics(), base.prestretch)
    pre, top = model.prestretch, pole_stretch_max(scene, settings)
    grid = pre * (1 + np.linspace(np.sqrt(2e-3), np.sqrt(top / pre - 1), settings.snap_grid_points) ** 2)
    curve = patterned_pressure_volume_curve(model, scene.zone_pattern(), 0.0, grid, settings)
    maxima = [lp for lp in curve.limit_points if lp.kind == "pressure_max"]
    if maxima:
        return Snap(float(maxima[0].p_hat), float(maxima[0].pole_stretch), True)
    i = int(np.nanargmax(np.where(curve.states.ok, curve.states.p_hat, np.nan)))
    return Snap(float(curve.states.p_hat[i]), float(curve.states.pole_stretch[i]), False)


def _print_scene(scene):
    click.echo(printable(f"scene {scene.name}: {scene.description}" if scene.description else f"scene {scene.name}"))
    click.echo(printable(f"source: {scene.source}"))
    click.echo("values (from the file, or the documented default where marked):")
    rows = scene.values()
    width = max(len(k) for k, _, _ in rows)
    for key, value, source in rows:
        click.echo(f"  {key:<{width}}  {value}" + ("  [default]" if source == "default" else ""))
    if scene.voltage is not None:
        click.echo(f"voltage path: {len(scene.voltage.values)} points")
    click.echo(f"effects: {', '.join(scene.effects())}")
    click.echo("dimensionless groups:")
    groups = scene.dimensionless_groups()
    width = max(map(len, groups))
    for key, value in groups.items():
        click.echo(f"  {key:<{width}}  {value:.6g}")
    if scene.fitted:
        click.echo("fitted:")
        for key, value in scene.fitted.items():
            click.echo(printable(f"  {key} = {value}"))
