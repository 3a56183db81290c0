"""The JSON snapshot of a :class:`motion.fusion.TrackFilter` (version 1).

The service keeps one per train (``train_positions.filter_state``) so that
any API worker can continue the train's filter; snapshots written by an
earlier release must load in a later one, and a later release must write the
same document for the same filter (workers of two releases run side by side
during an upgrade).  The document, a few kB::

    {"version": 1,
     "table": <MarkerTable.fingerprint>,
     "config": {<FilterConfig fields>},
     "buffer": [[t, accel, [[kind, value, variance], ...] | null,
                 s, u, b, p00, p01, p02, p11, p12, p22, real], ...],
     "post": [s, u, b, p00, p01, p02, p11, p12, p22],
     "reader": {<MarkerReader.to_dict()>},
     "last_fix_t": t | null, "last_gnss_t": t | null,
     "counters": [stale_measurements, unknown_markers],
     "gnss_rejects": n,          # only when n > 0 (added after version 1)
     "restart": [t, n],          # only during a run of far-behind samples (motion.restart)
     "direction": {"assumed": b, "anchor": [s, var] | null,
                   "last_fix": [s, var] | null},  # only while not settled
     "gnss_disagrees": true}     # only while GNSS jumped beyond any brake (motion.policy)

``gnss_rejects`` counts the GNSS speeds rejected in a row by the gate; it is
written only while non-zero, so a healthy filter keeps the version-1 form and
an older worker (which ignores the key) still reads the document.  A buffer
measurement of kind 2 (:attr:`~motion.model.MeasurementKind.SPEED_RESTART`)
is written only after such a run of rejections, one of kind 3
(``DIRECTION_FLIP``) only when a fix showed an assumed sign wrong; both leave
the buffer within ``max_delay_s``.  An older worker ignores the keys
``restart`` and ``direction`` (it then claims the assumed direction, as it
always did) but would misread a kind-3 entry as a speed: a snapshot written
during those seconds is for this release or a later one only.

``config`` holds every version-1 field, and a field added since only when it
differs from its default (so default-tuned snapshots keep the version-1 form).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import asdict, dataclass
from typing import Any, Protocol

from .buffer import Entry, ReplayBuffer
from .direction import DirectionWatch
from .marker_reader import MarkerReader
from .model import Estimate, Measurement, estimate
from .policy import GnssPolicy
from .restart import RestartWatch
from .samples import FilterConfig
from .track import MarkerTable

__all__ = ["SNAPSHOT_VERSION", "FilterParts", "Snapshot", "export"]

SNAPSHOT_VERSION = 1
# FilterConfig fields added after version 1: written only when not at their default.
_ADDED_AFTER_V1 = frozenset(
    {
        "fix_offset_sigmas",
        "fix_offset_margin_m",
        "direction_sigmas",
        "lost_speed_sigma",
        "gnss_reject_limit",
        "unknown_speed_sigma",
        "max_gap_s",
        "restart_jump_s",
        "restart_confirm_samples",
    }
)
_CONFIG_DEFAULTS = asdict(FilterConfig())


def _encode_config(cfg: FilterConfig) -> dict[str, Any]:
    return {
        k: v for k, v in asdict(cfg).items() if k not in _ADDED_AFTER_V1 or v != _CONFIG_DEFAULTS[k]
    }


def _encode_entry(e: Entry) -> list[Any]:
    ms = [[int(m.kind), m.value, m.variance] for m in e.measurements] if e.measurements else None
    return [e.t, e.accel, ms, *e.prior, bool(e.real)]


def _decode_entry(e: list[Any]) -> Entry:
    ms = [Measurement(int(m[0]), float(m[1]), float(m[2])) for m in e[2]] if e[2] else None
    prior = estimate(e[3:12])
    return Entry(float(e[0]), float(e[1]), ms, prior, bool(e[12]))


@dataclass(frozen=True)
class Snapshot:
    """Everything a filter needs to continue, apart from its marker table."""

    table_fingerprint: str
    config: FilterConfig
    entries: list[Entry]
    post: Estimate | None  # None before the first sample
    reader: dict[str, Any]
    last_fix_t: float  # -inf: no fix used yet
    last_gnss_t: float | None
    stale_measurements: int = 0
    unknown_markers: int = 0
    gnss_rejects: int = 0
    restart: list[Any] | None = None  # motion.restart.RestartWatch, during a run
    direction: dict[str, Any] | None = None  # motion.direction.DirectionWatch, while assumed
    gnss_disagrees: bool = False  # motion.policy.GnssPolicy.disagrees

    def to_json(self) -> dict[str, Any]:
        """The JSON-safe document (key order fixed: it is compared byte for byte)."""
        doc: dict[str, Any] = {
            "version": SNAPSHOT_VERSION,
            "table": self.table_fingerprint,
            "config": _encode_config(self.config),
            "buffer": [_encode_entry(e) for e in self.entries],
            "post": [] if self.post is None else list(self.post),
            "reader": self.reader,
            "last_fix_t": None if math.isinf(self.last_fix_t) else self.last_fix_t,
            "last_gnss_t": self.last_gnss_t,
            "counters": [self.stale_measurements, self.unknown_markers],
        }
        if self.gnss_rejects:
            doc["gnss_rejects"] = self.gnss_rejects
        if self.restart is not None:
            doc["restart"] = self.restart
        if self.direction is not None:
            doc["direction"] = self.direction
        if self.gnss_disagrees:
            doc["gnss_disagrees"] = True
        return doc

    @classmethod
    def from_json(cls, d: Mapping[str, Any], table_fingerprint: str) -> Snapshot:
        """Parse a document of :meth:`to_json` taken with the marker table of
        ``table_fingerprint``; ``ValueError`` if it is not one."""
        if d.get("version") != SNAPSHOT_VERSION:
            raise ValueError("unsupported filter snapshot version")
        if d.get("table") != table_fingerprint:
            raise ValueError("the snapshot was taken with a different marker table")
        post = [float(v) for v in d["post"]]
        lf = d.get("last_fix_t")
        lg = d.get("last_gnss_t")
        stale, unknown = (int(v) for v in d.get("counters", [0, 0]))
        return cls(
            table_fingerprint=table_fingerprint,
            config=FilterConfig(**d["config"]),
            entries=[_decode_entry(e) for e in d["buffer"]],
            post=estimate(post) if post else None,
            reader=d.get("reader", {}),
            last_fix_t=-math.inf if lf is None else float(lf),
            last_gnss_t=None if lg is None else float(lg),
            stale_measurements=stale,
            unknown_markers=unknown,
            gnss_rejects=int(d.get("gnss_rejects", 0)),
            restart=d.get("restart"),
            direction=d.get("direction"),
            gnss_disagrees=bool(d.get("gnss_disagrees", False)),
        )

    def restore_into(self, f: FilterParts) -> None:
        """Put this snapshot into a new filter made with its table and config."""
        f._buf.entries = self.entries
        f._post = self.post
        f._reader.restore(self.reader)
        f._policy.last_fix_t = self.last_fix_t
        f._policy.last_gnss_t = self.last_gnss_t
        f._policy.disagrees = self.gnss_disagrees
        f.stale_measurements = self.stale_measurements
        f.unknown_markers = self.unknown_markers
        f.gnss_rejects = self.gnss_rejects
        f._restart.restore(self.restart)
        f._direction.restore(self.direction)


class FilterParts(Protocol):
    """What a snapshot holds of a :class:`motion.fusion.TrackFilter` (its own parts)."""

    table: MarkerTable
    cfg: FilterConfig
    _buf: ReplayBuffer
    _post: Estimate | None
    _reader: MarkerReader
    _policy: GnssPolicy
    _restart: RestartWatch
    _direction: DirectionWatch
    stale_measurements: int
    unknown_markers: int
    gnss_rejects: int


def export(f: FilterParts) -> dict[str, Any]:
    """The JSON-safe snapshot document of filter ``f``."""
    return Snapshot(
        table_fingerprint=f.table.fingerprint,
        config=f.cfg,
        entries=f._buf.entries,
        post=f._post,
        reader=f._reader.to_dict(),
        last_fix_t=f._policy.last_fix_t,
        last_gnss_t=f._policy.last_gnss_t,
        stale_measurements=f.stale_measurements,
        unknown_markers=f.unknown_markers,
        gnss_rejects=f.gnss_rejects,
        restart=f._restart.to_json(),
        direction=f._direction.to_json(),
        gnss_disagrees=f._policy.disagrees,
    ).to_json()
