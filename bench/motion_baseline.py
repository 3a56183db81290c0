"""TrackFilter against an earlier release of itself, side by side in one run.

Checks out ``motion/`` of a git revision (default: ``97202a4``, the filter
before it was split into model, buffer, policy and state) into a temporary
directory, imports it as a second package, and feeds both filters the same
generated run in alternating rounds:

* the states of both must be identical, bit for bit (printed as a check),
  and so must the generated runs and the accuracy report of the simulation;
* the updates per CPU-second of each, best of the rounds, and their ratio
  (this tree / the baseline) for the three sample mixes of ``bench/motion.py``.

Run: ``python -m bench.motion_baseline [--baseline REV] [--rounds N]``; it
needs git and the revision in this repository's history (without them it
says so and compares nothing).
"""

from __future__ import annotations

import argparse
import dataclasses
import importlib.util
import subprocess
import sys
import tarfile
import tempfile
import time
from pathlib import Path
from types import ModuleType
from typing import Any

import numpy as np

from motion import fusion
from motion import simulation as sim

ROOT = Path(__file__).resolve().parents[1]

Args = tuple[float, float, float | None, float | None, str | None]


def _load_baseline(rev: str, into: Path) -> ModuleType:
    """``motion.fusion`` of ``rev``, imported as the package ``motion_baseline``."""
    archive = into / "motion.tar"
    with archive.open("wb") as out:
        subprocess.run(
            ["git", "-C", str(ROOT), "archive", "--format=tar", rev, "motion"],
            stdout=out,
            stderr=subprocess.PIPE,
            check=True,
        )
    with tarfile.open(archive) as tar:
        tar.extractall(into, filter="data")
    pkg = into / "motion"
    spec = importlib.util.spec_from_file_location(
        "motion_baseline", pkg / "__init__.py", submodule_search_locations=[str(pkg)]
    )
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    sys.modules["motion_baseline"] = module
    spec.loader.exec_module(module)
    return importlib.import_module("motion_baseline.fusion")


def _samples(run: sim.Run, mode: str) -> list[Args]:
    """The step arguments of ``bench/motion.py``'s three mixes."""
    t = [float(x) for x in run.t]
    a = [float(x) for x in run.accel_meas]
    n = len(t)
    if mode == "mix":
        gs = [run.gnss_speed.get(k) for k in range(n)]
    elif mode == "accel":
        gs = [None] * n
    else:  # every sample carries a delayed GNSS speed
        gs = [float(abs(run.v_true[max(0, k - 20)])) for k in range(n)]
    marker_at = {int(round(tp * 10)): mid for tp, mid, _ in run.marker_pass}
    return [
        (t[k], a[k], gs[k], None, marker_at.get(k) if mode == "mix" else None) for k in range(n)
    ]


def _timed(module: Any, run: sim.Run, samples: list[Args]) -> tuple[float, list[Any]]:
    f = module.TrackFilter(
        run.table, module.FilterConfig(initial_position_m=run.start_estimate_m, gnss_delay_s=2.0)
    )
    step = f.step
    states = []
    # CPU time of this process: the machine is shared, and time spent descheduled
    # is not the filter's (wall-clock rates swing by 2x under load; CPU time does not)
    t0 = time.process_time()
    for args in samples:
        states.append(step(*args))
    return len(samples) / (time.process_time() - t0), states


def _fields(states: list[Any]) -> list[tuple[Any, ...]]:
    return [dataclasses.astuple(s) for s in states]


def _same_simulation(seeds: range) -> bool:
    """The baseline's ``motion.simulation`` and this tree's give the same runs
    and the same report, bit for bit."""
    old = importlib.import_module("motion_baseline.simulation")
    for seed in seeds:
        a, b = old.generate_run(seed), sim.generate_run(seed)
        if a.table.to_dict() != b.table.to_dict():
            return False
        for f in dataclasses.fields(a):
            x, y = getattr(a, f.name), getattr(b, f.name)
            if f.name != "table" and not (
                np.array_equal(x, y) if isinstance(x, np.ndarray) else x == y
            ):
                return False
    ra, rb = old.evaluate(seeds), sim.evaluate(seeds)
    return bool(dataclasses.astuple(ra) == dataclasses.astuple(rb))


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("--baseline", default="97202a4", help="git revision to compare with")
    ap.add_argument("--rounds", type=int, default=5)
    args = ap.parse_args(argv)
    with tempfile.TemporaryDirectory() as tmp:
        try:
            base = _load_baseline(args.baseline, Path(tmp))
        except (OSError, subprocess.CalledProcessError) as exc:
            print(f"no baseline to compare with: git archive {args.baseline} failed ({exc})")
            print("  (run it in a clone that has that revision, or pass --baseline REV)")
            return 0
        run = sim.generate_run(0)
        print(f"TrackFilter, this tree against {args.baseline}, {run.t.size} samples per pass")
        print(f"(updates per CPU-second, best of {args.rounds} alternating rounds):")
        for mode, label in [
            ("mix", "10 Hz accel + 1 Hz GNSS (2 s late) + markers"),
            ("accel", "accelerometer only"),
            ("every", "delayed GNSS speed in every sample"),
        ]:
            samples = _samples(run, mode)
            best_new = best_old = 0.0
            same = True
            for _ in range(args.rounds):
                rate_old, old = _timed(base, run, samples)
                rate_new, new = _timed(fusion, run, samples)
                best_old, best_new = max(best_old, rate_old), max(best_new, rate_new)
                same = same and _fields(old) == _fields(new)
            print(
                f"  {label:46s} {best_old:9,.0f} → {best_new:9,.0f} updates/s  "
                f"ratio {best_new / best_old:.3f}  states identical: {same}"
            )
            if not same:
                return 1
        same_sim = _same_simulation(range(3))
        print(f"  generated runs and accuracy report identical: {same_sim}")
    return 0 if same_sim else 1


if __name__ == "__main__":
    raise SystemExit(main())
