"""``coexist shape``: the zones' shapes at chosen voltages of the slow ramp up (side view, apex numbers)."""

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
    parse_floats,
    settings_from,
    significant,
    voltage_decimals,
    write_json,
)

#: zones drawn one by one in the side view; more are drawn one per group of identical zones
MAX_DRAWN_ZONES = 12
#: zones printed one by one in the table; more are printed per group (as ``coexist ramp`` does)
MAX_LISTED_ZONES = 6
#: most voltages one --voltage-kV range may give
MAX_VOLTAGES = 2000
#: side views drawn in the lens figure of a patterned zone (spread over the voltages reached)
LENS_SIDE_VIEWS = 5
#: estimated seconds from which the cost estimate is printed (shorter runs print nothing more)
LONG_RUN_SECONDS = 10.0
#: significant figures of the table's largest apex height and curvature, and of its lengths (radius of curvature,
#: edges): the tricircle's 40 mm and 44 /m with six decimals, its 27 and 21.4 mm with four
APEX_DIGITS, LENGTH_DIGITS = 8, 6
#: significant figures of a voltage in a note (an end's bracket: 4.359050 kV)
NOTE_DIGITS = 7


@click.command()
@click.argument("scene", required=False, metavar="[SCENE]")
@click.option(
    "--voltage-kV",
    "voltages",
    default="0",
    show_default=True,
    help="Voltages in kV (0 to the scene's stop), visited on the slow ramp up: comma-separated, or a range "
    "START:STOP:STEP (STOP included when on the grid).",
)
@click.option(
    "-o",
    "--plot",
    "plot",
    default=None,
    help="Side view of the zones at each voltage (.png/.svg/.pdf); for a patterned zone the lens figure: side "
    "views at a few voltages and the apex curvature and height against the voltage.",
)
@click.option("--json", "as_json", is_flag=True, help="Print the shapes (with their profile points) as JSON.")
@click.option(
    "--points",
    type=click.IntRange(3, 100_001),
    default=201,
    show_default=True,
    help="Points per zone profile (equally spaced in the reference radius, pole and clamp included).",
)
@click.option("--overwrite", is_flag=True, help="Replace an existing figure file.")
@accuracy_option
@library_errors
def shape(scene, voltages, plot, as_json, points, overwrite, accuracy, rtol):
    """The shape of every zone of SCENE (default: tricircle) at the voltages --voltage-kV.

    For each voltage: the state of the zones on a slow ramp up from 0 V to that voltage (the ramp's
    stable state, so after the transition one zone is bulged and the others not), and per zone its
    apex height (mm), apex curvature (1/m: the curvature of the meridian at the pole, a lens's focal
    figure of merit, exact from the Laplace law p = 2 t κ0 of the equibiaxial pole) with its radius
    of curvature (mm), and the electrode edges (mm, from the pole out: the clamp for a uniform electrode,
    both edges of a ring). -o draws the zones side by side at each voltage, to scale, every edge marked.
    A hoop-wrinkled zone (a tension-field scene; uniform or patterned) has its profile too, integrated through
    the wrinkled band on the relaxed equations; there r is the geometric radius of the wrinkled surface
    (docs/physics.md section 11), and -o marks the band.

    One patterned zone (e.g. the inner-circle scene): the states on its gas (or at its controlled pressure)
    continued from the closing state, each a converged patterned state (hoop-wrinkled ones relaxed in a
    tension-field scene); the states stop where the branch ends (a snap-through, past which `coexist ramp`
    follows the zone on another branch if a stable one exists; wrinkling, in a scene that refuses it; pull-in:
    named, the voltage bisected); -o draws the lens figure. Several patterned zones on one gas: the ramp's
    states, as for uniform zones, each zone's profile region by region.
    """
    from coexist.ramp import Ramp
    from coexist.shapes import equilibrium_profiles
    from coexist.simulation import Simulation

    sc = load_scene_arg(scene)  # a patterned zone: its own path (_patterned)
    settings = settings_from(accuracy, rtol)
    kv = parse_voltages(voltages)
    if sc.voltage is None:
        if any(v != 0 for v in kv):
            raise InputError(f"--voltage-kV: the scene {sc.name or sc.source} has no [voltage]; only 0 kV is possible")
    else:
        stop = sc.voltage.peak / 1e3
        over = [v for v in kv if v > stop * (1 + 1e-12)]
        if over:
            raise InputError(f"--voltage-kV: {over[0]:.12g} kV is above the scene's stop, {stop:.12g} kV ([voltage])")
    from coexist.cost import MAX_GROUPS, shape_cost

    one_patterned = sc.patterned and sc.zone_count == 1
    cost = shape_cost(len(kv), 1 if one_patterned else min(MAX_GROUPS, sc.zone_count), points)
    cost.check()  # refused before any work: exit 2 naming --points (and what fits) or --voltage-kV
    if cost.seconds >= LONG_RUN_SECONDS:
        info(f"estimated cost: {cost.describe()}")
    if one_patterned:  # one patterned zone: its own path, and the lens figure
        _patterned(sc, settings, kv, plot, as_json, points, overwrite)
        return
    with Outputs(overwrite) as out:
        plot_path = out.figure(plot, "--plot")
        info(f"scene {sc.name or sc.source}: effects {', '.join(sc.effects())}")
        sim = Simulation.from_scene(sc, settings)
        order = sorted(set(kv))
        phis = [float(sc.phi_hat(v * 1e3)) for v in order]
        info("following the stable states up to each voltage ...")
        result = Ramp(sim.emap, sim.lam_max).run(phis, sim.start)
        by_kv = dict(zip(order, result.steps))
        rows = []
        for v in kv:
            step = by_kv[v]
            st = step.state
            groups = [] if st is None else equilibrium_profiles(sim.model, st, sc.zone_radius, points, settings)
            rows.append((v, step, groups))
        data = _to_dict(sc, settings, rows)
        if plot_path is not None:
            _figure(sc, rows, out.staged(plot_path))
    if as_json:
        write_json(data)
        return
    _table(data)


