"""Counters of this worker process, written in the Prometheus text format (``GET /metrics``).

Deliberately small: a counter and a histogram with labels, thread-safe, no dependency. Each
worker process counts what it answered (``depot serve --workers N``: one scrape reaches one
worker; docs/OPERATIONS.md says how to scrape them all). Gauges read from the database (stale
devices, the review queue) are added by ``service/metrics.py`` and are the same from any worker.
"""

from __future__ import annotations

import math
import re
import threading
import time
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from typing import Any

# A label value from a client (an event kind) is kept only when it looks like a kind; at
# most this many distinct label sets per metric, then "other": hostile input cannot make the
# answer grow without bound.
KIND_LABEL = re.compile(r"^[a-z][a-z0-9_]{0,39}$")
MAX_SERIES = 200
# Decision latency buckets, seconds: group commit waits ~2 ms, the p99 measured is ~150 ms.
DECISION_BUCKETS_S = (0.005, 0.01, 0.025, 0.05, 0.1, 0.25, 0.5, 1.0, 2.5, 5.0, 10.0)


def _escape(value: str) -> str:
    return value.replace("\\", "\\\\").replace("\n", "\\n").replace('"', '\\"')


def _labels(names: Sequence[str], values: Sequence[str], extra: str = "") -> str:
    pairs = [f'{n}="{_escape(v)}"' for n, v in zip(names, values, strict=True)]
    if extra:
        pairs.append(extra)
    return "{" + ",".join(pairs) + "}" if pairs else ""


def _number(value: float) -> str:
    if math.isinf(value):
        return "+Inf" if value > 0 else "-Inf"
    return repr(float(value)) if not float(value).is_integer() else str(int(value))


class Counter:
    """A monotonically increasing count per label set."""

    def __init__(self, name: str, help_text: str, labels: Sequence[str]) -> None:
        self.name, self.help, self.label_names = name, help_text, tuple(labels)
        self._values: dict[tuple[str, ...], float] = {}
        self._lock = threading.Lock()

    def inc(self, *labels: str, by: float = 1.0) -> None:
        with self._lock:
            key = tuple(labels)
            if key not in self._values and len(self._values) >= MAX_SERIES:
                key = tuple("other" for _ in labels)
            self._values[key] = self._values.get(key, 0.0) + by

    def value(self, *labels: str) -> float:
        with self._lock:
            return self._values.get(tuple(labels), 0.0)

    def render(self) -> list[str]:
        with self._lock:
            items = sorted(self._values.items())
        lines = [f"# HELP {self.name} {self.help}", f"# TYPE {self.name} counter"]
        lines += [f"{self.name}{_labels(self.label_names, k)} {_number(v)}" for k, v in items]
        return lines


@dataclass
class _Buckets:
    counts: list[int]
    total: float = 0.0
    count: int = 0


class Histogram:
    """Observations in cumulative buckets (``_bucket``, ``_sum``, ``_count``)."""

    def __init__(self, name: str, help_text: str, buckets: Sequence[float]) -> None:
        self.name, self.help = name, help_text
        self.bounds = (*sorted(buckets), math.inf)
        self._data = _Buckets([0] * len(self.bounds))
        self._lock = threading.Lock()

    def observe(self, value: float) -> None:
        with self._lock:
            for i, bound in enumerate(self.bounds):
                if value <= bound:
                    self._data.counts[i] += 1
            self._data.total += value
            self._data.count += 1

    def render(self) -> list[str]:
        with self._lock:
            counts, total, count = list(self._data.counts), self._data.total, self._data.count
        lines = [f"# HELP {self.name} {self.help}", f"# TYPE {self.name} histogram"]
        for bound, n in zip(self.bounds, counts, strict=True):
            lines.append(f'{self.name}_bucket{{le="{_number(bound)}"}} {n}')
        lines += [f"{self.name}_sum {_number(total)}", f"{self.name}_count {count}"]
        return lines


EVENTS = Counter(
    "depot_events_total",
    "device events answered by this worker, by kind, outcome (accepted, duplicate, refused)"
    " and HTTP status",
    ("kind", "outcome", "status"),
)
DECISIONS = Histogram(
    "depot_decision_seconds",
    "train_arrived received until its decision is committed (the answer), seconds",
    DECISION_BUCKETS_S,
)
STARTED = time.time()


def _kind_of(payload: Any) -> str:
    kind = payload.get("kind") if isinstance(payload, dict) else None
    return kind if isinstance(kind, str) and KIND_LABEL.match(kind) else "unknown"


def _outcome(status: int) -> str:
    return "accepted" if status == 201 else "duplicate" if status == 200 else "refused"


def event_answered(payload: Any, status: int, started: float) -> None:
    """Count one answered event (``started``: ``time.perf_counter()`` when it came in)."""
    kind = _kind_of(payload)
    EVENTS.inc(kind, _outcome(status), str(status))
    if kind == "train_arrived" and status == 201:
        DECISIONS.observe(time.perf_counter() - started)


def batch_answered(payloads: Iterable[Any], results: Iterable[dict[str, Any]]) -> None:
    """Count a batch's items by the status each got (added up first: one increment, and one
    take of the counter's lock, per label set rather than per item)."""
    counts: dict[tuple[str, str, str], int] = {}
    for payload, result in zip(payloads, results, strict=False):
        item = result.get("status")
        if item == "created":
            status = 201
        elif item == "duplicate":
            status = 200
        else:
            status = int((result.get("error") or {}).get("status") or 422)
        labels = (_kind_of(payload), _outcome(status), str(status))
        counts[labels] = counts.get(labels, 0) + 1
    for labels, count in counts.items():  # in the order first seen, as one by one
        EVENTS.inc(*labels, by=count)


def render(extra: Iterable[str] = ()) -> str:
    """The whole exposition: this process's counters, then ``extra`` lines (gauges)."""
    lines = [
        "# HELP depot_process_start_time_seconds when this worker started, Unix time",
        "# TYPE depot_process_start_time_seconds gauge",
        f"depot_process_start_time_seconds {_number(STARTED)}",
        *EVENTS.render(),
        *DECISIONS.render(),
        *extra,
    ]
    return "\n".join(lines) + "\n"
