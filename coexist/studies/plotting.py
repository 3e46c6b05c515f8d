"""The work-precision figure of ``coexist accuracy`` (matplotlib is imported only when drawing)."""

from __future__ import annotations

import math
from pathlib import Path

from ..plotting import pyplot, save_figure

_FAMILY_STYLE = {
    "rtol": ("tab:blue", "o", "rtol sweep"),
    "points": ("tab:orange", "s", "curve points"),
    "n": ("tab:orange", "s", "spline points n"),
}


#: where each family's point labels go, so that crossing families do not write over each other
_LABEL_PLACE = {
    "rtol": {"xytext": (4, 3), "ha": "left", "va": "bottom"},
    "points": {"xytext": (4, -3), "ha": "left", "va": "top"},
    "n": {"xytext": (4, -3), "ha": "left", "va": "top"},
}


def _short(m):
    if m.family == "rtol":
        return f"{m.rtol:.0e}".replace("e-0", "e-")
    if m.family == "grid":
        return "×".join(str(v) for v in m.sampling.values())
    return str(m.sampling[m.family])


def _study_panel(ax, study):
    floor = study.resolution
    families: dict = {}
    for m in study.measurements:
        if m.error is not None and m.time is not None:
            families.setdefault(m.family, []).append(m)
    for fam, ms in families.items():
        color, marker, name = _FAMILY_STYLE.get(fam, ("tab:gray", "o", fam))
        # joined in the order of the setting (loose to tight, coarse to fine), as measured
        ax.plot(
            [m.time for m in ms],
            [max(m.error, floor) for m in ms],
            marker=marker,
            color=color,
            lw=1.3,
            ms=5,
            label=name,
            alpha=0.9,
        )
        groups: list = []  # settings that land on the same spot share one label
        for m in ms:
            if m.default:
                continue
            x, y = m.time, max(m.error, floor)
            for g in groups:
                if abs(math.log10(g[0] / x)) < 0.02 and abs(math.log10(g[1] / y)) < 0.1:
                    g[2].append(_short(m))
                    break
            else:
                groups.append([x, y, [_short(m)]])
        for x, y, names in groups:
            ax.annotate(
                ",".join(names),
                (x, y),
                textcoords="offset points",
                fontsize=6.5,
                color=color,
                **_LABEL_PLACE.get(fam, _LABEL_PLACE["rtol"]),
            )
    front = study.front()
    if len(front) > 1:
        ax.step(
            [m.time for m in front],
            [max(m.error, floor) for m in front],
            where="post",
            color="0.6",
            lw=0.8,
            ls="--",
            label="Pareto front",
            zorder=0,
        )
    d = study.default
    if d is not None and d.error is not None:
        ax.plot(d.time, max(d.error, floor), "*", ms=16, color="gold", mec="k", mew=0.8, zorder=5, label="default")
    if study.reference_checks:
        ax.axhline(floor, color="0.5", lw=0.7, ls=":", zorder=0)
        ax.text(
            0.99,
            floor,
            "reference resolution",
            transform=ax.get_yaxis_transform(),
            ha="right",
            va="bottom",
            fontsize=6.5,
            color="0.4",
        )
    times = [m.time for m in study.measurements if m.time]
    if times and max(times) / min(times) > 3:
        ax.set_xscale("log")
    else:  # a narrow range of times: log ticks would crowd; plain seconds read better
        from matplotlib.ticker import MaxNLocator

        ax.xaxis.set_major_locator(MaxNLocator(4))
    ax.set_yscale("log")
    ax.margins(x=0.12, y=0.08)
    ax.set_xlabel("wall time (s)")
    ax.set_ylabel("relative error")
    ref = study.reference["value"]
    unit = f" {study.unit}" if study.unit else ""
    setup = study.setup
    extra = ""
    if "zone_radius_mm" in setup:
        jlim = "" if setup.get("jlim") is None else f" {setup['jlim']:g}"
        extra = f"\n{setup['material']}{jlim}, zone radius {setup['zone_radius_mm']:g} mm"
    ax.set_title(f"{study.number}. {study.title}\nreference {ref:.10g}{unit}{extra}", fontsize=9)
    ax.grid(alpha=0.3, lw=0.5)
    ax.legend(fontsize=7, loc="best")


def _tolerance_panel(ax, study):
    rows = [r for r in study.tolerance if r.get("achieved_error") is not None]
    floor = study.resolution
    r = [x["requested_rtol"] for x in rows]
    ax.plot(r, [max(x["achieved_error"], floor) for x in rows], "o-", color="tab:blue", lw=1.3, ms=5, label="p̂max")
    if rows and rows[0].get("states_max_error_p_hat") is not None:
        for key, style, color, name in (("p_hat", "s--", "tab:red", "p̂"), ("v_hat", "^:", "tab:brown", "V̂")):
            worst = [x[f"states_max_error_{key}"] for x in rows]
            ax.plot(r, worst, style, color=color, lw=1.1, ms=4, label=f"{name}, worst of the curve's states")
    lo, hi = min(r + [1e-14]), max(r + [1e-3])
    ax.plot([lo, hi], [lo, hi], color="k", lw=0.8, label="error = rtol")
    ax.plot([lo, hi], [lo * 100, hi * 100], color="0.6", lw=0.7, ls="--", label="error = 100 rtol")
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("requested rtol")
    ax.set_ylabel("achieved relative error")
    ax.set_title("what the tolerance buys (study 1, 200 points)", fontsize=9)
    ax.grid(alpha=0.3, lw=0.5)
    ax.legend(fontsize=7, loc="upper left")


def plot_accuracy(studies, path: str | Path, title: str | None = None):
    """One work-precision panel per study (log error against log time, one line per setting family,
    the default starred, the Pareto front dashed) and, with study 1, the achieved error against the
    requested tolerance.

    Parameters
    ----------
    studies : list of Study
        The studies (:func:`~coexist.studies.accuracy.run_studies`), one panel each, plus one tolerance
        panel for each study with ``tolerance`` data.
    path : str or pathlib.Path
        The file to write (:func:`~coexist.plotting.save_figure`).
    title : str, optional
        Title over the figure; default "What accuracy costs in time (work-precision)".

    Returns
    -------
    pathlib.Path
        ``path``.
    """
    plt = pyplot()
    tol = [s for s in studies if s.tolerance]
    n = len(studies) + len(tol)
    cols = 2 if n > 1 else 1
    rows = (n + cols - 1) // cols
    fig, axes = plt.subplots(rows, cols, figsize=(5.6 * cols, 4.6 * rows), squeeze=False)
    flat = list(axes.ravel())
    for ax, s in zip(flat, studies):
        _study_panel(ax, s)
    for ax, s in zip(flat[len(studies) :], tol):
        _tolerance_panel(ax, s)
    for ax in flat[n:]:
        ax.set_visible(False)
    return save_figure(fig, path, title or "What accuracy costs in time (work-precision)", title_size=11)
