"""When the marker reader should be on, and which markers were missed
(seed ``004``: "the reader is switched on only near the next expected
marker"; "a marker that is not read: in its expected zone, convert the GNSS
geographic fix to a track coordinate and correct with it")."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from .track import Marker, MarkerTable

__all__ = ["MarkerReader", "ReaderView"]


@dataclass(frozen=True, slots=True)
class ReaderView:
    reader_on: bool
    next_marker: Marker | None
    distance_m: float | None


class MarkerReader:
    """Reader switching and missed-marker bookkeeping for one train.

    The reader is on while a marker not yet read lies within
    ``3·σ_s + margin_m`` of the estimated coordinate; a marker passed by
    more than that window without a read is *missed*, and its zone
    (``± zone_m``) then accepts GNSS fixes.
    """

    __slots__ = ("table", "margin_m", "zone_m", "armed", "last_read", "missed", "zone", "last_dir")

    def __init__(self, table: MarkerTable, margin_m: float, zone_m: float) -> None:
        self.table = table
        self.margin_m = margin_m
        self.zone_m = zone_m
        self.armed: str | None = None  # the marker the reader is on for
        self.last_read: str | None = None
        self.missed: list[str] = []  # the newest eight
        self.zone: str | None = None  # a missed marker whose zone is current
        self.last_dir = 1

    def read(self, marker_id: str) -> None:
        self.last_read = marker_id
        self.armed = None
        self.zone = None
        if marker_id in self.missed:
            self.missed.remove(marker_id)

    def update(self, s: float, sigma_s: float, direction: int, known: bool) -> ReaderView:
        """Advance with the newest estimate (coordinate, its σ, direction)."""
        if direction:
            self.last_dir = direction
        if not known:
            return ReaderView(True, None, None)
        table = self.table
        if not len(table):
            return ReaderView(False, None, None)
        window = 3.0 * sigma_s + self.margin_m
        if self.armed is not None:
            m = table.get(self.armed)
            if m is None or (s - m.track_m) * self.last_dir > window:
                if m is not None:
                    self.missed = [*self.missed, m.id][-8:]
                    self.zone = m.id
                self.armed = None
        if self.zone is not None:
            zm = table.get(self.zone)
            if zm is None or abs(s - zm.track_m) > self.zone_m:
                self.zone = None
        # the cheap test first: most of the time no marker is anywhere near
        if self.armed is None and table.distance_to_nearest(s) <= window:
            m2 = table.nearest(s, exclude=self.last_read)
            if (
                m2 is not None
                and abs(m2.track_m - s) <= window
                and m2.id not in self.missed
                and (m2.track_m - s) * self.last_dir > -window
            ):
                self.armed = m2.id
        if self.armed is not None:
            nxt = table.get(self.armed)
        else:
            nxt = table.next_marker(s, self.last_dir)
            if nxt is not None and nxt.id == self.last_read:
                nxt = table.next_marker(nxt.track_m, self.last_dir)
        dist = None if nxt is None else abs(nxt.track_m - s)
        return ReaderView(self.armed is not None, nxt, dist)

    def to_dict(self) -> dict[str, Any]:
        return {
            "armed": self.armed,
            "last_read": self.last_read,
            "missed": list(self.missed),
            "zone": self.zone,
            "last_dir": self.last_dir,
        }

    def restore(self, d: dict[str, Any]) -> None:
        self.armed = d.get("armed")
        self.last_read = d.get("last_read")
        self.missed = [str(m) for m in d.get("missed", [])]
        self.zone = d.get("zone")
        self.last_dir = int(d.get("last_dir", 1))
