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
One :class:`TrackFilter` per train, sharing one :class:`MarkerTable`
(``MarkerTable.from_dict(line_json)``); ``filt.update(event)`` takes a
:class:`MotionSample` or a ``motion_sample`` event body (``t`` on the on-board
clock, ``accel_mps2``, optional ``gnss_speed_mps``, ``gnss_delay_s``,
``marker_id``, ``gnss_lat``, ``gnss_lon``; other keys ignored) and returns a
:class:`TrackState`.  Invalid values raise
:class:`~motion.samples.SampleRuleError` (the API refuses them with 422 by the
same rules); a sample older than the buffer raises :class:`StaleSampleError`
(both ``ValueError``); out-of-order samples within the buffer are inserted
and the filter re-run.  ``to_dict()``/``TrackFilter.from_dict(d, table)``
give a JSON-safe snapshot of a few kB; the filter also pickles.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

from .buffer import ReplayBuffer
from .direction import DirectionWatch
from .gnss_delay import estimate_gnss_delay
from .marker_reader import MarkerReader
from .model import PER_MILLE, Estimate, G, KalmanModel, Measurement, MeasurementKind
from .policy import GnssPolicy
from .restart import RestartWatch
from .samples import (
    FilterConfig,
    MotionSample,
    StaleSampleError,
    TrackState,
    check_sample,
    coerce_sample,
)
from .state import Snapshot, export
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


