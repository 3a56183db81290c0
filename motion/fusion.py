"""Train position and speed by mutual correction of sensors (seed ``004``).

An accelerometer on the car's long axis (continuous, no delay, but its
integral drifts), a GNSS receiver giving the speed late (``gnss_delay_s``)
and losing it in tunnels, and a reader of track markers whose ids map to
track coordinates in a database — all on one clock — are fused by
:class:`TrackFilter`, a Kalman filter on

    x = [track coordinate s (m), speed u along increasing s (m/s),
         accelerometer bias b (m/s²)].

Model
-----
The accelerometer reads the specific force along the car's forward axis,
``a_m = o·(ü + g·i(s)) + b + noise``, where ``o = ±1`` is the car's
orientation on the track (``FilterConfig.orientation``: +1 when the car's
forward axis points to increasing coordinates) and ``i(s)`` the track
gradient (rising with s, from the marker table; 0 when none is given).  So
``u̇ = o·(a_m - b) - g·i(s)``; between two samples the acceleration is taken
linear in time and integrated exactly.

Measurements:

* GNSS speed — ``|u|`` at time ``t - gnss_delay_s``.  The filter keeps the
  last ``max_delay_s`` seconds of samples with their states; a delayed
  speed is inserted at its own time and the filter is re-run from the
  buffered state there up to now ("re-filtering from a buffered state").
  This is the patent's "correction held through the delay and refined when
  the signal returns": the bias state carries the correction across
  outages.
* Track marker — the marker's coordinate at the sample's time (the reader
  time-stamps the read on the common clock; the on-board unit sends a
  sample at the read).  It is a near-exact position fix.
* GNSS geographic fix — only for a marker that was *not* read: inside the
  missed marker's zone the fix (``gnss_lat``/``gnss_lon``, delayed like the
  speed) is projected onto the track geometry of the marker table and
  applied as a coarse position measurement, at most one per
  ``gnss_fix_interval_s`` (fixes are correlated in time).  Also used to find
  the train when its position is unknown.

The marker reader should be on (``TrackState.reader_on``) while a marker
that has not been read lies within ``3·σ_s + reader_margin_m`` of the
estimated position (or while the position is unknown); when the estimate has
passed a marker by that window without a read, the marker is declared
missed.

Feeding it from the service
---------------------------
One :class:`TrackFilter` per train, sharing one :class:`MarkerTable`::

    table = MarkerTable.from_dict(line_json)          # once
    filt = filters.setdefault(train, TrackFilter(table, FilterConfig()))
    state = filt.update(event)   # a motion_sample event body (a mapping)
    state.position_m, state.speed_mps, state.sigma_position_m, state.section

``update`` accepts a :class:`MotionSample` or any mapping with the keys of
the ``motion_sample`` event: ``t`` (s, the on-board clock), ``accel_mps2``,
optional ``gnss_speed_mps``, ``gnss_delay_s``, ``marker_id``, ``gnss_lat``,
``gnss_lon``; other keys (``train``, ``event_id``, ...) are ignored.
Invalid values raise :class:`ValueError` (answer 422); a sample older than
the buffer raises :class:`StaleSampleError` (a ``ValueError``).  Samples
that arrive out of order but within the buffer are inserted and the filter
re-run.  ``to_dict()``/``TrackFilter.from_dict(d, table)`` give a JSON-safe
snapshot (a few kB: the buffer of the last ``max_delay_s`` seconds); the
filter also pickles.
"""

from __future__ import annotations

import bisect
import math
from collections.abc import Mapping
from dataclasses import asdict
from typing import Any

from .gnss_delay import estimate_gnss_delay
from .marker_reader import MarkerReader
from .samples import (
    FilterConfig,
    MotionSample,
    StaleSampleError,
    TrackState,
    check_sample,
    coerce_sample,
)
from .track import Marker, MarkerTable, Section

__all__ = [
    "G",
    "FilterConfig",
    "Marker",
    "MarkerTable",
    "MotionSample",
    "Section",
    "StaleSampleError",
    "TrackFilter",
    "TrackState",
    "estimate_gnss_delay",
]

