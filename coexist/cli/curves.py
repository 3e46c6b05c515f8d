"""``coexist curves``: the p̂–V̂ and Φ̂–Q̂ families of one clamped zone."""

from __future__ import annotations

from pathlib import Path

import click

from ..settings import error_reference
from .common import (
    InputError,
    Outputs,
    accuracy_option,
    check_jlim,
    info,
    library_errors,
    load_scene_arg,
    material_options,  # noqa: I001
    parse_floats,
    settings_from,
    with_error,
    write_json,
)

#: estimated seconds from which the cost estimate is printed (shorter runs print nothing more)
LONG_RUN_SECONDS = 10.0


@click.command()
@click.option(
    "--scene",
    default=None,
    help="Take material, Jlim, prestretch, wrinkling and the electrode pattern from this scene (name or file).",
)
@click.option("--material", default=None, help="neo-hookean (default) or gent.")
@click.option("--jlim", type=float, default=None, help="Gent limiting stretch invariant Jlim (gent only), e.g. 97.")
@click.option("--prestretch", type=float, default=None, help="Equibiaxial prestretch λpre ≥ 1 (default 1).")
@click.option(
    "--wrinkling",
    type=click.Choice(["refuse", "tension-field"]),
    default=None,
    help="A state whose hoop tension would turn negative: no state (refuse, default) or wrinkled (tension-field).",
)
@click.option(
    "--pattern",
    type=click.Choice(["full", "inner-circle", "ring"]),
    default=None,
    help="Electrode pattern of the zone (default: the scene's, else full).",
)
@click.option(
    "--inner-fraction",
    "inner_fraction",
    type=float,
    default=None,
    help="inner-circle: the electrode disc's radius over the zone radius; ring: its inner edge (reference state).",
)
@click.option(
    "--outer-fraction", "outer_fraction", type=float, default=None, help="ring: its outer edge over the zone radius."
)
@click.option(
    "--passive-layers",
    "passive_layers",
    type=int,
    default=None,
    help="Layers of the regions without electrode (default: the scene's, else 1); the electrode region is one.",
)
@click.option(
    "--phi-hat",
    "phi_hat",
    default="0,0.05,0.1,0.15,0.2",
    show_default=True,
    help="Voltages Φ̂ of the pressure–volume curves, comma-separated ('none' to skip).",
)
@click.option(
    "--p-hat",
    "p_hat",
    default=None,
    help="Pressures p̂ of the voltage–charge curves, comma-separated ('none' to skip); default 1.2,1.5,1.7 "
    "(a patterned zone's three take about a second).",
)
@click.option(
    "--pole-stretch",
    "pole_stretch",
    default=None,
    help="Pole-stretch range 'start,stop' of every curve (default 1.01 λpre to max(4, 1.5 λpre); 1.01,4 without "
    "prestretch; a Gent membrane's ends at its equibiaxial locking stretch, and starts closer to λpre near it).",
)
@click.option("--points", type=click.IntRange(3, 5000), default=200, show_default=True, help="States per curve.")
@click.option("-o", "--plot", "plot", default=None, help="Write the figure here (.png, .svg or .pdf).")
@click.option("--json", "as_json", is_flag=True, help="Print the curves as JSON on stdout.")
@click.option("--csv", "csv_path", default=None, help="Write the curves as CSV to this file ('-' for stdout).")
@click.option("--overwrite", is_flag=True, help="Replace existing output files.")
@accuracy_option
@library_errors
def curves(
    scene,
    material,
    jlim,
    prestretch,
    wrinkling,
    pattern,
    inner_fraction,
    outer_fraction,
    passive_layers,
    phi_hat,
    p_hat,
    pole_stretch,
    points,
    plot,
    as_json,
    csv_path,
    overwrite,
    accuracy,
    rtol,
):
    """Pressure–volume curves at fixed voltage and voltage–charge curves at fixed pressure.

    All quantities are normalised (docs/physics.md): p̂ = pA/(μH), V̂ = V/A³, Φ̂ = (Φ/H)√(ε/μ),
    Q̂ = Q/(A²√(εμ)). Limit points (pressure, voltage and volume extrema) are located to the solver
    tolerance and marked.

    A patterned zone (--pattern inner-circle or ring, or a scene's [electrodes] pattern): an electrode
    region of one layer, passive regions of --passive-layers layers (coexist.patterned). Both families are
    computed, shot region by region (a Φ̂–Q̂ curve in under a second); its charge Q̂ is the electrode's only.
    """
    import numpy as np

    from coexist.curves import pressure_volume_curve, voltage_charge_curve
    from coexist.errors import ModelRangeError, SceneError
    from coexist.model import build_model

    settings = settings_from(accuracy, rtol, events=False)
    material, jlim, prestretch = material_options(scene, material, jlim, prestretch)
    sc = load_scene_arg(scene) if scene is not None else None
    if wrinkling is None:
        wrinkling = sc.wrinkling if sc is not None else "refuse"
    fields = _pattern_fields(sc, pattern, inner_fraction, outer_fraction, passive_layers)
    patterned = fields["electrode_pattern"] != "full"
    phis = [] if phi_hat.strip().lower() == "none" else parse_floats(phi_hat, "--phi-hat", nonnegative=True)
    defaulted_pressures = p_hat is None
    if p_hat is None:
        p_hat = "1.2,1.5,1.7"
    pressures = [] if p_hat.strip().lower() == "none" else parse_floats(p_hat, "--p-hat", positive=True)
    if not phis and not pressures:
        raise InputError("--phi-hat, --p-hat: both are 'none': no curve to compute")
    if pole_stretch is not None:
        lo, hi = parse_floats(pole_stretch, "--pole-stretch", positive=True, count=(2,))
        if hi <= lo:
            raise InputError(f"--pole-stretch: the range must increase, got {pole_stretch!r}")
    check_jlim(material, jlim)
    try:
        model = build_model(material, jlim=jlim, voltage=True, prestretch=prestretch, wrinkling=wrinkling)
    except SceneError as exc:
        raise InputError(f"--{(exc.field or 'material').replace('_', '-')}: {exc.message}") from None
    lam = model.prestretch
    if jlim is not None and 2 * lam**2 + lam**-4 - 3 >= jlim:  # as a scene's [membrane] is checked
        raise InputError(f"--prestretch: a prestretch of {lam:g} locks a Gent membrane with jlim = {jlim:g}")
    wider = ""  # a scene's zones are followed further than the default range: say how far, should it be needed
    if pole_stretch is None:  # the library's default range, which follows the prestretch
        lo, hi = 1.01 * model.prestretch, max(4.0, 1.5 * model.prestretch)
        lock = getattr(model.elasticity, "exact_locking_stretch", None)
        if lock is not None and lo >= model.prestretch + 0.5 * (lock - model.prestretch):
            # a prestretch near the Gent locking stretch (1.06 at Jlim 0.05, locking at 1.068): the default range
            # started past it, every state locked, and the command refused its own default (exit 2)
            lo = model.prestretch + 0.1 * (lock - model.prestretch)
        if lock is not None and lock < hi:  # no state at the pole stretches beyond it (Jlim 2: 1.554, not 4)
            hi = lock
        if sc is not None:
            from coexist.simulation import stretch_range_end

            end = stretch_range_end(model.elasticity, model.prestretch, settings)
            if end > hi:
                wider = f" (this scene's zones are followed up to λ0 = {end:.4g}: --pole-stretch {lo:.4g},{end:.4g})"
    if lo <= model.prestretch:
        raise InputError(f"--pole-stretch: must start above the prestretch {model.prestretch:g}, got {lo:g}")
    from coexist.cost import curves_cost

    cost = curves_cost(len(phis), len(pressures), points, patterned=patterned)
    cost.check()  # refused before any work: exit 2 naming --points (and what fits) or the lists
    if cost.seconds >= LONG_RUN_SECONDS:
        info(f"estimated cost: {cost.describe()}")
    out = Outputs(overwrite)
    plot_path = out.figure(plot, "--plot")
    csv_target = out.data(csv_path, "--csv", ".csv")
    if as_json:
        out.stdout("--json")
    grid = np.linspace(lo, hi, points)
    pv, vq = [], []
    zone = None
    if patterned:
        from coexist.scene import zone_pattern

        zone = zone_pattern(*fields.values())
    for phi in phis:
        try:
            if zone is not None:
                from coexist.patterned import patterned_pressure_volume_curve

                pv.append(patterned_pressure_volume_curve(model, zone, phi, grid, settings))
            else:
                pv.append(pressure_volume_curve(model, phi, grid, settings))
        except ModelRangeError as exc:
            raise _no_curve(exc, "--phi-hat", f"Φ̂ = {phi:g}", wider) from None
        _note(pv[-1])
    if zone is not None and pressures:
        from coexist.patterned import PatternedModel

        # the zone's model (refusing wrinkled states): solve_states shoots it region by region
        zone_model = PatternedModel(model.elasticity, model.electrostatics, model.prestretch, "refuse", zone)
    for p in pressures:
        try:
            vq.append(voltage_charge_curve(model if zone is None else zone_model, p, grid, settings))
        except ModelRangeError as exc:
            if not defaulted_pressures:
                raise _no_curve(exc, "--p-hat", f"p̂ = {p:g}", wider) from None
            # a default pressure this zone does not reach with any voltage: said, not fatal
            info(f"note: no Φ̂–Q̂ curve at the default p̂ = {p:g}: {exc}")
            continue
        _note(vq[-1])
    data = {
        "model": model.describe() | ({} if zone is None else {"pattern": _pattern_dict(fields, zone)}),
        "settings": {"relative_tolerance": settings.rtol, "points": points, "pole_stretch_range": [lo, hi]},
        "curves": [c.to_dict() for c in pv + vq],
    }
    with out:
        if plot_path is not None:
            from coexist.plotting import plot_curves

            plot_curves(pv, vq, out.staged(plot_path), title=_title(model, zone))
        if isinstance(csv_target, Path):
            from coexist.curves import curves_csv

            out.write_text(csv_target, curves_csv(pv + vq))
    if csv_target == "-":
        from coexist.curves import curves_csv

        click.echo(curves_csv(pv + vq), nl=False)
        _summary(pv, vq, settings, err=True)  # the CSV holds the states; the limit points go beside it, to stderr
    elif as_json:
        write_json(data)
    else:
        _summary(pv, vq, settings)


