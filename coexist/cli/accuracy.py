"""``coexist accuracy``: what accuracy costs in time (work-precision of the headline outputs)."""

from __future__ import annotations

import os

import click

from .common import InputError, Outputs, info, library_errors, parse_floats, write_json


def _parse_studies(text: str) -> list[int]:
    values = parse_floats(text, "--study", positive=True)
    if any(v != int(v) or int(v) not in (1, 2, 3) for v in values):
        raise InputError(f"--study: expected study numbers among 1, 2, 3 (comma-separated), got {text!r}")
    out = []
    for v in values:
        if int(v) not in out:
            out.append(int(v))
    return out


@click.command()
@click.option(
    "--study",
    "study",
    default="1,2,3",
    show_default=True,
    help="Which studies, comma-separated: 1 p̂max of a p̂–V̂ curve, 2 Maxwell pressure of a Gent "
    "zone, 3 transition voltage of the tricircle scene.",
)
@click.option("--quick", is_flag=True, help="Fewer settings and cheaper references (for tests; about 15 s).")
@click.option("-o", "--plot", "plot", default=None, help="Write the work-precision figure here (.png, .svg or .pdf).")
@click.option("--json", "as_json", is_flag=True, help="Print the measurements as JSON on stdout.")
@click.option("--overwrite", is_flag=True, help="Replace an existing figure.")
@library_errors
def accuracy(study, quick, plot, as_json, overwrite):
    """What accuracy costs in time: error against a tight reference versus wall time.

    For each headline output, every solver setting the project offers (the integrator tolerance
    rtol, and the sampling: curve points, spline points) is timed (best of a few runs) and its
    relative error taken against a reference at rtol = 1e-13 on a denser sampling. The table says
    whether the project's default (rtol 1e-10, 200 curve points, 128 spline points) lies on the
    Pareto front of (time, error). Study 1 also gives the achieved error against the requested rtol;
    study 3 (the transition voltage) is an event located on the exact equations, so only rtol
    matters there. Timings depend on the machine and its load. The full run takes a few minutes.
    """
    from coexist.studies.accuracy import report, run_studies, summary_lines

    numbers = _parse_studies(study)
    out = Outputs(overwrite)
    plot_path = out.figure(plot, "--plot")
    if plot_path is None:
        info("note: no figure (pass -o figures/accuracy_cost.png to draw one)")
    try:
        load_before = os.getloadavg()
    except OSError:
        load_before = None
    if load_before is not None and load_before[0] > 0.5 * (os.cpu_count() or 1):
        info(f"note: the machine is busy (load {load_before[0]:.2f} on {os.cpu_count()} CPUs); timings will be slower")
    studies = run_studies(numbers, quick=quick, progress=info)
    with out:
        if plot_path is not None:
            from coexist.studies.plotting import plot_accuracy

            title = "What accuracy costs in time" + (" (quick)" if quick else "")
            plot_accuracy(studies, out.staged(plot_path), title=title)
    if as_json:
        write_json(report(studies, quick=quick, load_before=load_before))
    else:
        for s in studies:
            click.echo("\n".join(summary_lines(s)))
