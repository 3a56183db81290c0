"""Which GNSS measurements :class:`motion.fusion.TrackFilter` uses, and when.

* GNSS speed — always (it arrives ``delay`` late and is applied at its own
  time); the Kalman update itself gates outliers (``FilterConfig.gnss_gate``).
* GNSS geographic fix — only where the markers cannot help (seed ``004``:
  "a marker that is not read: in its expected zone, convert the GNSS
  geographic fix to a track coordinate and correct with it"), or to find a
  train whose position is unknown; at most one per ``gnss_fix_interval_s``,
  and only when it lies on the track.
"""

from __future__ import annotations

import math

from .samples import FilterConfig

__all__ = ["GnssPolicy"]


class GnssPolicy:
    """The GNSS acceptance rules of one filter, and the times they remember.

    ``last_fix_t`` is the measurement time of the newest fix used
    (``-inf`` before the first), ``last_gnss_t`` that of the newest GNSS
    speed (``None`` before the first).
    """

    __slots__ = ("cfg", "last_fix_t", "last_gnss_t")

    def __init__(self, cfg: FilterConfig) -> None:
        self.cfg = cfg
        self.last_fix_t = -math.inf
        self.last_gnss_t: float | None = None

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
