"""Feeding a generated run to a :class:`~motion.fusion.TrackFilter` in a
closed loop: the marker reader reads a marker only while the filter has it
switched on (``TrackState.reader_on``), as on board."""

from __future__ import annotations

from ..fusion import FilterConfig, TrackFilter, TrackState
from .generator import Run

__all__ = ["run_fusion"]


def _reading(run: Run, k: int, tp: float) -> float:
    """The accelerometer at a marker read at ``tp``, between samples k-1 and k."""
    t, acc = run.t, run.accel_meas
    if not k:
        return float(acc[0])
    w = (tp - t[k - 1]) / (t[k] - t[k - 1])
    return float(acc[k - 1] + w * (acc[k] - acc[k - 1]))


def run_fusion(
    run: Run,
    config: FilterConfig | None = None,
    *,
    use_markers: bool = True,
    use_fixes: bool = True,
    use_speed: bool = True,
    record: bool = False,
) -> tuple[TrackState, list[TrackState], int]:
    """Feed the run to a filter; the reader reads a marker only while
    ``reader_on``.  Returns (final state, states if ``record``, markers read)."""
    cfg = config or FilterConfig(
        initial_position_m=run.start_estimate_m,
        gnss_delay_s=run.delay_s,
        accel_noise_mps2=run.accel_noise,
    )
    f = TrackFilter(run.table, cfg)
    passes = sorted(run.marker_pass) if use_markers else []
    pi = 0
    states: list[TrackState] = []
    reads = 0
    st: TrackState | None = None
    t = run.t
    for k in range(t.size):
        # marker reads that happened since the previous sample
        while pi < len(passes) and passes[pi][0] <= t[k]:
            tp, mid, _ = passes[pi]
            pi += 1
            if mid == run.missed_id or tp <= (st.t if st else -1.0):
                continue
            if st is not None and not st.reader_on:
                continue
            st = f.step(tp, _reading(run, k, tp), marker_id=mid)
            reads += 1
            if record:
                states.append(st)
        gs = run.gnss_speed.get(k) if use_speed else None
        fx = run.gnss_fix.get(k) if use_fixes else None
        st = f.step(
            float(t[k]),
            float(run.accel_meas[k]),
            gs,
            run.delay_s if gs is not None or fx is not None else None,
            None,
            fx[0] if fx else None,
            fx[1] if fx else None,
        )
        if record:
            states.append(st)
    assert st is not None
    return st, states, reads