def parse_voltages(text: str) -> list[float]:
    """``--voltage-kV``: ``"0,2,4"`` or a range ``"START:STOP:STEP"`` (``STOP`` included when it lies on the grid,
    to 1e-9 of a step), or an :class:`InputError` naming the option.

    Parameters
    ----------
    text : str
        The option's value.

    Returns
    -------
    list of float
        The voltages in kV (not negative).
    """
    import math

    if ":" not in str(text):
        values = parse_floats(text, "--voltage-kV", nonnegative=True)
        twice = sorted({v for v in values if values.count(v) > 1})
        if twice:  # the same state twice (sweep refuses a repeated value too: review, helper-74)
            raise InputError(f"--voltage-kV: {twice[0]:g} kV is given more than once")
        return values
    parts = str(text).replace(" ", "").split(":")
    if len(parts) != 3:
        raise InputError(f"--voltage-kV: a range is START:STOP:STEP, got {text!r}")
    try:
        start, stop, step = (float(x) for x in parts)
    except ValueError:
        raise InputError(f"--voltage-kV: a range is START:STOP:STEP with numbers, got {text!r}") from None
    if not all(math.isfinite(x) for x in (start, stop, step)):
        raise InputError(f"--voltage-kV: values must be finite, got {text!r}")
    if start < 0:
        raise InputError(f"--voltage-kV: values must not be negative, got {text!r}")
    if not step > 0:
        raise InputError(f"--voltage-kV: the step must be positive, got {step:g}")
    if stop < start:
        raise InputError(f"--voltage-kV: the range must go up, got {start:g} to {stop:g}")
    n = math.floor((stop - start) / step + 1e-9)
    if n + 1 > MAX_VOLTAGES:
        raise InputError(f"--voltage-kV: {n + 1} voltages; at most {MAX_VOLTAGES}")
    return [float(f"{start + i * step:.12g}") for i in range(n + 1)]  # 12 digits, not 12 decimals of a kV


