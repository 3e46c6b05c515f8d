"""``coexist phase-diagram``: binodal, spinodals and critical point of one zone in the (Φ̂, p̂) plane."""

from __future__ import annotations

import click

from .common import (
    InputError,
    Outputs,
    accuracy_option,
    check_jlim,
    decimals_for,
    info,
    library_errors,
    load_scene_arg,
    material_options,  # noqa: I001
    parse_floats,
    settings_from,
    write_json,
)


@click.command("phase-diagram")
@click.option(
    "--scene",
    default=None,
    help="Take [membrane] material, jlim and prestretch from this scene (name or file; --material/--jlim win), and "
    "its [electrodes] pattern and [layers]; nothing else (the diagram is normalised: no radius, thickness, "
    'modulus, chamber or voltage path), and not its wrinkling: the states are taut (wrinkling = "refuse").',
)
@click.option("--material", default=None, help="neo-hookean or gent (default gent).")
@click.option("--jlim", type=float, default=None, help="Gent Jlim (default 40, where the critical point is in range).")
@click.option("--phi-hat", "phi_range", default="0,0.36", show_default=True, help="Voltage range 'start,stop' of Φ̂.")
@click.option("--points", type=click.IntRange(3, 400), default=37, show_default=True, help="Voltages in the range.")
@click.option("-o", "--plot", "plot", default=None, help="Write the figure here (.png/.svg/.pdf).")
@click.option("--json", "as_json", is_flag=True, help="Print the diagram as JSON on stdout.")
@click.option("--overwrite", is_flag=True, help="Replace an existing figure.")
@accuracy_option
@library_errors
def phase_diagram(scene, material, jlim, phi_range, points, plot, as_json, overwrite, accuracy, rtol):
    """The (Φ̂, p̂) phase diagram of one clamped zone under pressure control: where bulged and unbulged
    states coexist (binodal, equal free energy), where each stops being stable (spinodals), and the
    critical point where they merge.

    The zone is taut everywhere (wrinkling = "refuse", whatever the scene says): a state whose hoop tension
    would turn compressive is no state and is left out; a tension-field scene gets a note saying so."""
    import numpy as np

    from coexist.coexistence import phase_diagram as compute
    from coexist.model import build_model
    from coexist.simulation import stretch_range_end

    settings = settings_from(accuracy, rtol)
    if scene is None and material is None:
        material = "gent"
    material, jlim, prestretch = material_options(scene, material, jlim, None)
    check_jlim(material, jlim)
    if material == "gent" and jlim is None:
        jlim = 40.0
    lo, hi = parse_floats(phi_range, "--phi-hat", nonnegative=True, count=(2,))
    if hi <= lo:
        raise InputError(f"--phi-hat: the range must increase, got {phi_range!r}")
    gent = material == "gent"
    model = build_model(material, jlim=jlim if gent else None, prestretch=prestretch)
    pattern = None
    if scene is not None:
        sc = load_scene_arg(scene)
        if sc.wrinkling != "refuse":
            info(
                f'note: {sc.name or scene} asks for wrinkling = "{sc.wrinkling}"; the phase diagram is of taut zones '
                '(wrinkling = "refuse"): states that would wrinkle are left out'
            )
        if sc.patterned:  # the zone's own regions: shot region by region (coexist.patterned)
            from coexist.patterned import PatternedModel

            pattern = sc.zone_pattern()
            model = PatternedModel.of(model, pattern)
            info(f"zone: regions R/A {pattern.describe()}")
    lmax = stretch_range_end(model.elasticity, prestretch, settings)
    out = Outputs(overwrite)
    plot_path = out.figure(plot, "--plot")
    info(f"{points} voltages ...")
    d = compute(model, np.linspace(lo, hi, points), lmax, settings)
    with out:
        if plot_path is not None:
            from coexist.plotting import plot_phase_diagram

            title = f"{material}" + (f", Jlim = {jlim:g}" if gent else "")
            title += f"; {pattern.describe()}" if pattern is not None else ""
            plot_phase_diagram(d, out.staged(plot_path), title=title)
    data = {"model": model.describe(), "relative_tolerance": settings.rtol, **d.to_dict()}
    if as_json:
        write_json(data)
        return
    click.echo(f"{'phi_hat':>8} {'p_spinodal_max':>15} {'p_binodal':>15} {'p_spinodal_min':>15}")
    # the voltages are the input grid: as many decimals (4 to 10) as keep neighbours apart
    places = next((k for k in range(4, 11) if np.unique(np.round(d.phi_hat, k)).size == d.phi_hat.size), 10)
    nan = np.full(d.phi_hat.size, np.nan)
    errs = [nan if e is None else e for e in (d.spinodal_max_error, d.binodal_error, d.spinodal_min_error)]
    for i, phi in enumerate(d.phi_hat):
        cells = (pressure_cell(x[i], e[i]) for x, e in zip((d.spinodal_max, d.binodal, d.spinodal_min), errs))
        click.echo(f"{phi:>8.{places}f} " + " ".join(f"{c:>15}" for c in cells))
    if d.critical_point:
        click.echo(
            f"critical point: Φ̂ = {d.critical_point[0]:.8f}, p̂ = {d.critical_point[1]:.6f}, "
            f"λ0 = {d.critical_point[2]:.4f}"
        )
    for n in d.notes:
        info(f"note: {n}")
    largest = [float(np.nanmax(e)) if np.isfinite(e).any() else None for e in errs]
    errors = ", ".join(
        f"{name} {e:.0e}" for name, e in zip(("spinodal max", "binodal", "spinodal min"), largest) if e is not None
    )
    click.echo(
        f"(solver rtol {settings.rtol:.0e}; every pressure converged on the exact shooting equations, first guesses "
        f"from splines of {settings.phase_diagram_points} shot states per voltage; errors measured at rtol/100"
        + (f", largest: {errors}" if errors else "")
        + ", digits printed as they support; a critical point's error in the notes)"
    )


def pressure_cell(p_hat: float, error: float) -> str:
    """A pressure with the decimals its measured error supports (``⌈−log10 error⌉``, 3 to 12), or ``-``.

    Parameters
    ----------
    p_hat, error : float
        The pressure and its error (NaN: no value).

    Returns
    -------
    str
        E.g. ``1.3194320301`` for an error of 1.6e-10.
    """
    import math

    if not (math.isfinite(p_hat) and math.isfinite(error)):
        return "-"
    return f"{p_hat:.{decimals_for(error)}f}"