G = 9.81

# Buffer entry layout (a list per sample, for speed).
_T, _A, _M, _S, _U, _B, _P00, _P01, _P02, _P11, _P12, _P22, _REAL = range(13)
_POS, _SPD = 0, 1


class TrackFilter:
    """Online Kalman filter on (coordinate, speed, accelerometer bias).

    ``update(sample) -> TrackState`` per ``motion_sample``; see the module
    documentation for the model and for how the service feeds it.

    Internals: ``_buf`` holds one entry per sample of the last
    ``max_delay_s`` seconds (plus entries inserted at the times of delayed
    measurements): ``[t, accel, measurements, prior state (9 floats), real]``
    where the prior is the state predicted to ``t`` before that entry's
    measurements.  A delayed measurement is attached to its entry and the
    filter re-run from there; ``_post`` is the newest posterior
    ``[s, u, b, P00, P01, P02, P11, P12, P22]``.
    """

    __slots__ = (
        "table",
        "cfg",
        "_buf",
        "_post",
        "_qa",
        "_qb",
        "_o",
        "_grad",
        "_reader",
        "_last_fix_t",
        "_last_gnss_t",
        "_state",
        "stale_measurements",
        "unknown_markers",
    )

    def __init__(
        self, table: MarkerTable | None = None, config: FilterConfig | None = None
    ) -> None:
        self.table = table if table is not None else MarkerTable([])
        self.cfg = config or FilterConfig()
        c = self.cfg
        self._qa = c.accel_noise_mps2**2 / c.sample_rate_hz + c.accel_model_psd
        self._qb = c.bias_walk**2
        self._o = float(c.orientation)
        self._grad = self.table.has_gradients
        self._buf: list[list[Any]] = []
        self._post: list[float] = []
        self._reader = MarkerReader(self.table, c.reader_margin_m, c.missed_zone_m)
        self._last_fix_t = -math.inf
        self._last_gnss_t: float | None = None
        self._state: TrackState | None = None
        self.stale_measurements = 0
        self.unknown_markers = 0

    # -- public API ----------------------------------------------------------
    @property
    def state(self) -> TrackState | None:
        """The newest estimate (``None`` before the first sample)."""
        return self._state

    def update(self, sample: MotionSample | Mapping[str, Any]) -> TrackState:
        """Feed one sample (a :class:`MotionSample` or an event mapping)."""
        s = coerce_sample(sample)
        return self.step(
            s.t,
            s.accel_mps2,
            s.gnss_speed_mps,
            s.gnss_delay_s,
            s.marker_id,
            s.gnss_lat,
            s.gnss_lon,
        )

    def step(
        self,
        t: float,
        accel_mps2: float,
        gnss_speed_mps: float | None = None,
        gnss_delay_s: float | None = None,
        marker_id: str | None = None,
        gnss_lat: float | None = None,
        gnss_lon: float | None = None,
    ) -> TrackState:
        """Same as :meth:`update` with plain arguments (the fast path)."""
        cfg = self.cfg
        delay = cfg.gnss_delay_s if gnss_delay_s is None else gnss_delay_s
        check_sample(t, accel_mps2, gnss_speed_mps, delay, gnss_lat, gnss_lon)
        buf = self._buf
        if not buf:
            self._init(t, accel_mps2)
            i = 0
            replay = 0
        elif t > buf[-1][_T]:
            p = buf[-1]
            e = [t, accel_mps2, None, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, True]
            self._propagate(self._post, p[_T], p[_A], e)
            buf.append(e)
            i = len(buf) - 1
            replay = i
        else:
            i = self._insert_real(t, accel_mps2)
            replay = i

        # Marker read: an exact position at the sample's time.
        if marker_id is not None:
            mk = self.table.get(marker_id)
            if mk is None:
                self.unknown_markers += 1
            else:
                self._add_meas(i, (_POS, mk.track_m, cfg.marker_sigma**2))
                self._reader.read(mk.id)
        # Delayed GNSS speed at its own time.
        if gnss_speed_mps is not None:
            tg = t - delay
            j = self._at_time(tg)
            if j is None:
                self.stale_measurements += 1
            else:
                # (an entry inserted at j <= replay shifts the later ones: j is then the start)
                self._add_meas(j, (_SPD, gnss_speed_mps, cfg.gnss_speed_sigma**2))
                replay = min(replay, j)
                if self._last_gnss_t is None or tg > self._last_gnss_t:
                    self._last_gnss_t = tg
        self._replay(replay)
        # Delayed GNSS fix: only in a missed marker's zone or with the position unknown.
        if gnss_lat is not None and gnss_lon is not None and self.table.has_geometry:
            j2 = self._fix_entry(t - delay, gnss_lat, gnss_lon)
            if j2 is not None:
                self._replay(j2)
        self._trim()
        st = self._make_state()
        self._state = st
        return st

    # -- buffer mechanics ----------------------------------------------------
    def _init(self, t: float, a: float) -> None:
        c = self.cfg
        if c.initial_position_m is None:
            s0, ps = 0.0, c.unknown_position_sigma**2
        else:
            s0, ps = c.initial_position_m, c.initial_position_sigma**2
        prior = [
            s0,
            c.initial_speed_mps,
            0.0,
            ps,
            0.0,
            0.0,
            c.initial_speed_sigma**2,
            0.0,
            c.bias_sigma0**2,
        ]
        self._buf.append([t, a, None, *prior, True])
        self._post = list(prior)

    def _propagate(self, x: list[float], t0: float, a0: float, e: list[Any]) -> None:
        """Prior of entry ``e`` predicted from posterior ``x`` at ``(t0, a0)``,
        the acceleration taken linear in time between the two samples."""
        dt = e[_T] - t0
        o = self._o
        a1 = e[_A]
        s, u, b = x[0], x[1], x[2]
        gi = G * self.table.gradient_at(s) / 1000.0 if self._grad else 0.0
        acc_v = o * ((a0 + a1) * 0.5 - b) - gi
        acc_s = o * ((2.0 * a0 + a1) / 3.0 - b) - gi
        e[_S] = s + u * dt + 0.5 * acc_s * dt * dt
        e[_U] = u + acc_v * dt
        e[_B] = b
        A = dt
        Bc = -o * 0.5 * dt * dt
        C = -o * dt
        p00, p01, p02, p11, p12, p22 = x[3], x[4], x[5], x[6], x[7], x[8]
        r00 = p00 + A * p01 + Bc * p02
        r01 = p01 + A * p11 + Bc * p12
        r02 = p02 + A * p12 + Bc * p22
        r11 = p11 + C * p12
        r12 = p12 + C * p22
        qa = self._qa
        dt2 = dt * dt
        e[_P00] = r00 + A * r01 + Bc * r02 + qa * dt2 * dt / 3.0
        e[_P01] = r01 + C * r02 + qa * dt2 * 0.5
        e[_P02] = r02
        e[_P11] = r11 + C * r12 + qa * dt
        e[_P12] = r12
        e[_P22] = p22 + self._qb * dt

    def _apply(self, x: list[float], meas: list[tuple[int, float, float]]) -> None:
        """Scalar Kalman updates of the state ``x`` (9 floats) in place."""
        for kind, z, r in meas:
            if kind == _POS:
                y = z - x[0]
                p0, p1, p2 = x[3], x[4], x[5]
                sv = p0 + r
            else:
                # GNSS measures |u|: linearised with the sign of the estimate.
                sg = 1.0 if x[1] >= 0.0 else -1.0
                y = sg * z - x[1]
                p0, p1, p2 = x[4], x[6], x[7]
                sv = p1 + r
                if y * y > self.cfg.gnss_gate**2 * sv:
                    continue  # an outlier (multipath, re-acquisition glitch)
            k0, k1, k2 = p0 / sv, p1 / sv, p2 / sv
            x[0] += k0 * y
            x[1] += k1 * y
            x[2] += k2 * y
            x[3] -= k0 * p0
            x[4] -= k0 * p1
            x[5] -= k0 * p2
            x[6] -= k1 * p1
            x[7] -= k1 * p2
            x[8] -= k2 * p2

    def _post_of(self, j: int) -> list[float]:
        e = self._buf[j]
        x: list[float] = e[_S : _P22 + 1]
        if e[_M]:
            self._apply(x, e[_M])
        return x

    def _replay(self, i: int) -> None:
        """Re-run the filter from entry ``i`` (its prior is valid) to the end."""
        buf = self._buf
        x = self._post_of(i)
        for j in range(i + 1, len(buf)):
            p = buf[j - 1]
            e = buf[j]
            self._propagate(x, p[_T], p[_A], e)
            x = e[_S : _P22 + 1]
            if e[_M]:
                self._apply(x, e[_M])
        self._post = x

    def _add_meas(self, i: int, m: tuple[int, float, float]) -> None:
        e = self._buf[i]
        if e[_M] is None:
            e[_M] = [m]
        else:
            e[_M].append(m)

    def _new_entry(self, k: int, t: float, a: float, real: bool) -> None:
        """Insert an entry at index ``k`` (``k ≥ 1``); its successors must be re-run."""
        buf = self._buf
        p = buf[k - 1]
        e = [t, a, None, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, real]
        self._propagate(self._post_of(k - 1), p[_T], p[_A], e)
        buf.insert(k, e)

    def _at_time(self, tau: float) -> int | None:
        """Index of the buffer entry at time ``tau``, inserted if needed;
        ``None`` when ``tau`` is older than the buffer."""
        buf = self._buf
        if tau >= buf[-1][_T] - 1e-9:
            return len(buf) - 1
        if tau < buf[0][_T] - 1e-9:
            return None
        k = bisect.bisect_left(buf, tau - 1e-9, key=lambda e: e[_T])
        if abs(buf[k][_T] - tau) <= 1e-9:
            return k
        p = buf[k - 1]
        nx = buf[k]
        w = (tau - p[_T]) / (nx[_T] - p[_T])
        self._new_entry(k, tau, p[_A] + w * (nx[_A] - p[_A]), False)
        return k

    def _insert_real(self, t: float, a: float) -> int:
        """An out-of-order (or repeated) sample inside the buffer."""
        buf = self._buf
        if t < buf[0][_T] - 1e-9:
            raise StaleSampleError(
                f"sample at t={t} is older than the filter's buffer (starts at t={buf[0][_T]})"
            )
        k = bisect.bisect_left(buf, t - 1e-9, key=lambda e: e[_T])
        if abs(buf[k][_T] - t) <= 1e-9:
            e = buf[k]
            e[_A] = a
            e[_REAL] = True
            if k > 0:
                self._propagate(self._post_of(k - 1), buf[k - 1][_T], buf[k - 1][_A], e)
            return k
        self._new_entry(k, t, a, True)
        return k

    def _trim(self) -> None:
        buf = self._buf
        horizon = buf[-1][_T] - self.cfg.max_delay_s
        # trim about once a second, not at every sample
        if len(buf) > 2 and buf[0][_T] < horizon - 1.0:
            k = bisect.bisect_left(buf, horizon, key=lambda e: e[_T])
            del buf[: max(0, k - 1)]  # keep one entry at or before the horizon

    def _fix_entry(self, tau: float, lat: float, lon: float) -> int | None:
        """Attach a GNSS geographic fix if it is wanted; the entry index or None."""
        cfg = self.cfg
        if tau - self._last_fix_t < cfg.gnss_fix_interval_s:
            return None
        var = self._post[3]
        unknown = var > cfg.lost_position_sigma**2
        # In a missed marker's zone a fix is used only when it can help: GNSS
        # errors are correlated over minutes, so repeated fixes do not average.
        if not unknown and (self._reader.zone is None or var < cfg.gnss_position_sigma**2):
            return None
        j = self._at_time(tau)
        if j is None:
            self.stale_measurements += 1
            return None
        s_at = self._post_of(j)[0]
        s_fix, offset = self.table.project(lat, lon, None if unknown else s_at)
        if offset > 5 * cfg.gnss_position_sigma + 50.0:
            self._replay(j)  # an entry may have been inserted
            return None
        self._last_fix_t = tau
        self._add_meas(j, (_POS, s_fix, cfg.gnss_position_sigma**2))
        return j

    # -- outputs ---------------------------------------------------------------
    def _make_state(self) -> TrackState:
        cfg = self.cfg
        e = self._buf[-1]
        s, u, b, p00, _, _, p11, _, p22 = self._post
        sig_s = math.sqrt(max(p00, 0.0))
        sig_u = math.sqrt(max(p11, 0.0))
        known = sig_s < cfg.lost_position_sigma
        thr = max(2.0 * sig_u, cfg.standstill_mps)
        d = 1 if u > thr else (-1 if u < -thr else 0)
        table = self.table
        gi = G * table.gradient_at(s) / 1000.0 if table.has_gradients else 0.0
        view = self._reader.update(s, sig_s, d, known)
        return TrackState(
            t=e[_T],
            position_m=s,
            speed_mps=u,
            acceleration_mps2=cfg.orientation * (e[_A] - b) - gi,
            direction=d,
            sigma_position_m=sig_s,
            sigma_speed_mps=sig_u,
            sigma_acceleration_mps2=math.sqrt(max(p22, 0.0) + cfg.accel_noise_mps2**2),
            accel_bias_mps2=b,
            sigma_bias_mps2=math.sqrt(max(p22, 0.0)),
            position_known=known,
            reader_on=view.reader_on,
            next_marker_id=None if view.next_marker is None else view.next_marker.id,
            distance_to_next_marker_m=view.distance_m,
            last_marker_id=self._reader.last_read,
            missed_marker_ids=tuple(self._reader.missed),
            section=table.section_at(s),
            gnss_age_s=None if self._last_gnss_t is None else e[_T] - self._last_gnss_t,
        )

    # -- persistence -------------------------------------------------------------
    def to_dict(self) -> dict[str, Any]:
        """A JSON-safe snapshot; restore with :meth:`from_dict` and the same table."""
        return {
            "version": 1,
            "table": self.table.fingerprint,
            "config": asdict(self.cfg),
            "buffer": [
                [e[0], e[1], [list(m) for m in e[2]] if e[2] else None, *e[3:12], bool(e[12])]
                for e in self._buf
            ],
            "post": list(self._post),
            "reader": self._reader.to_dict(),
            "last_fix_t": None if math.isinf(self._last_fix_t) else self._last_fix_t,
            "last_gnss_t": self._last_gnss_t,
            "counters": [self.stale_measurements, self.unknown_markers],
        }

    @classmethod
    def from_dict(cls, d: Mapping[str, Any], table: MarkerTable | None = None) -> TrackFilter:
        """Restore a snapshot of :meth:`to_dict` (``table``: the same marker table)."""
        if d.get("version") != 1:
            raise ValueError("unsupported filter snapshot version")
        tb = table if table is not None else MarkerTable([])
        if d.get("table") != tb.fingerprint:
            raise ValueError("the snapshot was taken with a different marker table")
        f = cls(tb, FilterConfig(**d["config"]))
        f._buf = [
            [
                float(e[0]),
                float(e[1]),
                [(int(m[0]), float(m[1]), float(m[2])) for m in e[2]] if e[2] else None,
                *(float(v) for v in e[3:12]),
                bool(e[12]),
            ]
            for e in d["buffer"]
        ]
        f._post = [float(v) for v in d["post"]]
        f._reader.restore(d.get("reader", {}))
        lf = d.get("last_fix_t")
        f._last_fix_t = -math.inf if lf is None else float(lf)
        lg = d.get("last_gnss_t")
        f._last_gnss_t = None if lg is None else float(lg)
        f.stale_measurements, f.unknown_markers = (int(v) for v in d.get("counters", [0, 0]))
        if f._buf:
            f._state = f._make_state()
        return f

    def __getstate__(self) -> dict[str, Any]:
        return {"table": self.table, "snap": self.to_dict()}

    def __setstate__(self, st: dict[str, Any]) -> None:
        g = TrackFilter.from_dict(st["snap"], st["table"])
        for name in TrackFilter.__slots__:
            setattr(self, name, getattr(g, name))