class TrackFilter:
    """Online Kalman filter on (coordinate, speed, accelerometer bias).

    ``update(sample) -> TrackState`` per ``motion_sample``; see the module
    documentation for the model and for how the service feeds it.  A delayed
    measurement is attached to the buffer entry at its own time and the
    filter re-run from there; ``_post`` is the newest posterior.
    """

    __slots__ = (
        "table",
        "cfg",
        "_model",
        "_buf",
        "_post",
        "_reader",
        "_policy",
        "_state",
        "stale_measurements",
        "unknown_markers",
        "gnss_rejects",
        "_started_again",
        "_restart",
        "_direction",
    )

    def __init__(
        self, table: MarkerTable | None = None, config: FilterConfig | None = None
    ) -> None:
        self.table = table if table is not None else MarkerTable([])
        self.cfg = config or FilterConfig()
        c = self.cfg
        self._model = KalmanModel(self.table, c)
        self._buf = ReplayBuffer(self._model, span_s=c.max_delay_s)
        self._post: Estimate | None = None
        self._reader = MarkerReader(self.table, c.reader_margin_m, c.missed_zone_m)
        self._policy = GnssPolicy(c)
        self._state: TrackState | None = None
        self.stale_measurements = 0
        self.unknown_markers = 0
        self.gnss_rejects = 0  # GNSS speeds rejected in a row by the gate
        self._started_again = False  # a gap beyond max_gap_s made everything unknown
        self._restart = RestartWatch(c)  # an on-board restart: its clock starts again
        self._direction = DirectionWatch(c)  # whether the sign of the speed is evidence

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
        if self._post is not None and self._starts_again_at(t):
            self._start_again()
        post = self._post
        if post is not None and t > buf.entries[-1].t:
            i = buf.append(t, accel_mps2, post)  # a new newest sample: most of them
        else:
            i = self._place(t, accel_mps2)
        replay = i
        if marker_id is not None:  # a marker read: an exact position at the sample's time
            self._marker_read(i, marker_id)
        j = None
        if gnss_speed_mps is not None:  # the delayed GNSS speed at its own time
            j = self._gnss_speed(t - delay, gnss_speed_mps)
            replay = replay if j is None else min(replay, j)
        self._post = buf.replay(replay)
        if j is not None:
            self._gate_watch(j)
        # The delayed GNSS fix: only in a missed marker's zone or with the position unknown.
        if gnss_lat is not None and gnss_lon is not None and self.table.has_geometry:
            self._gnss_fix(t - delay, gnss_lat, gnss_lon)
        buf.trim(cfg.max_delay_s)
        st = self._make_state()
        self._state = st
        return st

    # -- one sample, part by part -------------------------------------------
    def _place(self, t: float, accel: float) -> int:
        """The buffer index of the first sample, or of one that is not the
        newest (inserted out of order); ``step`` appends the newest itself."""
        buf = self._buf
        if self._post is None or not buf.entries:
            buf.start(t, accel, self._initial())
            return 0
        return buf.insert_real(t, accel)

    def _initial(self) -> Estimate:
        c = self.cfg
        speed_var, bias_var = c.initial_speed_sigma**2, c.bias_sigma0**2
        if self._started_again:  # nothing known about the train: the configured start is past
            ps, speed_var = c.unknown_position_sigma**2, c.unknown_speed_sigma**2
            return (0.0, 0.0, 0.0, ps, 0.0, 0.0, speed_var, 0.0, bias_var)
        if c.initial_position_m is None:
            s0, ps = 0.0, c.unknown_position_sigma**2
        else:
            s0, ps = c.initial_position_m, c.initial_position_sigma**2
        return (s0, c.initial_speed_mps, 0.0, ps, 0.0, 0.0, speed_var, 0.0, bias_var)

    def _starts_again_at(self, t: float) -> bool:
        """Whether the sample at ``t`` starts the filter again: it confirms a
        forward clock jump beyond ``max_gap_s`` (nothing can be integrated across
        that) or an on-board restart; :meth:`RestartWatch.check` refuses a sample
        of a run not yet confirmed, and one later than the late-sample bound (one
        corrupt time stamp, a late old batch, must not wipe a good estimate)."""
        entries = self._buf.entries
        return self._restart.check(t, entries[0].t, entries[-1].t)

    def _start_again(self) -> None:
        """Forget the train's motion (not the counters): the next sample starts
        the filter with position and speed unknown."""
        c = self.cfg
        self._buf.entries = []
        self._post = None
        self._reader = MarkerReader(self.table, c.reader_margin_m, c.missed_zone_m)
        self._policy = GnssPolicy(c)
        self.gnss_rejects = 0
        self._started_again = True
        self._restart.clear()
        self._direction.reset()

    def _marker_read(self, i: int, marker_id: str) -> None:
        mk = self.table.get(marker_id)
        if mk is None:
            self.unknown_markers += 1
            return
        variance = self.cfg.marker_sigma**2
        self._position(i, mk.track_m, variance)
        self._reader.read(mk.id)

    def _position(self, i: int, z: float, variance: float) -> None:
        """A position fix ``z`` at entry ``i``; mirrored first when it shows the
        assumed sign of the speed wrong (:mod:`motion.direction`)."""
        buf = self._buf
        flip_at = self._direction.position_fix(buf.posterior(i), z, variance)
        if flip_at is not None:
            buf.add(i, Measurement(MeasurementKind.DIRECTION_FLIP, flip_at, 0.0))
        buf.add(i, Measurement(MeasurementKind.POSITION, z, variance))

    def _gnss_speed(self, tau: float, speed: float) -> int | None:
        """Attach a GNSS speed measured at ``tau``; returns its entry (where to
        re-run from: an entry inserted at j shifts the later ones), ``None``
        when it is older than the buffer."""
        j = self._buf.at_time(tau)
        if j is None:
            self.stale_measurements += 1
            return None
        variance = self.cfg.gnss_speed_sigma**2
        self._buf.add(j, Measurement(MeasurementKind.SPEED, speed, variance))
        self._policy.speed_used(tau)
        return j

    def _gate_watch(self, j: int) -> None:
        """Count the GNSS speeds the gate rejects in a row (the one just
        attached at entry ``j`` is the last of its measurements).  A single
        outlier is a receiver glitch; ``gnss_reject_limit`` in a row mean the
        filter is confidently wrong, and the gate would keep GNSS out for
        good: the speed starts again from this measurement."""
        buf = self._buf
        e = buf.entries[j]
        assert e.measurements
        m = e.measurements[-1]
        x = self._model.update(e.prior, e.measurements[:-1])
        self._direction.gnss_speed(x, m.value, m.variance)
        policy = self._policy
        if not self._model.speed_rejected(x, m.value, m.variance):
            self.gnss_rejects = 0
            policy.disagrees = False
            return
        if policy.impossible_jump(buf.speed_before(j), e.t, m.value):
            policy.disagrees = True
        limit = self.cfg.gnss_reject_limit
        self.gnss_rejects += 1
        if self.gnss_rejects < limit:
            return
        if policy.disagrees:
            # Following GNSS would be a braking no brake gives: the accelerometer's speed
            # stays, its σ growing as dead reckoning's (the readings are not applied).
            self.gnss_rejects = limit
            return
        self.gnss_rejects = 0
        e.measurements[-1] = Measurement(MeasurementKind.SPEED_RESTART, m.value, m.variance)
        self._direction.lost()  # the speed starts again from a magnitude
        self._post = buf.replay(j)

    def _gnss_fix(self, tau: float, lat: float, lon: float) -> None:
        """Apply a GNSS geographic fix measured at ``tau`` if the policy wants it."""
        policy = self._policy
        assert self._post is not None
        s_now, _, _, var, *_ = self._post
        var += self._direction.spread(s_now)  # with the sign assumed, it may be either way
        if not policy.wants_fix(tau, var, self._reader.zone is not None):
            return
        buf = self._buf
        j = buf.at_time(tau)
        if j is None:
            self.stale_measurements += 1
            return
        s_at, *_ = buf.posterior(j)
        near = None if policy.position_unknown(var) else s_at
        s_fix, offset = self.table.project(lat, lon, near)
        if policy.fix_on_track(offset):
            policy.fix_used(tau)
            self._position(j, s_fix, self.cfg.gnss_position_sigma**2)
        self._post = buf.replay(j)  # (an entry may have been inserted at j)

    # -- outputs ---------------------------------------------------------------
    def _make_state(self) -> TrackState:
        cfg = self.cfg
        e = self._buf.entries[-1]
        assert self._post is not None
        s_in, u, b, p00, _, _, p11, _, p22 = self._post
        # With the sign assumed: no direction, a magnitude, and both ways possible.
        way = self._direction
        s, sig_s = way.centre(s_in), math.sqrt(max(p00, 0.0) + way.spread(s_in))
        sig_u = math.sqrt(max(p11, 0.0))
        known = sig_s < cfg.lost_position_sigma
        thr = max(cfg.direction_sigmas * sig_u, cfg.standstill_mps)
        d = 0 if way.assumed else (1 if u > thr else (-1 if u < -thr else 0))
        view = self._reader.update(s, sig_s, d, known)
        last_gnss_t = self._policy.last_gnss_t
        model = self._model
        gi = G * self.table.gradient_at(s_in) / PER_MILLE if model.grad else 0.0
        return TrackState(
            t=e.t,
            position_m=s,
            speed_mps=abs(u) if way.assumed else u,
            acceleration_mps2=cfg.orientation * (e.accel - b) - gi,
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
            # An unknown position names no section: the placeholder coordinate is nowhere.
            section=self.table.section_at(s) if known else None,
            gnss_age_s=None if last_gnss_t is None else e.t - last_gnss_t,
            gnss_disagrees=self._policy.disagrees,
        )

    # -- persistence (the document and its parts: motion.state) ------------------
    def to_dict(self) -> dict[str, Any]:
        """A JSON-safe snapshot (:mod:`motion.state`); restore with
        :meth:`from_dict` and the same table."""
        return export(self)

    @classmethod
    def from_dict(cls, d: Mapping[str, Any], table: MarkerTable | None = None) -> TrackFilter:
        """Restore a snapshot of :meth:`to_dict` (``table``: the same marker table)."""
        tb = table if table is not None else MarkerTable([])
        snap = Snapshot.from_json(d, tb.fingerprint)
        f = cls(tb, snap.config)
        snap.restore_into(f)
        if f._buf.entries:
            f._state = f._make_state()
        return f

    def __getstate__(self) -> dict[str, Any]:
        return {"table": self.table, "snap": self.to_dict()}

    def __setstate__(self, st: dict[str, Any]) -> None:
        g = TrackFilter.from_dict(st["snap"], st["table"])
        for name in TrackFilter.__slots__:
            setattr(self, name, getattr(g, name))
