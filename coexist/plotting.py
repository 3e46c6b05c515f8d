"""Figures. matplotlib is imported only here (and only when a figure is drawn)."""

from __future__ import annotations

from pathlib import Path


def pyplot():
    """matplotlib's pyplot on the non-interactive Agg backend (imported on first use).

    Returns
    -------
    module
        :mod:`matplotlib.pyplot`.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


_MARKERS = {
    "pressure_max": "v",
    "pressure_min": "^",
    "volume_max": "s",
    "volume_min": "s",
    "voltage_max": "v",
    "voltage_min": "^",
    "charge_max": "D",
    "charge_min": "D",
}


def _family_panel(ax, curves, x, y, label, xlabel, ylabel, title):
    """One family of curves (attributes ``x`` against ``y`` of states and limit points), labelled."""
    for c in curves:
        (line,) = ax.plot(getattr(c.states, x), getattr(c.states, y), lw=1.6, label=label.format(c.fixed))
        for lp in c.limit_points:
            ax.plot(
                getattr(lp, x),
                getattr(lp, y),
                _MARKERS.get(lp.kind, "o"),
                color=line.get_color(),
                ms=6,
                mec="k",
                mew=0.6,
            )
    ax.set_xlabel(xlabel)
    ax.set_ylabel(ylabel)
    ax.set_title(title)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)


def drawable(text: str) -> str:
    """``text`` as a figure can draw it: control characters shown as ``\\xNN`` escapes, line breaks kept (no font
    has a glyph for a control character).

    Parameters
    ----------
    text : str
        E.g. a title with a scene's name.

    Returns
    -------
    str
        :func:`coexist.validation.escaped` of ``text``, keeping ``"\\n"``.
    """
    from .validation import escaped

    return escaped(text, keep="\n")


def save_figure(fig, path, title=None, title_size=10) -> Path:
    """Lay out ``fig`` and write it to ``path`` atomically: drawn into a temporary file in the same folder,
    then renamed over ``path``, so a failure leaves no half-written figure (and no old one destroyed)
    (:func:`coexist.files.atomic`: the permissions ``open()`` would give, a symbolic link written through).

    Parameters
    ----------
    fig : matplotlib.figure.Figure
        The figure; it is closed afterwards, also on failure.
    path : str or pathlib.Path
        The file to write (its folder must exist); the suffix selects the format. Drawn at 130 dpi.
    title : str, optional
        Title over the whole figure.
    title_size : float
        Its font size in points.

    Returns
    -------
    pathlib.Path
        ``path``.
    """
    from matplotlib.text import Text

    from .files import atomic

    plt = pyplot()
    path = Path(path)
    try:
        if title:
            fig.suptitle(title, fontsize=title_size)
        for text in fig.findobj(Text):  # a scene's name may carry control characters: no font draws them
            raw = text.get_text()
            if not all(ch.isprintable() or ch in " \n" for ch in raw):
                text.set_text(drawable(raw))
        fig.tight_layout()
        with atomic(path) as tmp:
            fig.savefig(tmp, dpi=130)
    finally:
        plt.close(fig)
    return path


def plot_curves(pv_curves, vq_curves, path: str | Path, title: str | None = None):
    """The ``p̂–V̂`` family (left) and the ``Φ̂–Q̂`` family (right), limit points marked.

    Parameters
    ----------
    pv_curves : list of Curve
        ``p̂–V̂`` curves (:func:`~coexist.curves.pressure_volume_curve`), one per ``Φ̂``.
    vq_curves : list of Curve
        ``Φ̂–Q̂`` curves (:func:`~coexist.curves.voltage_charge_curve`), one per ``p̂``; empty: no right panel.
    path : str or pathlib.Path
        The file to write (:func:`save_figure`).
    title : str, optional
        Title over the figure.

    Returns
    -------
    pathlib.Path
        ``path``.
    """
    plt = pyplot()
    panels = 2 if vq_curves else 1
    fig, axes = plt.subplots(1, panels, figsize=(5.2 * panels, 4.2), squeeze=False)
    _family_panel(
        axes[0, 0],
        pv_curves,
        "v_hat",
        "p_hat",
        "Φ̂ = {:g}",
        "volume  V̂ = V/A³",
        "pressure  p̂ = pA/(μH)",
        "pressure–volume at fixed voltage",
    )
    if vq_curves:
        _family_panel(
            axes[0, 1],
            vq_curves,
            "q_hat",
            "phi_hat",
            "p̂ = {:g}",
            "charge  Q̂ = Q/(A²√(εμ))",
            "voltage  Φ̂ = (Φ/H)√(ε/μ)",
            "voltage–charge at fixed pressure",
        )
    return save_figure(fig, path, title)


def plot_ramp_volumes(report, path, title=None, branches=()):
    """Zone volumes against voltage: the branches of the configurations the ramp visits (stable solid,
    unstable dashed; traced on the exact equations), the ramp path with its jumps, transitions marked.

    Parameters
    ----------
    report : RampReport
        The ramp (:meth:`~coexist.simulation.Simulation.ramp`); volumes in ml, voltages in kV.
    path : str or pathlib.Path
        The file to write (:func:`save_figure`).
    title : str, optional
        Title of the axes.
    branches : iterable of Branch
        Branches drawn behind the path (:meth:`~coexist.simulation.Simulation.branches`).

    Returns
    -------
    pathlib.Path
        ``path``.
    """
    plt = pyplot()
    import numpy as np

    res = report.result
    fig, ax = plt.subplots(figsize=(7.2, 4.6))
    path_kV = [report.voltage_kV(s.phi_hat) for s in res.steps]
    # the branches are drawn over the voltages they were traced over, from 0 V to the path's top (the last point of
    # a direction lies a continuation step past them)
    window = (min(0.0, *path_kV), max(path_kV)) if path_kV else (-np.inf, np.inf)
    for br in branches:
        # the branch's points and, where stability changes between two of them, the exact event there
        nodes = [(p.s, p.eq, p.stable, p.stable) for p in br.points]
        nodes += [
            (e.s, e.eq, e.stable_before, e.stable_after)
            for e in br.events
            if e.eq is not None and e.stable_before != e.stable_after
        ]
        nodes.sort(key=lambda n: n[0])
        if len(nodes) < 2:
            continue
        for g in range(len(nodes[0][1].v_hat)):
            run = [nodes[0]]
            for node in nodes[1:]:
                run.append(node)
                if node[2] != node[3] or node is nodes[-1]:  # a stability change (or the end) closes the run
                    stable = run[0][3] if len(run) > 1 else run[0][2]
                    ax.plot(
                        *_clipped(
                            [report.voltage_kV(n[1].phi_hat) for n in run],
                            [report.volume_ml(n[1].v_hat[g]) for n in run],
                            window,
                        ),
                        "-" if stable else "--",
                        color="0.55" if stable else "0.72",
                        lw=1.0 if stable else 0.9,
                        zorder=1,
                    )
                    run = [node]
    for direction, color, size in (("down", "tab:blue", 2.0), ("up", "tab:red", 3.5)):
        pts = [
            (report.voltage_kV(s.phi_hat), [report.volume_ml(v) for v in s.state.zone_volumes])
            for s in res.steps
            if s.direction == direction and s.state is not None
        ]
        if not pts:
            continue
        x = np.array([p[0] for p in pts])
        width = max(len(p[1]) for p in pts)
        for j in range(width):
            y = np.array([p[1][j] if j < len(p[1]) else np.nan for p in pts])
            ax.plot(
                x,
                y,
                ".",
                color=color,
                ms=size,
                zorder=3 if direction == "up" else 2,
                label=f"ramp {direction}" if j == 0 else None,
            )
    # zones in a hoop-wrinkled state (a tension-field scene): ringed
    wr = [
        (report.voltage_kV(s.phi_hat), report.volume_ml(v))
        for s in res.steps
        if s.state is not None and s.state.wrinkled_fraction
        for v, f in zip(s.state.zone_volumes, _per_zone(s.state.wrinkled_fraction, s.state.configuration.counts))
        if f > 0
    ]
    if wr:
        ax.plot(*zip(*wr), "o", mfc="none", mec="k", ms=6, mew=0.8, zorder=4, label="wrinkled zone")
    top = ax.get_ylim()[1]
    for t in res.transitions:
        if t.kind in ("spinodal", "no_stable_state", "merge", "breakdown"):
            kv = report.voltage_kV(t.phi_hat)
            ax.axvline(kv, color="tab:red" if t.direction == "up" else "tab:blue", ls=":", lw=1)
            if t.kind == "no_stable_state" and t.direction == "up":  # why the states end there
                parts = (t.reason or "").split(": ")
                why = (parts[1] if len(parts) > 1 else parts[0]).replace("_", " ")
                ax.text(kv, top, f" {kv:.5g} kV: {why}", fontsize=7, va="top", ha="left", rotation=90)
    for t in res.equal_free_energy:
        ax.axvline(report.voltage_kV(t.phi_hat), color="k", ls="-.", lw=0.8)
    ax.plot([], [], "-", color="0.55", label="stable equilibria")
    ax.plot([], [], "--", color="0.72", label="unstable equilibria")
    ax.plot([], [], ":", color="tab:red", label="transitions")
    ax.plot([], [], "-.", color="k", label="equal free energy")
    ax.set_xlabel("voltage (kV)")
    ax.set_ylabel("zone volume (ml)")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8, loc="upper left")
    if title:
        ax.set_title(title, fontsize=10)
    return save_figure(fig, path)


def _clipped(x, y, window):
    """The polyline ``(x, y)`` cut to ``window[0] ≤ x ≤ window[1]``: a piece that crosses an edge ends on it
    (linear between its points), the pieces outside are left out (NaN breaks the line between pieces)."""
    import numpy as np

    lo, hi = window
    xs, ys = [], []
    for i in range(len(x)):
        inside = lo <= x[i] <= hi
        if i > 0:
            x0, x1 = x[i - 1], x[i]
            # the edges this piece crosses, in the order it crosses them (one piece may cross both)
            cuts = sorted(((e - x0) / (x1 - x0), e) for e in (lo, hi) if (x0 - e) * (x1 - e) < 0)
            for t, edge in cuts:
                xs.append(edge)
                ys.append(y[i - 1] + t * (y[i] - y[i - 1]))
        if inside:
            xs.append(x[i])
            ys.append(y[i])
        elif xs and not np.isnan(xs[-1]):  # left the window (also from a point on its edge): break the line
            xs.append(np.nan)
            ys.append(np.nan)
    return np.array(xs, dtype=float), np.array(ys, dtype=float)


def _per_zone(values, counts):
    """Per-group values repeated for every zone of the group."""
    return [v for v, n in zip(values, counts) for _ in range(n)]


def plot_coexisting_states(curve, state, scale_title, path):
    """The paper's Fig. 7(c): the p̂–V̂ curve at the transition voltage, coexisting states marked.

    Parameters
    ----------
    curve : ZoneCurve
        One zone's curve at the state's voltage.
    state : Equilibrium
        The zones' state; its unbulged (and, if any, bulged) zones are marked at its pressure ``p̂``.
    scale_title : str
        Title of the axes (e.g. the voltage and pressure in physical units).
    path : str or pathlib.Path
        The file to write (:func:`save_figure`).

    Returns
    -------
    pathlib.Path
        ``path``.
    """
    plt = pyplot()
    import numpy as np

    fig, ax = plt.subplots(figsize=(6.0, 4.4))
    u = np.linspace(curve.grid[0], curve.grid[-1], 800)
    ax.plot(curve.v(u), curve.p(u), color="tab:blue", lw=1.6, label=f"zone curve at Φ̂ = {curve.phi_hat:.4f}")
    ax.axhline(state.p_hat, color="0.5", ls="--", lw=0.8)
    n_unbulged = state.zones - state.k
    marks = [(state.v_unbulged, "o", "tab:green", f"unbulged ({n_unbulged} zone{'s' if n_unbulged != 1 else ''})")]
    if state.k:
        marks.append((state.v_bulged, "s", "tab:red", f"bulged ({state.k} zone{'s' if state.k > 1 else ''})"))
    for v, marker, color, label in marks:
        ax.plot([v], [state.p_hat], marker, color=color, ms=9, mec="k", label=label)
    ax.set_xlabel("volume  V̂ = V/A³")
    ax.set_ylabel("pressure  p̂ = pA/(μH)")
    ax.set_title(scale_title, fontsize=10)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    return save_figure(fig, path)


def plot_phase_diagram(diagram, path, title=None):
    """Binodal, spinodals and critical point in the (Φ̂, p̂) plane.

    Parameters
    ----------
    diagram : PhaseDiagram
        One zone's phase diagram (:func:`~coexist.coexistence.phase_diagram`).
    path : str or pathlib.Path
        The file to write (:func:`save_figure`).
    title : str, optional
        Title of the axes.

    Returns
    -------
    pathlib.Path
        ``path``.
    """
    plt = pyplot()

    import numpy as np

    fig, ax = plt.subplots(figsize=(6.0, 4.4))
    phi, smax, smin, bino = diagram.phi_hat, diagram.spinodal_max, diagram.spinodal_min, diagram.binodal
    if diagram.critical_point is not None:
        # the three lines meet at the critical point: draw them from there
        phi_c, p_c, _ = diagram.critical_point
        order = np.argsort(np.append(phi, phi_c))
        phi, smax, smin, bino = (
            np.append(a, b)[order] for a, b in ((phi, phi_c), (smax, p_c), (smin, p_c), (bino, p_c))
        )
    ax.plot(phi, smax, "--", color="tab:red", label="spinodal (pressure maximum)")
    ax.plot(phi, smin, "--", color="tab:blue", label="spinodal (pressure minimum)")
    ax.plot(phi, bino, "-", color="k", lw=1.8, label="binodal (equal free energy)")
    if diagram.critical_point is not None:
        phi_c, p_c, _ = diagram.critical_point
        ax.plot([phi_c], [p_c], "o", color="gold", mec="k", ms=9, label=f"critical point Φ̂ = {phi_c:.4f}")
    ax.set_xlabel("voltage  Φ̂ = (Φ/H)√(ε/μ)")
    ax.set_ylabel("pressure  p̂ = pA/(μH)")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    if title:
        ax.set_title(title, fontsize=10)
    return save_figure(fig, path)


def plot_lens(scene, voltages_kV, profiles, end, path, side_views: int = 5):
    """The lens figure of one patterned zone along the voltage: side views (left) and its apex numbers (right).

    Left: the meridians ``(r, z)`` in mm, mirrored about the axis, at ``side_views`` voltages spread over those
    reached (the first and the last among them), to scale, every electrode edge marked (a ring: inner and outer).
    Right: the apex curvature ``κ0`` (1/m, left axis) and the apex height (mm, twin axis) against the voltage (kV),
    every point a converged state; where the states end early, a dotted line at the end voltage with its kind. Each
    side view's label carries :func:`coexist.shapes.lens_ratio`, ``κ0/κring`` (how far the centre bulges ahead of the
    ring).

    Parameters
    ----------
    scene : Scene
        The scene (name, zone radius and pattern for the titles).
    voltages_kV : sequence of float
        The voltages reached, ascending, one per profile.
    profiles : sequence of Profile
        The zone's state at each voltage (:func:`coexist.shapes.patterned_profiles`).
    end : dict or None
        ``{"kind", "reason", "voltage_kV": [with, without]}`` when the states stop early.
    path : str or Path
        The figure file.
    side_views : int
        Number of side views drawn.

    Returns
    -------
    Path
        ``path``.
    """
    import numpy as np

    from .errors import SceneError
    from .shapes import lens_ratio

    plt = pyplot()
    fig, (ax, bx) = plt.subplots(1, 2, figsize=(11.5, 4.6), gridspec_kw={"width_ratios": [1.25, 1]})
    v = np.asarray(voltages_kV, dtype=float)
    n = len(profiles)
    picks = sorted(set(np.round(np.linspace(0, n - 1, min(side_views, n))).astype(int))) if n else []
    cmap = plt.get_cmap("viridis")
    wrinkle_label: str | None = "hoop-wrinkled band (r: geometric)"  # one legend entry
    for j, i in enumerate(picks):
        p = profiles[i]
        color = cmap(0.85 * j / max(1, len(picks) - 1))
        r, z = p.r * 1e3, p.z * 1e3
        try:
            label = f"{v[i]:g} kV: κ0/κring = {lens_ratio(p):.3f}"
        except SceneError:
            label = f"{v[i]:g} kV"
        ax.plot(np.concatenate([-r[::-1], r]), np.concatenate([z[::-1], z]), color=color, lw=1.6, label=label)
        if mark_wrinkled_bands(ax, p, color=color, label=wrinkle_label):
            wrinkle_label = None
        for er, ez in ((r_e * 1e3, z_e * 1e3) for r_e, z_e in p.electrode_edges):  # a ring: inner and outer
            ax.plot([-er, er], [ez, ez], "o", color=color, ms=4.5, mec="k", mew=0.5)
    if picks:
        a = profiles[0].prestretch * scene.zone_radius * 1e3
        ax.plot([-1.08 * a, -a], [0, 0], color="0.3", lw=3)
        ax.plot([a, 1.08 * a], [0, 0], color="0.3", lw=3)
    ax.set_aspect("equal")
    ax.set_xlabel("r (mm)")
    ax.set_ylabel("z (mm)")
    ax.grid(alpha=0.25)
    several = any(len(profiles[i].electrode_edges_hat) > 1 for i in picks)  # a ring: inner and outer edge
    ax.legend(fontsize=8, loc="lower center", title=f"● electrode edge{'s' if several else ''}", title_fontsize=8)
    ax.set_title("side views (to scale)", fontsize=9)
    kappa = np.array([p.apex_curvature for p in profiles])
    height = np.array([p.apex_height * 1e3 for p in profiles])
    (l1,) = bx.plot(v, kappa, "o-", color="C3", ms=3, lw=1.4, label="apex curvature κ0 (1/m)")
    bx.set_xlabel("voltage (kV)")
    bx.set_ylabel("apex curvature κ0 (1/m)", color="C3")
    bx.grid(alpha=0.3)
    tx = bx.twinx()
    (l2,) = tx.plot(v, height, "s--", color="C0", ms=2.5, lw=1.0, label="apex height (mm)")
    tx.set_ylabel("apex height (mm)", color="C0")
    lines = [l1, l2]
    if end is not None and end.get("voltage_kV"):
        x_end = end["voltage_kV"][0]
        l3 = bx.axvline(x_end, color="k", ls=":", lw=1.2, label=f"{end['kind']} at {x_end:.5g} kV: no state above")
        lines.append(l3)
    bx.legend(lines, [ln.get_label() for ln in lines], fontsize=8, loc="upper left")
    bx.set_title("apex of the zone against the voltage (each point a converged state)", fontsize=9)
    name = scene.name or scene.source
    title = f"{name}: one zone, A = {scene.zone_radius * 1e3:.4g} mm, regions R/A {scene.zone_pattern().describe()}"
    return save_figure(fig, path, title=title, title_size=9)


def mark_wrinkled_bands(ax, profile, centre: float = 0.0, color: str = "k", label: str | None = None) -> bool:
    """Mark the hoop-wrinkled bands of a profile on a side view drawn in mm, mirrored about ``centre``: a thick,
    hatched-looking stroke (dashes over a wide pale line) along the meridian between each band's ends.

    In a band the profile's ``r`` is the geometric radius of the wrinkled surface (docs/physics.md section 11).
    The band's ends are drawn where they lie between the profile's points by linear interpolation of the
    points in ``R̂`` (a drawing aid only: every printed number is a point of the profile).

    Parameters
    ----------
    ax : matplotlib.axes.Axes
        The side view (mm).
    profile : Profile
        A state with its points (:mod:`coexist.shapes`); nothing is drawn without a band or without points.
    centre : float
        Where the axis of the zone is drawn (mm).
    color : str
        The stroke's colour.
    label : str, optional
        Legend label of the first stroke drawn.

    Returns
    -------
    bool
        Whether anything was drawn.
    """
    import numpy as np

    R, r, z = profile.R_hat, profile.r * 1e3, profile.z * 1e3
    if not profile.wrinkled_radii or R.size < 2:
        return False
    for a, b in profile.wrinkled_radii:
        inside = (R > a) & (R < b)
        Rb = np.concatenate([[a], R[inside], [b]])
        rb, zb = np.interp(Rb, R, r), np.interp(Rb, R, z)
        for side in (-1.0, 1.0):
            ax.plot(centre + side * rb, zb, color=color, lw=5.0, alpha=0.25, solid_capstyle="butt")
            ax.plot(centre + side * rb, zb, color=color, lw=5.0, ls=(0, (0.6, 0.6)), label=label)
            label = None
    return True
