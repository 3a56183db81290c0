"""The replay buffer of :class:`motion.fusion.TrackFilter`: the last
``max_delay_s`` seconds of samples with their predicted states, so that a
measurement that arrives late (GNSS, 2 s or more) is applied at its own time
and the filter re-run from there ("re-filtering from a buffered state").
"""

from __future__ import annotations

import bisect
from dataclasses import dataclass

from .model import Estimate, KalmanModel, Measurement, MeasurementKind
from .samples import StaleSampleError

__all__ = ["TIME_TOLERANCE_S", "TRIM_PERIOD_S", "Entry", "ReplayBuffer"]

# Two times closer than this are the same instant (the samples' clock resolution
# is far coarser); keeps float round-off from inserting a twin entry.
TIME_TOLERANCE_S = 1e-9
# Old entries are dropped about once per this period, not at every sample.
TRIM_PERIOD_S = 1.0


@dataclass(slots=True)
class Entry:
    """One instant in the buffer.

    ``prior`` is the state predicted to ``t`` before this entry's
    ``measurements``; ``real`` is False for an entry inserted only to carry a
    delayed measurement (its ``accel`` interpolated between its neighbours).
    """

    t: float  # s, the on-board clock
    accel: float  # m/s², the accelerometer reading at t
    measurements: list[Measurement] | None
    prior: Estimate
    real: bool


# The kinds that carry a GNSS speed.
_SPEEDS = frozenset({int(MeasurementKind.SPEED), int(MeasurementKind.SPEED_RESTART)})


def _entry_time(e: Entry) -> float:
    return e.t


class ReplayBuffer:
    """Entries in time order; predictions go through ``model``."""

    __slots__ = ("model", "entries", "_span_s")

    def __init__(
        self, model: KalmanModel, entries: list[Entry] | None = None, span_s: float = 0.0
    ) -> None:
        self.model = model
        self.entries: list[Entry] = entries if entries is not None else []
        # max_delay_s: a buffer spanning less was never trimmed (its first entry is the start)
        self._span_s = span_s

    def __len__(self) -> int:
        return len(self.entries)

    @property
    def last(self) -> Entry:
        return self.entries[-1]

    def start(self, t: float, accel: float, prior: Estimate) -> None:
        self.entries.append(Entry(t, accel, None, prior, True))

    def _predicted(self, x: Estimate, p: Entry, t: float, accel: float) -> Estimate:
        return self.model.predict(x, t - p.t, p.accel, accel)

    def append(self, t: float, accel: float, post: Estimate) -> int:
        """A new newest sample (``t`` after the last), predicted from the
        newest posterior ``post``; returns its index."""
        entries = self.entries
        p = entries[-1]
        entries.append(
            Entry(t, accel, None, self.model.predict(post, t - p.t, p.accel, accel), True)
        )
        return len(entries) - 1

    def posterior(self, i: int) -> Estimate:
        """The state at entry ``i`` after its measurements."""
        e = self.entries[i]
        if e.measurements:
            return self.model.update(e.prior, e.measurements)
        return e.prior

    def replay(self, i: int) -> Estimate:
        """Re-run the filter from entry ``i`` (its prior is valid) to the end;
        returns the newest posterior."""
        entries = self.entries
        x = self.posterior(i)
        if i == len(entries) - 1:
            return x  # the newest sample: nothing to re-run (most samples)
        predict = self.model.predict
        update = self.model.update
        for j in range(i + 1, len(entries)):
            p = entries[j - 1]
            e = entries[j]
            e.prior = x = predict(x, e.t - p.t, p.accel, e.accel)
            if e.measurements:
                x = update(x, e.measurements)
        return x

    def speed_before(self, j: int) -> tuple[float, float] | None:
        """``(time, value)`` of the GNSS speed attached before the newest
        measurement of entry ``j`` (the one just attached), in time order;
        ``None`` when the buffer holds none."""
        entries = self.entries
        for i in range(j, -1, -1):
            ms = entries[i].measurements
            if not ms:
                continue
            for m in reversed(ms[:-1] if i == j else ms):
                if m.kind in _SPEEDS:
                    return entries[i].t, m.value
        return None

    def add(self, i: int, m: Measurement) -> None:
        e = self.entries[i]
        if e.measurements is None:
            e.measurements = [m]
        else:
            e.measurements.append(m)

    def _insert(self, k: int, t: float, accel: float, real: bool) -> None:
        """An entry at index ``k`` (``k ≥ 1``); its successors must be re-run."""
        p = self.entries[k - 1]
        prior = self._predicted(self.posterior(k - 1), p, t, accel)
        self.entries.insert(k, Entry(t, accel, None, prior, real))

    def _index(self, t: float) -> int:
        return bisect.bisect_left(self.entries, t - TIME_TOLERANCE_S, key=_entry_time)

    def at_time(self, tau: float) -> int | None:
        """Index of the entry at time ``tau``, inserted if needed (the
        acceleration interpolated); ``None`` when ``tau`` is older than the buffer."""
        entries = self.entries
        if tau >= entries[-1].t - TIME_TOLERANCE_S:
            return len(entries) - 1
        if tau < entries[0].t - TIME_TOLERANCE_S:
            return None
        k = self._index(tau)
        if abs(entries[k].t - tau) <= TIME_TOLERANCE_S:
            return k
        p = entries[k - 1]
        nx = entries[k]
        w = (tau - p.t) / (nx.t - p.t)
        self._insert(k, tau, p.accel + w * (nx.accel - p.accel), False)
        return k

    def insert_real(self, t: float, accel: float) -> int:
        """An out-of-order (or repeated) sample inside the buffer; its index.

        A sample before the first entry is taken as the new first entry when the
        first entry is the filter's start (the buffer does not yet span
        ``max_delay_s``: the caller checked the late-sample bound), so the first
        samples of a stream arriving out of order are used too.  Raises
        :class:`StaleSampleError` when ``t`` is older than the buffer otherwise.
        """
        entries = self.entries
        if t < entries[0].t - TIME_TOLERANCE_S:
            if entries[-1].t - entries[0].t > self._span_s:
                raise StaleSampleError(
                    f"sample at t={t} is older than the filter's buffer"
                    f" (starts at t={entries[0].t})"
                )
            self._prepend(t, accel)
            return 0
        k = self._index(t)
        e = entries[k]
        if abs(e.t - t) <= TIME_TOLERANCE_S:
            e.accel = accel
            e.real = True
            if k > 0:
                p = entries[k - 1]
                e.prior = self._predicted(self.posterior(k - 1), p, e.t, accel)
            return k
        self._insert(k, t, accel, True)
        return k

    def _prepend(self, t: float, accel: float) -> None:
        """A new first entry at ``t``: it takes the start's prior (the filter's
        initial estimate, which holds for any instant) and the old first entry
        is predicted from it; the caller re-runs from 0."""
        first = self.entries[0]
        self.entries.insert(0, Entry(t, accel, None, first.prior, True))
        first.prior = self._predicted(first.prior, self.entries[0], first.t, first.accel)

    def trim(self, max_delay_s: float) -> None:
        """Forget entries older than ``max_delay_s`` before the newest,
        keeping one at or before that horizon to restart from."""
        entries = self.entries
        horizon = entries[-1].t - max_delay_s
        if len(entries) > 2 and entries[0].t < horizon - TRIM_PERIOD_S:
            k = bisect.bisect_left(entries, horizon, key=_entry_time)
            del entries[: max(0, k - 1)]