def _patterned(sc, settings, kv, plot, as_json, points, overwrite):
    """``coexist shape`` for one patterned zone: its states along the voltages (on its gas or at its controlled
    pressure, :func:`coexist.shapes.scene_zone_path`), their profiles and the lens figure (the voltages already
    checked by the caller). Patterned zones on one gas (several) take the ramp's path, as uniform ones."""
    from coexist.errors import SceneError
    from coexist.shapes import lens_ratio, patterned_profiles, scene_zone_path

    with Outputs(overwrite) as out:
        plot_path = out.figure(plot, "--plot")
        info(f"scene {sc.name or sc.source}: effects {', '.join(sc.effects())}")
        info(f"zone: regions R/A {sc.zone_pattern().describe()}")
        order = sorted(set(kv))
        phis = [float(sc.phi_hat(v * 1e3)) for v in order]
        info(f"following the patterned zone's states up through {len(order)} voltages ...")
        path, source = scene_zone_path(sc, phis, settings)
        reached = order[: path.phi_hat.size]
        profs = (
            patterned_profiles(
                sc.model(),
                sc.zone_pattern(),
                path.pole_stretch,
                path.phi_hat,
                zone_radius=sc.zone_radius,
                points=points,
                settings=settings,
            )
            if path.phi_hat.size
            else []
        )
        by_kv = dict(zip(reached, profs))
        end_kv = None if path.end_phi_hat is None else [float(sc.voltage_of(x)) / 1e3 for x in path.end_phi_hat]
        entries = []
        for v in kv:
            prof = by_kv.get(v)
            if prof is None:
                note = (
                    f"{path.end_kind}: no state above {significant(end_kv[0], NOTE_DIGITS)} kV"
                    if end_kv
                    else path.end_reason
                )
                entries.append({"voltage_kV": v, "configuration": "none", "groups": [], "note": note})
                continue
            entry = {
                "voltage_kV": v,
                "configuration": "1 zone",
                "pressure_mbar": float(sc.pressure(prof.p_hat) / 100),
                "groups": [{"zones": 1, **prof.to_dict(points=True)}],
            }
            try:
                entry["groups"][0]["lens_ratio"] = lens_ratio(prof)
            except SceneError:
                pass
            entries.append(entry)
        data = {
            "scene": sc.name or str(sc.source),
            "zone_radius_mm": sc.zone_radius * 1e3,
            "zones": sc.zone_count,
            "pattern": sc.zone_pattern().describe(),
            "relative_tolerance": settings.rtol,
            "voltages": entries,
            "end": None
            if path.end_kind is None
            else {"kind": path.end_kind, "reason": path.end_reason, "voltage_kV": end_kv},
        }
        if plot_path is not None:
            from coexist.plotting import plot_lens

            plot_lens(sc, reached, profs, data["end"], out.staged(plot_path), side_views=LENS_SIDE_VIEWS)
    if path.end_kind is not None:
        where = (
            ""
            if end_kv is None
            else f" between {significant(end_kv[0], NOTE_DIGITS)} and {significant(end_kv[1], NOTE_DIGITS)} kV"
        )
        info(f"the states end{where}: {path.end_kind}: {path.end_reason}")
    if as_json:
        write_json(data)
        return
    _table(data)


def _to_dict(sc, settings, rows) -> dict:
    entries = []
    for v, step, groups in rows:
        st = step.state
        entries.append(
            {
                "voltage_kV": v,
                "configuration": "none" if st is None else st.label,
                "pressure_mbar": None if st is None else float(sc.pressure(st.p_hat) / 100),
                "stable": False if st is None else bool(st.stable),
                "groups": [{"zones": n, **prof.to_dict(points=True)} for n, prof in groups],
                **({"note": step.note} if step.note else {}),
            }
        )
    return {
        "scene": sc.name or str(sc.source),
        "zone_radius_mm": sc.zone_radius * 1e3,
        "zones": sc.zone_count,
        "relative_tolerance": settings.rtol,
        "voltages": entries,
    }


def _zones(entry):
    """Rows of the table: ``(label, group)`` per zone for a few zones, else per group."""
    groups = entry["groups"]
    if sum(g["zones"] for g in groups) <= MAX_LISTED_ZONES:
        out, i = [], 1
        for g in groups:
            for _ in range(g["zones"]):
                out.append((str(i), g))
                i += 1
        return out
    return [(f"{g['zones']}×", g) for g in groups]


