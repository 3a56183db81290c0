"""On-board restarts seen by :class:`motion.fusion.TrackFilter`.

An on-board unit that reboots starts its clock ``t`` again from (near) zero
in the middle of the stream.  Every sample after that is far older than the
filter's buffer and was refused for good (found by the independent trial).
A single old sample must still be refused: a late batch of old samples must
not wipe a good estimate.  So a restart is taken only when
``FilterConfig.restart_confirm_samples`` samples in a row lie more than
``FilterConfig.restart_jump_s`` behind the newest one and run forward among
themselves (each after the previous, by at most ``max_gap_s``), as a rebooted
clock does; one live sample in between, or one going back, and the run
starts over.  The samples of the run before the last are refused
(:class:`~motion.samples.StaleSampleError`): a restart costs them.

A clock that jumps *forward* by more than ``max_gap_s`` is confirmed the same way
(found by the independent trial: one corrupt time stamp far ahead wiped the
estimate at once, and the live samples after it were then "old"); the samples of
the run before the last are refused with :class:`~motion.samples.ClockJumpError`.
A sample behind the newest by at most ``max_delay_s`` is a late sample and used.
"""

from __future__ import annotations

from typing import Any

from .buffer import TIME_TOLERANCE_S
from .samples import ClockJumpError, FilterConfig, StaleSampleError

__all__ = ["RestartWatch"]


class RestartWatch:
    """The run of far-behind samples of one filter: time of the latest, count."""

    __slots__ = ("cfg", "last_t", "count")

    def __init__(self, cfg: FilterConfig) -> None:
        self.cfg = cfg
        self.last_t = 0.0
        self.count = 0

    def check(self, t: float, oldest_t: float, newest_t: float) -> bool:
        """Whether the sample at ``t`` (the buffer spanning ``oldest_t`` to
        ``newest_t``) confirms a restart or a forward jump; raises
        :class:`StaleSampleError` for a late sample beyond the bound, and
        :class:`ClockJumpError` or :class:`StaleSampleError` for one of a run that
        is not confirmed yet (counting it)."""
        cfg = self.cfg
        if t - newest_t > cfg.max_gap_s:
            return self._run(t, newest_t, "ahead of")
        if t >= oldest_t - TIME_TOLERANCE_S or newest_t - t <= cfg.max_delay_s:
            self.clear()  # inside the buffer, within the late-sample bound, or newer
            return False
        if not self.far_behind(t, newest_t):
            self.clear()
            raise StaleSampleError(
                f"sample at t={t} is {newest_t - t:.6g} s behind the newest (t={newest_t}):"
                f" later than max_delay_s = {cfg.max_delay_s:g} s, the bound within which"
                " late samples are used; it is refused (send samples in time order, or"
                " within that bound)"
            )
        return self._run(t, newest_t, "behind")

    def _run(self, t: float, newest_t: float, where: str) -> bool:
        """Count ``t`` in the run of far-off samples; whether it confirms the run."""
        if self.confirmed(t):
            return True
        more = self.cfg.restart_confirm_samples - self.count
        if where == "behind":
            raise StaleSampleError(
                f"sample at t={t} is far older than the filter's buffer (newest t={newest_t}):"
                f" refused; {more} more in a row would be taken as an on-board restart"
            )
        raise ClockJumpError(
            f"sample at t={t} is {t - newest_t:.6g} s ahead of the newest (t={newest_t}),"
            f" beyond max_gap_s = {self.cfg.max_gap_s:g} s: refused, the estimate kept;"
            f" {more} more in a row, running forward, would be taken as a clock jump"
            " (the train then starts again unknown)"
        )

    def far_behind(self, t: float, newest_t: float) -> bool:
        """Whether ``t`` is a possible restart, not an ordinary late sample."""
        return newest_t - t > self.cfg.restart_jump_s

    def confirmed(self, t: float) -> bool:
        """Count the far-behind sample ``t``; whether the restart is now confirmed."""
        if self.count and self.last_t < t <= self.last_t + self.cfg.max_gap_s:
            self.count += 1
        else:
            self.count = 1
        self.last_t = t
        if self.count < self.cfg.restart_confirm_samples:
            return False
        self.clear()
        return True

    def clear(self) -> None:
        self.last_t, self.count = 0.0, 0

    def to_json(self) -> list[Any] | None:
        """``None`` with no run going (the snapshot then keeps its older form)."""
        return [self.last_t, self.count] if self.count else None

    def restore(self, d: list[Any] | None) -> None:
        if not d:
            self.clear()
            return
        self.last_t, self.count = float(d[0]), int(d[1])
