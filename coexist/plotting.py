"""Figures. matplotlib is imported only here (and only when a figure is drawn)."""

from __future__ import annotations

from pathlib import Path


def _pyplot():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


_MARKERS = {"pressure_max": "v", "pressure_min": "^", "volume_max": "s", "volume_min": "s",
            "voltage_max": "v", "voltage_min": "^", "charge_max": "D", "charge_min": "D"}


def plot_curves(pv_curves, vq_curves, path: str | Path, title: str | None = None):
    """The ``p̂–V̂`` family (left) and the ``Φ̂–Q̂`` family (right), limit points marked."""
    plt = _pyplot()
    panels = 2 if vq_curves else 1
    fig, axes = plt.subplots(1, panels, figsize=(5.2 * panels, 4.2), squeeze=False)
    ax = axes[0, 0]
    for c in pv_curves:
        (line,) = ax.plot(c.states.v_hat, c.states.p_hat, lw=1.6, label=f"Φ̂ = {c.fixed:g}")
        for lp in c.limit_points:
            ax.plot(lp.v_hat, lp.p_hat, _MARKERS.get(lp.kind, "o"), color=line.get_color(), ms=6, mec="k", mew=0.6)
    ax.set_xlabel("volume  V̂ = V/A³")
    ax.set_ylabel("pressure  p̂ = pA/(μH)")
    ax.set_title("pressure–volume at fixed voltage")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    if vq_curves:
        ax = axes[0, 1]
        for c in vq_curves:
            (line,) = ax.plot(c.states.q_hat, c.states.phi_hat, lw=1.6, label=f"p̂ = {c.fixed:g}")
            for lp in c.limit_points:
                ax.plot(lp.q_hat, lp.phi_hat, _MARKERS.get(lp.kind, "o"), color=line.get_color(), ms=6, mec="k",
                        mew=0.6)
        ax.set_xlabel("charge  Q̂ = Q/(A²√(εμ))")
        ax.set_ylabel("voltage  Φ̂ = (Φ/H)√(ε/μ)")
        ax.set_title("voltage–charge at fixed pressure")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8)
    if title:
        fig.suptitle(title, fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=130)
    plt.close(fig)
    return Path(path)