def _no_curve(exc, option: str, value: str, wider: str = "") -> Exception:
    """The error of a curve that failed at ``value`` of ``option``: when the zone has no state at that value
    anywhere in the pole-stretch range, the value is out of the model's range for that range, bad input (an
    :class:`InputError` naming the option, exit 2); any other failure keeps its kind (exit 1), the value named.
    ``wider``: a ``--pole-stretch`` range to suggest (a scene's, where the default range stops short of it)."""
    from coexist.errors import ModelRangeError, NoStateInRange

    text = str(exc)
    if isinstance(exc, NoStateInRange):
        where = text.removeprefix("no valid state anywhere").lstrip()
        return InputError(
            f"{option}: the zone has no state at {value} {where}; take another value or --pole-stretch range"
            f"{wider}, or another membrane (--jlim, --prestretch, the pattern: a state missing at every voltage, "
            "Φ̂ = 0 too, is theirs)"
        )
    return ModelRangeError(f"{value} ({option}): {text}", exc.reason)


def _title(model, zone=None):
    d = model.describe()
    s = d["material"] + (f", Jlim = {d['jlim']:g}" if "jlim" in d else "")
    s += f", λpre = {model.prestretch:g}" if model.prestretch != 1 else ""
    return s if zone is None else f"{s}\nregions R/A {zone.describe()}"