def _edges_text(group, length) -> str:
    """Every electrode edge of a zone, from the pole out, as ``(r, z) (r, z)`` in mm (a ring: inner, outer)."""
    edges = group.get("electrode_edges_mm") or [group["electrode_edge_mm"]]
    return " ".join(f"({length(r)}, {length(z)})" for r, z in edges)


def _table(data):
    rows = [(e, label, g) for e in data["voltages"] for label, g in _zones(e)]
    groups = [g for _, _, g in rows]
    # lengths and curvatures with a fixed number of significant figures (the same decimals down a column), the
    # voltages with the decimals they were given: any scale, from µm zones at volts to metres at 100 kV
    places = voltage_decimals([e["voltage_kV"] for e in data["voltages"]])
    height = column_format([g["apex_height_mm"] for g in groups], APEX_DIGITS)
    curvature = column_format([g["apex_curvature_per_m"] for g in groups], APEX_DIGITS)
    roc_of = column_format([g["radius_of_curvature_mm"] for g in groups], LENGTH_DIGITS)
    edges = [x for g in groups for edge in g.get("electrode_edges_mm") or [g["electrode_edge_mm"]] for x in edge]
    length = column_format(edges, LENGTH_DIGITS)
    several = any(len(g.get("electrode_edges_mm") or ()) > 1 for g in groups)
    head = "electrode_edges_mm (r, z), from the pole out" if several else "electrode_edge_mm (r, z)"
    width = max([len(head)] + [len(_edges_text(g, length)) for g in groups])
    kv_width = max([10] + [len(_kv(e["voltage_kV"], places)) for e in data["voltages"]])
    widths = {  # the headers' widths, wider where a number is longer
        "apex_height_mm": max([14] + [len(height(g["apex_height_mm"])) for g in groups]),
        "apex_curvature_per_m": max([20] + [len(curvature(g["apex_curvature_per_m"])) for g in groups]),
    }
    click.echo(
        f"{'voltage_kV':>{kv_width}} {'zone':>5} {'pole_stretch':>12} {'apex_height_mm':>{widths['apex_height_mm']}} "
        f"{'apex_curvature_per_m':>{widths['apex_curvature_per_m']}} {'radius_of_curvature_mm':>22} "
        f"{head:>{width}}  configuration"
    )
    for e in data["voltages"]:
        kv = _kv(e["voltage_kV"], places)
        if not e["groups"]:
            click.echo(f"{kv:>{kv_width}} {'-':>5} no state: {e.get('note') or 'outside the model range'}")
            continue
        for label, g in _zones(e):
            roc = "inf" if g["radius_of_curvature_mm"] is None else roc_of(g["radius_of_curvature_mm"])
            edge = _edges_text(g, length)
            bands = g.get("wrinkled_radii") or []
            wrinkled = "".join(f"; wrinkled for R/A {a:.4f}-{b:.4f}" for a, b in bands)
            click.echo(
                f"{kv:>{kv_width}} {label:>5} {g['pole_stretch']:>12.6f} "
                f"{height(g['apex_height_mm']):>{widths['apex_height_mm']}} "
                f"{curvature(g['apex_curvature_per_m']):>{widths['apex_curvature_per_m']}} {roc:>22} "
                f"{edge:>{width}}  {e['configuration']}{wrinkled}"
            )
    click.echo(
        f"(every state converged on the exact equations, solver rtol {data['relative_tolerance']:.0e}; "
        "apex curvature from the Laplace law at the pole)"
    )


def _kv(v: float, places: int) -> str:
    """A voltage asked for, in kV, with the table's decimals ``places`` (:func:`voltage_decimals` of the voltages asked
    for: three, or as many as they have), or more where it has more itself (3.90003 and 3.90004 kV were both printed
    3.900, one state uniform and the other with a zone bulged: review, helper-74)."""
    return f"{v:.{max(places, voltage_decimals([v]))}f}"


