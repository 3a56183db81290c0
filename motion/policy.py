"""Which GNSS measurements :class:`motion.fusion.TrackFilter` uses, and when.

* GNSS speed — always (it arrives ``delay`` late and is applied at its own
  time); the Kalman update itself gates outliers (``FilterConfig.gnss_gate``).
  A run of rejected speeds starts the speed again from GNSS (the estimate was
  wrong) — unless the run began with a jump no brake gives: from the GNSS speed
  before it, faster than ``BRAKING_LIMITS.max_deceleration_mps2`` (plus the
  gate's noise allowance).  A lost or frozen fix in a tunnel reads 0 while the
  train runs on (found by the independent trial: the filter followed it to a
  standstill): then the accelerometer's speed stays, and the state says GNSS
  ``disagrees`` until a GNSS speed passes the gate again.
* GNSS geographic fix — only where the markers cannot help (seed ``004``:
  "a marker that is not read: in its expected zone, convert the GNSS
  geographic fix to a track coordinate and correct with it"), or to find a
  train whose position is unknown; at most one per ``gnss_fix_interval_s``,
  and only when it lies on the track.
"""

from __future__ import annotations

import math

from .braking_limits import BRAKING_LIMITS
from .samples import FilterConfig

__all__ = ["GnssPolicy"]


class GnssPolicy:
    """The GNSS acceptance rules of one filter, and the times they remember.

    ``last_fix_t`` is the measurement time of the newest fix used
    (``-inf`` before the first), ``last_gnss_t`` that of the newest GNSS
    speed (``None`` before the first).
    """

    __slots__ = ("cfg", "last_fix_t", "last_gnss_t", "disagrees", "_jump_noise")

    def __init__(self, cfg: FilterConfig) -> None:
        self.cfg = cfg
        self.last_fix_t = -math.inf
        self.last_gnss_t: float | None = None
        # GNSS speeds jumped beyond any brake and are being rejected (see the module).
        self.disagrees = False
        # Two readings' noise within the gate: the part of a jump that is not motion.
        self._jump_noise = cfg.gnss_gate * math.sqrt(2.0) * cfg.gnss_speed_sigma

    def impossible_jump(self, before: tuple[float, float] | None, tau: float, z: float) -> bool:
        """Whether GNSS speed ``z`` at ``tau`` lies beyond what any brake (or drive)
        reaches from the GNSS speed ``before`` (``(time, value)``; ``None``: no
        reading to compare with, nothing shown impossible)."""
        if before is None:
            return False
        tau0, z0 = before
        reach = BRAKING_LIMITS.max_deceleration_mps2 * abs(tau - tau0) + self._jump_noise
        return abs(z - z0) > reach

    def speed_used(self, tau: float) -> None:
        """A GNSS speed measured at ``tau`` was attached to the buffer."""
        if self.last_gnss_t is None or tau > self.last_gnss_t:
            self.last_gnss_t = tau

    def wants_fix(self, tau: float, var_position: float, in_missed_zone: bool) -> bool:
        """Whether a fix measured at ``tau`` is worth applying, given the newest
        position variance (m²) and whether a missed marker's zone is current."""
        cfg = self.cfg
        if tau - self.last_fix_t < cfg.gnss_fix_interval_s:
            return False  # fixes are correlated in time: one per interval
        if self.position_unknown(var_position):
            return True
        # In a missed marker's zone a fix is used only when it can help: GNSS
        # errors are correlated over minutes, so repeated fixes do not average.
        return in_missed_zone and var_position >= cfg.gnss_position_sigma**2

    def position_unknown(self, var_position: float) -> bool:
        return var_position > self.cfg.lost_position_sigma**2

    def fix_on_track(self, offset_m: float) -> bool:
        """Whether a fix ``offset_m`` from the track geometry can be on this line."""
        cfg = self.cfg
        limit = cfg.fix_offset_sigmas * cfg.gnss_position_sigma + cfg.fix_offset_margin_m
        return not offset_m > limit

    def fix_used(self, tau: float) -> None:
        self.last_fix_t = tau