def _pattern_fields(sc, pattern, inner, outer, passive) -> dict:
    """The zone's pattern: each option, else the scene's value where the pattern uses it, else the default
    (full, one passive layer); checked by :func:`coexist.scene_format.pattern_fields`, errors naming the option
    (or the scene's field when the value came from the scene)."""
    from coexist.errors import SceneError
    from coexist.scene_format import pattern_fields

    options = {
        "pattern": "--pattern",
        "inner_fraction": "--inner-fraction",
        "outer_fraction": "--outer-fraction",
        "passive": "--passive-layers",
    }
    from_scene = set()
    if pattern is None:
        pattern = sc.electrode_pattern if sc is not None else "full"
        from_scene.add("pattern")
    if sc is not None and sc.electrode_pattern != "full":  # the scene's edges and layers, where they still apply
        if inner is None and pattern in ("inner-circle", "ring") and sc.inner_fraction is not None:
            inner = sc.inner_fraction
            from_scene.add("inner_fraction")
        if outer is None and pattern == "ring" and sc.outer_fraction is not None:
            outer = sc.outer_fraction
            from_scene.add("outer_fraction")
        region_layers = None
        if passive is None and pattern == sc.electrode_pattern and sc.region_layers is not None:
            region_layers = sc.region_layers  # the scene's [layers] regions, where its pattern still applies
            from_scene.add("regions")
        elif passive is None and pattern != "full":
            passive = sc.passive_layers
            from_scene.add("passive")
    else:
        region_layers = None
    passive = 1 if passive is None else passive

    def where(name):
        if name in from_scene and sc is not None:
            return f"{sc.name or sc.source}: [{'layers' if name in ('passive', 'regions') else 'electrodes'}].{name}"
        return options.get(name, name)

    try:
        return pattern_fields(pattern, inner, outer, passive, where, region_layers=region_layers)
    except SceneError as exc:
        raise InputError(str(exc)) from None


