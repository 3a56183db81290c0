"""The on-board track database: markers, geometry, gradients, sections
(seed ``004``: marker ids map to track and geographic coordinates).
"""

from __future__ import annotations

import bisect
import hashlib
import json
import math
from collections.abc import Iterable, Mapping
from dataclasses import asdict, dataclass
from typing import Any

import numpy as np
import numpy.typing as npt

__all__ = ["EARTH_R", "Marker", "MarkerTable", "Section"]

EARTH_R = 6_371_000.0


@dataclass(frozen=True, slots=True)
class Marker:
    id: str
    track_m: float
    lat: float | None = None
    lon: float | None = None


@dataclass(frozen=True, slots=True)
class Section:
    id: str
    start_m: float
    end_m: float


class MarkerTable:
    """Track markers (id → track coordinate, optionally geographic position),
    the track geometry used to project GNSS fixes, the gradient profile and
    the block sections.  Immutable; share one per line among all filters.

    * ``gradients``: ``(from_m, permille)`` breakpoints; a gradient holds
      from its coordinate to the next breakpoint; positive rises with the
      coordinate.
    * ``geometry``: ``(track_m, lat, lon)`` points along the track; defaults
      to the markers that have a geographic position.  Fixes are projected
      on the polyline through them.
    * ``sections``: block sections ``(id, start_m, end_m)``.
    """

    __slots__ = (
        "_by_id",
        "_coords",
        "_ids",
        "_grad_at",
        "_grad_val",
        "_sections",
        "_geo_s",
        "_geo_xy",
        "_geo_pts",
        "_lat0",
        "_lon0",
        "fingerprint",
    )

    def __init__(
        self,
        markers: Iterable[Marker | tuple[Any, ...] | Mapping[str, Any]],
        *,
        gradients: Iterable[tuple[float, float]] = (),
        sections: Iterable[Section | tuple[str, float, float]] = (),
        geometry: Iterable[tuple[float, float, float]] | None = None,
    ) -> None:
        ms: list[Marker] = []
        for m in markers:
            if isinstance(m, Marker):
                mk = m
            elif isinstance(m, Mapping):
                mk = Marker(str(m["id"]), float(m["track_m"]), m.get("lat"), m.get("lon"))
            else:
                mk = Marker(str(m[0]), float(m[1]), *(m[2:4]))
            if not math.isfinite(mk.track_m):
                raise ValueError(f"marker {mk.id}: track coordinate must be finite")
            ms.append(mk)
        ms.sort(key=lambda m: m.track_m)
        self._by_id = {m.id: m for m in ms}
        if len(self._by_id) != len(ms):
            raise ValueError("duplicate marker ids")
        self._coords = [m.track_m for m in ms]
        self._ids = [m.id for m in ms]
        g = sorted((float(a), float(b)) for a, b in gradients)
        self._grad_at = [a for a, _ in g]
        self._grad_val = [b for _, b in g]
        secs = [
            s if isinstance(s, Section) else Section(str(s[0]), float(s[1]), float(s[2]))
            for s in sections
        ]
        self._sections = sorted(secs, key=lambda s: s.start_m)
        if geometry is None:
            pts = [
                (m.track_m, float(m.lat), float(m.lon))
                for m in ms
                if m.lat is not None and m.lon is not None
            ]
        else:
            pts = sorted((float(a), float(b), float(c)) for a, b, c in geometry)
        if len(pts) >= 2:
            arr = np.asarray(pts, dtype=np.float64)
            self._lat0 = float(arr[0, 1])
            self._lon0 = float(arr[0, 2])
            self._geo_s = arr[:, 0]
            self._geo_xy = self._to_xy(arr[:, 1], arr[:, 2])
            self._geo_pts: list[list[float]] = [list(p) for p in pts]  # exact round trips
        else:
            self._lat0 = self._lon0 = 0.0
            self._geo_s = np.empty(0)
            self._geo_xy = np.empty((0, 2))
            self._geo_pts = []
        blob = json.dumps(self.to_dict(), sort_keys=True).encode()
        self.fingerprint = hashlib.sha256(blob).hexdigest()[:16]

    # -- lookups -------------------------------------------------------------
    def __len__(self) -> int:
        return len(self._ids)

    def __contains__(self, marker_id: object) -> bool:
        return str(marker_id) in self._by_id

    def get(self, marker_id: object) -> Marker | None:
        return self._by_id.get(str(marker_id))

    def coordinate(self, marker_id: object) -> float:
        """Track coordinate of a marker; ``KeyError`` if unknown."""
        return self._by_id[str(marker_id)].track_m

    @property
    def markers(self) -> list[Marker]:
        return [self._by_id[i] for i in self._ids]

    def nearest(self, s: float, exclude: object = None) -> Marker | None:
        """The marker nearest to coordinate ``s`` (optionally not ``exclude``)."""
        c = self._coords
        ids = self._ids
        k = bisect.bisect_left(c, s)
        best = -1
        bd = math.inf
        for j in (k - 2, k - 1, k, k + 1):
            if 0 <= j < len(c) and ids[j] != exclude:
                d = abs(c[j] - s)
                if d < bd:
                    bd, best = d, j
        return self._by_id[ids[best]] if best >= 0 else None

    def distance_to_nearest(self, s: float) -> float:
        """Distance from ``s`` to the nearest marker (inf without markers)."""
        c = self._coords
        k = bisect.bisect_left(c, s)
        d = abs(c[k] - s) if k < len(c) else math.inf
        return min(d, abs(c[k - 1] - s)) if k > 0 else d

    def next_marker(self, s: float, direction: int) -> Marker | None:
        """First marker strictly ahead of ``s`` in ``direction`` (+1/-1)."""
        c = self._coords
        if direction >= 0:
            k = bisect.bisect_right(c, s)
            return self._by_id[self._ids[k]] if k < len(c) else None
        k = bisect.bisect_left(c, s) - 1
        return self._by_id[self._ids[k]] if k >= 0 else None

    def gradient_at(self, s: float) -> float:
        """Gradient in ‰ at coordinate ``s`` (0 before the first breakpoint)."""
        k = bisect.bisect_right(self._grad_at, s) - 1
        return self._grad_val[k] if k >= 0 else 0.0

    @property
    def has_gradients(self) -> bool:
        return bool(self._grad_at)

    def section_at(self, s: float) -> str | None:
        """The block section containing coordinate ``s`` (None outside all)."""
        for sec in self._sections:
            if sec.start_m <= s < sec.end_m:
                return sec.id
        return None

    @property
    def has_geometry(self) -> bool:
        return self._geo_s.size >= 2

    def _to_xy(self, lat: Any, lon: Any) -> npt.NDArray[np.float64]:
        lat = np.asarray(lat, dtype=np.float64)
        lon = np.asarray(lon, dtype=np.float64)
        x = np.radians(lon - self._lon0) * EARTH_R * math.cos(math.radians(self._lat0))
        y = np.radians(lat - self._lat0) * EARTH_R
        return np.stack([x, y], axis=-1)

    def project(
        self, lat: float, lon: float, near_m: float | None = None, search_m: float = 3000.0
    ) -> tuple[float, float]:
        """Project a geographic fix onto the track: ``(track_m, offset_m)``.

        The geometry polyline is flattened around its first point; the
        coordinate is interpolated along the nearest segment.  With
        ``near_m`` only segments within ``search_m`` of it are considered.
        """
        if not self.has_geometry:
            raise ValueError("the marker table has no geographic positions")
        p = self._to_xy(lat, lon)
        a = self._geo_xy[:-1]
        b = self._geo_xy[1:]
        ab = b - a
        L2 = np.maximum(np.sum(ab * ab, axis=1), 1e-12)
        t = np.clip(np.sum((p - a) * ab, axis=1) / L2, 0.0, 1.0)
        q = a + ab * t[:, None]
        d = np.hypot(q[:, 0] - p[0], q[:, 1] - p[1])
        s0 = self._geo_s[:-1]
        s1 = self._geo_s[1:]
        if near_m is not None:
            far = (s1 < near_m - search_m) | (s0 > near_m + search_m)
            if not np.all(far):
                d = np.where(far, np.inf, d)
        i = int(np.argmin(d))
        return float(s0[i] + t[i] * (s1[i] - s0[i])), float(d[i])

    # -- (de)serialisation ---------------------------------------------------
    def to_dict(self) -> dict[str, Any]:
        return {
            "markers": [asdict(self._by_id[i]) for i in self._ids],
            "gradients": [[a, b] for a, b in zip(self._grad_at, self._grad_val, strict=True)],
            "sections": [[s.id, s.start_m, s.end_m] for s in self._sections],
            "geometry": [list(p) for p in self._geo_pts],
        }

    @classmethod
    def from_dict(cls, d: Mapping[str, Any]) -> MarkerTable:
        geo = d.get("geometry")
        return cls(
            [
                Marker(str(m["id"]), float(m["track_m"]), m.get("lat"), m.get("lon"))
                for m in d["markers"]
            ],
            gradients=[(float(a), float(b)) for a, b in d.get("gradients", [])],
            sections=[(str(a), float(b), float(c)) for a, b, c in d.get("sections", [])],
            geometry=[(float(a), float(b), float(c)) for a, b, c in geo] if geo else None,
        )
