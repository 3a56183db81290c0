"""Outputs of the motion commands: the braking-error histogram and both papers' tables.

A helper module (no ``register``): the ``depot`` CLI skips command modules starting with ``_``.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from motion import braking, optical


def render_histogram_png(result: braking.MonteCarloResult, path: str | Path) -> Path:
    """Histogram of relative frequencies of the braking-distance error (PNG,
    matplotlib Agg), with the Pearson type I fit and the empirical bound."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np

    out = Path(path)
    edges = np.asarray(result.edges_m)
    counts = np.asarray(result.counts, dtype=float)
    width = np.diff(edges)
    fig, ax = plt.subplots(figsize=(7, 4.2), dpi=110)
    ax.bar(
        edges[:-1],
        counts / result.runs,
        width=width,
        align="edge",
        edgecolor="black",
        alpha=0.7,
        label=f"{result.runs} runs",
    )
    if result.fit is not None:
        x = np.linspace(edges[0], edges[-1], 400)
        ax.plot(
            x,
            result.fit.pdf(x) * float(np.mean(width)),
            "r-",
            label=f"Pearson I fit (χ² p = {result.fit.p_value:.2f})",
        )
    ax.axvline(
        -result.delta_s_max_m,
        color="k",
        ls="--",
        label=f"ΔS_max = {result.delta_s_max_m:.2f} m "
        f"(p ≤ {result.p_exceed:.1e}, β = {result.beta:g})",
    )
    ax.set_xlabel("braking-distance error ΔS = S_nominal − S_actual, m")
    ax.set_ylabel("relative frequency")
    ax.set_title(
        f"Target braking by {result.control}, V = {result.speed_mps * 3.6:.0f} km/h, ΔV = ±10 %"
    )
    ax.legend(fontsize=8)
    fig.tight_layout()
    out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out, format="png")
    plt.close(fig)
    return out


# ------------------------------------------------------------------ motion-tables
def tables() -> dict[str, Any]:
    """Both papers' tables as the service computes them, with the printed values."""
    t000 = []
    for row in optical.table1():
        printed = optical.PAPER_TABLE1.get(row.meter)
        t000.append(
            {
                **row.as_dict(),
                "printed": None
                if printed is None
                else dict(
                    zip(
                        ["d1_m", "sigma_d1_m", "d2_m", "sigma_d2_m", "sigma_v_mps", "sigma_v_kmh"],
                        printed,
                        strict=True,
                    )
                ),
            }
        )
    ex = optical.PAPER_EXAMPLE
    geom = {
        "distance_m": ex["distance_m"],
        "pixel_fov_rad": ex["pixel_fov_rad"],
        "rows": ex["rows"],
        "row_time_s": ex["row_time_s"],
    }
    smear = optical.smear_for_speed(ex["speed_kmh"] / 3.6, **geom)
    study = optical.roll_scatter_study()
    t001 = [
        {
            "p_max": c.p_max,
            "beta": c.beta,
            "computed": c.computed,
            "printed": c.printed,
            "matches": c.matches,
        }
        for c in braking.table1()
    ]
    return {
        "000_table1": t000,
        "000_example_40kmh": {
            "rows": optical.rows_for_stripe(1.0, ex["distance_m"], ex["pixel_fov_rad"]),
            "smear_px": smear,
            "smear_px_printed": ex["smear_px"],
            "sigma15_mps": study.sigma15_mps,
            "max_sigma16_mps": study.max_sigma_mps,
            "max_sigma16_kmh": study.max_sigma_kmh,
            "worst_case_sigma16_mps": study.bound_sigma_mps,
            "bound_printed_kmh": ex["bound_kmh"],
            "bound_printed_mps": ex["bound_mps"],
        },
        "001_table1": t001,
    }
