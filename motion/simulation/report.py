"""Final-stop position errors of the fusion and of both baselines over many
generated runs (seed ``004`` asks ±5 m at station dead-end tracks)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from .baselines import dead_reckoning, gnss_only
from .generator import generate_run
from .runner import run_fusion

__all__ = ["FusionReport", "evaluate"]

# The figures of a summary: the share of runs whose fusion error is within
# this many of its own σ (is the stated uncertainty honest?), and the tail percentile.
CONSISTENCY_SIGMAS = 3.0
TAIL_PERCENTILE = 95.0
_TINY_SIGMA_M = 1e-9  # a zero σ would divide by zero; any error is then outside it


@dataclass(frozen=True)
class FusionReport:
    """Signed final-stop errors (estimate − truth, m), one per run."""

    runs: int
    threshold_m: float
    fusion_errors_m: list[float]
    dead_reckoning_errors_m: list[float]
    gnss_only_errors_m: list[float]
    fusion_sigma_m: list[float]
    markers_read: list[int]

    @staticmethod
    def _stats(e: list[float], thr: float) -> dict[str, float]:
        a = np.abs(np.asarray(e))
        return {
            "within_threshold": float(np.mean(a <= thr)),
            "median_m": float(np.median(a)),
            "p95_m": float(np.percentile(a, TAIL_PERCENTILE)),
            "max_m": float(a.max()),
        }

    def summary(self) -> dict[str, dict[str, float]]:
        """Per method: share within the threshold, median, p95 and max |error|;
        for the fusion also the share within 3σ of its own uncertainty."""
        thr = self.threshold_m
        z = np.abs(np.asarray(self.fusion_errors_m)) / np.maximum(
            np.asarray(self.fusion_sigma_m), _TINY_SIGMA_M
        )
        fus = self._stats(self.fusion_errors_m, thr)
        fus["within_3_sigma"] = float(np.mean(z <= CONSISTENCY_SIGMAS))
        return {
            "fusion": fus,
            "dead_reckoning": self._stats(self.dead_reckoning_errors_m, thr),
            "gnss_only": self._stats(self.gnss_only_errors_m, thr),
        }


def evaluate(seeds: range | list[int], threshold_m: float = 5.0, **run_kw: Any) -> FusionReport:
    """Final-stop position errors of the filter and both baselines
    (``run_kw`` go to :func:`~motion.simulation.generator.generate_run`)."""
    fe: list[float] = []
    de: list[float] = []
    ge: list[float] = []
    sg: list[float] = []
    rd: list[int] = []
    for seed in seeds:
        run = generate_run(seed, **run_kw)
        st, _, reads = run_fusion(run)
        truth = run.final_position
        fe.append(st.position_m - truth)
        sg.append(st.sigma_position_m)
        rd.append(reads)
        de.append(dead_reckoning(run) - truth)
        ge.append(gnss_only(run) - truth)
    return FusionReport(len(fe), threshold_m, fe, de, ge, sg, rd)
