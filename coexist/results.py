"""Plain results to JSON-ready dicts and CSV text."""

from __future__ import annotations

import csv
import io


def curves_csv(curves) -> str:
    """One row per state of every curve: family, fixed value, and the state quantities."""
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(
        [
            "family",
            "fixed_name",
            "fixed_value",
            "pole_stretch",
            "phi_hat",
            "p_hat",
            "v_hat",
            "q_hat",
            "psi_hat",
            "apex_height",
            "max_field_hat",
            "min_tension_hat",
        ]
    )
    for c in curves:
        s = c.states
        name = "phi_hat" if c.family == "pressure_volume" else "p_hat"
        for i in range(s.pole_stretch.size):
            w.writerow(
                [c.family, name, repr(c.fixed)]
                + [
                    repr(float(getattr(s, k)[i]))
                    for k in (
                        "pole_stretch",
                        "phi_hat",
                        "p_hat",
                        "v_hat",
                        "q_hat",
                        "psi_hat",
                        "apex_height",
                        "max_field",
                        "min_tension",
                    )
                ]
            )
    return buf.getvalue()
