"""Whether :class:`motion.fusion.TrackFilter` knows which way the train runs.

GNSS gives the speed over ground, a magnitude.  The filter's state is a signed
speed, so a GNSS speed is applied with the sign of the estimate; when the
estimate did not know that sign (a filter started with the speed unknown, or
started again), the sign after the update is an *assumption*, not evidence.
Taking it as forward reported a train shunting backwards from its first GNSS
speed as running forwards, its position integrated the wrong way (found by
the independent trial).

So the sign is tracked: while it is assumed the filter claims no direction
(``direction`` 0, the speed a magnitude) and its position is known only to
``anchor ± distance run since``.  Evidence settles it:

* a GNSS speed at standstill (the sign does not matter there; moving off, the
  accelerometer gives it);
* a GNSS speed whose prior excludes the other sign (a known start, or the
  accelerometer carried a known speed);
* two position fixes (marker reads, projected GNSS fixes) apart along the
  track by more than their uncertainty: their order is the direction.  When it
  contradicts the assumed sign, the state is flipped at the second fix
  (:attr:`~motion.model.MeasurementKind.DIRECTION_FLIP`).
"""

from __future__ import annotations

from typing import Any

from .model import Estimate
from .samples import FilterConfig

__all__ = ["DirectionWatch"]

# The other sign counts as excluded when its likelihood is below e^(-2k²) of the
# assumed one's (k = FilterConfig.direction_sigmas; k = 2: below 3.4e-4).
_EXCLUSION_FACTOR = 2.0


class DirectionWatch:
    """The sign bookkeeping of one filter (see the module documentation).

    ``assumed`` is True while the sign of the speed rests on an assumption;
    ``anchor`` is ``(coordinate, variance)`` of the position when the sign was
    assumed, or of the first fix since (``None`` when the position was unknown).
    ``last_fix`` is the newest fix while no speed of known sign has moved the
    train since: the anchor when the position is unknown at the assumption (a
    marker read at the start, then the first GNSS speed).
    """

    __slots__ = ("cfg", "assumed", "anchor", "last_fix")

    def __init__(self, cfg: FilterConfig) -> None:
        self.cfg = cfg
        self.assumed = False
        self.anchor: tuple[float, float] | None = None
        self.last_fix: tuple[float, float] | None = None

    def standstill(self, z: float) -> bool:
        """Whether a GNSS speed ``z`` says the train is standing (no sign to know)."""
        c = self.cfg
        return z <= max(c.standstill_mps, c.direction_sigmas * c.gnss_speed_sigma)

    def gnss_speed(self, prior: Estimate, z: float, r: float) -> None:
        """A GNSS speed ``z`` (variance ``r``) applied at ``prior``: does the
        estimate after it know its sign?"""
        if self.standstill(z):
            self.assumed, self.anchor, self.last_fix = False, None, None
            return
        if self.assumed:
            return  # the prior's sign is itself the assumption
        s, u, _, p00, _, _, p11, _, _ = prior
        k = self.cfg.direction_sigmas
        # log-likelihood ratio of the assumed sign over the other: 2·z·|u|/σ²
        if 2.0 * z * abs(u) >= _EXCLUSION_FACTOR * k * k * (p11 + r):
            self.last_fix = None  # a speed of known sign moves the train from it
            return
        self.assumed = True
        known = p00 <= self.cfg.lost_position_sigma**2
        self.anchor = (s, p00) if known else self.last_fix

    def position_fix(self, prior: Estimate, z: float, r: float) -> float | None:
        """A position fix ``z`` (variance ``r``) at ``prior``.  Returns the
        coordinate to mirror the state about when the fix shows the assumed sign
        wrong (a :attr:`~motion.model.MeasurementKind.DIRECTION_FLIP` goes
        before the fix), else ``None``; settles the sign when it can."""
        if not self.assumed:
            _, _, _, _, _, _, p11, _, _ = prior
            if p11 > self.cfg.lost_speed_sigma**2:  # the speed, so its sign, not known yet
                self.last_fix = (z, r)
            return None
        if self.anchor is None:
            self.anchor = (z, r)
            return None
        s_a, var_a = self.anchor
        delta = z - s_a
        k = self.cfg.direction_sigmas
        if delta * delta <= k * k * (var_a + r):
            return None  # too close to the first fix to tell the order
        _, u, *_ = prior
        self.assumed, self.anchor = False, None
        return s_a if (delta > 0.0) != (u >= 0.0) else None

    def lost(self) -> None:
        """The speed starts again from a GNSS magnitude, the position unknown."""
        self.assumed, self.anchor, self.last_fix = True, None, None

    def spread(self, s: float) -> float:
        """The variance the assumed sign adds to the coordinate ``s``: the train
        is at ``s`` or as far on the other side of the anchor."""
        if not self.assumed or self.anchor is None:
            return 0.0
        d = s - self.anchor[0]
        return d * d

    def centre(self, s: float) -> float:
        """The coordinate to report for the estimate ``s`` (the anchor while
        the sign is assumed: half way between the two possibilities)."""
        if not self.assumed or self.anchor is None:
            return s
        return self.anchor[0]

    def reset(self) -> None:
        self.assumed, self.anchor, self.last_fix = False, None, None

    def to_json(self) -> dict[str, Any] | None:
        """``None`` while the sign is known and no fix is pending (the snapshot
        then keeps its older form)."""
        if not self.assumed and self.last_fix is None:
            return None
        return {
            "assumed": self.assumed,
            "anchor": None if self.anchor is None else list(self.anchor),
            "last_fix": None if self.last_fix is None else list(self.last_fix),
        }

    def restore(self, d: dict[str, Any] | None) -> None:
        self.reset()
        if d is None:
            return
        a, f = d.get("anchor"), d.get("last_fix")
        self.assumed = bool(d.get("assumed", True))
        self.anchor = None if a is None else (float(a[0]), float(a[1]))
        self.last_fix = None if f is None else (float(f[0]), float(f[1]))