def _figure(sc, rows, path):
    """Side view: one panel per voltage, the zones side by side (true scale), as the paper's Fig. 6; hoop-wrinkled
    bands marked (:func:`coexist.plotting.mark_wrinkled_bands`)."""
    import textwrap

    from coexist.plotting import mark_wrinkled_bands, pyplot, save_figure

    plt = pyplot()
    A = sc.zone_radius * 1e3
    # a bulged zone may stand out past its clamp (r > λpre A): the pitch makes room for the widest one drawn, so that
    # no zone overlaps its neighbour or is cut off by the panel's edge
    widest = max([float(p.r.max()) * 1e3 for _, _, g in rows for _, p in g if p.r_hat.size] + [sc.prestretch * A])
    pitch = max(2 * sc.prestretch * A * 1.15, 2 * widest * 1.08)
    tops = [max(p.apex_height, float(p.z.max()) if p.z_hat.size else 0.0) * 1e3 for _, _, g in rows for _, p in g]
    zmax = max(tops + [0.2 * A])
    if sc.zone_count <= MAX_DRAWN_ZONES:
        span = sc.zone_count
    else:  # one drawing per group of identical zones
        span = max([len(g) for _, _, g in rows] + [1])
    x_lo, x_hi = -pitch / 2, (span - 0.5) * pitch
    y_lo, y_hi = -0.08 * zmax, 1.35 * zmax
    width = 9.0
    panel = max(1.4, width * 0.92 * (y_hi - y_lo) / (x_hi - x_lo)) + 0.55
    fig, axes = plt.subplots(len(rows), 1, figsize=(width, panel * len(rows) + 0.5), squeeze=False)
    mat = sc.material + (f" Jlim={sc.jlim:g}" if sc.jlim else "")
    head = f"{sc.name or sc.source}: {sc.zone_count} zones, A = {A:.4g} mm, {mat}; | electrode edges\n"
    for i_row, (ax, (v, step, groups)) in enumerate(zip(axes[:, 0], rows)):
        st = step.state
        total = sum(n for n, _ in groups)
        if total <= MAX_DRAWN_ZONES:
            drawn = [(None, p) for n, p in groups for _ in range(n)]
        else:
            drawn = [(n, p) for n, p in groups]
        bulged = groups[-1][1] if st is not None and st.k > 0 and len(groups) > 1 else None
        wrinkle_label = False  # one legend entry per panel
        for i, (n, p) in enumerate(drawn):
            c = i * pitch
            r, z = p.r * 1e3, p.z * 1e3
            xs = [c - x for x in r[::-1]] + [c + x for x in r]
            zs = list(z[::-1]) + list(z)
            color = "C3" if p is bulged else "C0"
            ax.fill(xs, zs, color=color, alpha=0.18, lw=0)
            ax.plot(xs, zs, color=color, lw=1.6)
            if mark_wrinkled_bands(ax, p, c, label=None if wrinkle_label else "hoop-wrinkled band (r: geometric)"):
                wrinkle_label = True
            for er, ez in ((r_e * 1e3, z_e * 1e3) for r_e, z_e in p.electrode_edges):  # a ring: inner and outer
                ax.plot([c - er, c + er], [ez, ez], "|", color="k", ms=9, mew=1.5)
            label = f"h {significant(p.apex_height * 1e3, 4)} mm\nκ0 {significant(p.apex_curvature, 3)} /m"
            if n is not None:
                label = f"{n} zones\n" + label
            ax.annotate(
                label,
                (c, p.apex_height * 1e3),
                xytext=(0, 3),
                textcoords="offset points",
                ha="center",
                va="bottom",
                fontsize=7,
            )
        ax.plot([x_lo, x_hi], [0, 0], color="0.35", lw=1.0)
        ax.set_xlim(x_lo, x_hi)
        ax.set_ylim(y_lo, y_hi)
        ax.set_aspect("equal")
        ax.set_ylabel("z (mm)")
        state = "no state" if st is None else f"{st.label}, {sc.pressure(st.p_hat) / 100:.4g} mbar"
        ax.set_title(("" if i_row else head) + f"{v:g} kV: {state}", fontsize=9)
        ax.grid(alpha=0.25)
        if st is None:
            why = textwrap.fill(step.note or "outside the model's range", 70)
            ax.text(0.5, 0.5, why, transform=ax.transAxes, ha="center", va="center", fontsize=8)
        if wrinkle_label:
            ax.legend(loc="upper right", fontsize=7)
    axes[-1, 0].set_xlabel("r (mm): the zones side by side, to scale")
    save_figure(fig, path)