def _pattern_dict(fields, zone) -> dict:
    return {
        "name": fields["electrode_pattern"],
        "inner_fraction": fields["inner_fraction"],
        "outer_fraction": fields["outer_fraction"],
        "passive_layers": fields["passive_layers"],
        "region_layers": None if fields.get("region_layers") is None else list(fields["region_layers"]),
        "regions": [{"outer": r.outer, "layers": r.layers, "electrode": r.electrode} for r in zone.regions],
    }


def _note(curve):
    name = "Φ̂" if curve.family == "pressure_volume" else "p̂"
    if curve.starts_because:
        info(f"note: curve at {name} = {curve.fixed:g} starts late: {curve.starts_because}")
    if curve.stopped_because:
        info(f"note: curve at {name} = {curve.fixed:g} stops early: {curve.stopped_because}")


def _summary(pv, vq, settings, err=False):
    again = error_reference(settings).rtol
    click.echo(
        f"limit points (relative tolerance {settings.rtol:.0e}; each number ± its error, measured by locating the"
        f" limit point again at rtol {again:.0e}):",
        err=err,
    )
    for curves, held, shown in (
        (pv, "Φ̂", (("p̂", "p_hat"), ("V̂", "v_hat"))),
        (vq, "p̂", (("Φ̂", "phi_hat"), ("Q̂", "q_hat"))),
    ):
        for c in curves:
            for lp in c.limit_points:
                e = lp.errors or {}
                numbers = "  ".join(
                    f"{name} = {with_error(getattr(lp, attr), e.get(attr))}"
                    for name, attr in (("λ0", "pole_stretch"), *shown)
                )
                note = "" if lp.errors is not None else "  (error not measured)"
                click.echo(f"  {held} = {c.fixed:<6g} {lp.kind:<13} {numbers}{note}", err=err)
    if not any(c.limit_points for c in (*pv, *vq)):
        click.echo("  none on these curves", err=err)
