"""Generated train runs for testing and benchmarking :mod:`motion.fusion`.

* :mod:`~motion.simulation.generator` — :func:`generate_run`: a line, a
  drive and the on-board event stream of one seed (:class:`Scenario`);
* :mod:`~motion.simulation.runner` — :func:`run_fusion`: the events fed to a
  :class:`~motion.fusion.TrackFilter` in a closed loop (the reader follows
  ``reader_on``);
* :mod:`~motion.simulation.baselines` — :func:`dead_reckoning` and
  :func:`gnss_only`;
* :mod:`~motion.simulation.report` — :func:`evaluate`: the final-stop
  errors of all three over many seeds (:class:`FusionReport`).
"""

from __future__ import annotations

from .baselines import dead_reckoning, gnss_only
from .generator import Run, Scenario, generate_run
from .report import FusionReport, evaluate
from .runner import run_fusion

__all__ = [
    "FusionReport",
    "Run",
    "Scenario",
    "dead_reckoning",
    "evaluate",
    "generate_run",
    "gnss_only",
    "run_fusion",
]
