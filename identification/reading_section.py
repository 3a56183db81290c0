"""The wheel-mark reading section as a state machine fed with sensor edges (spec §2).

Sensors (thesis 002, fig. 2.4): the read sensor DS (a flux-gate magnetometer), zone sensors
DZ1 and DZ2 at the two ends, and for each direction j the car-head sensors DOM 1-j … 4-j,
placed so that when the car's head reaches DOM k-j its k-th wheel is over DS. Public entry
point: :class:`identification.wheel_marks.ReadingSection` (re-exported there).
"""

from __future__ import annotations

import re
from collections import deque
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from typing import Any, Literal

import numpy as np

__all__ = ["ReadingSection", "WheelReading"]


@dataclass(frozen=True)
class WheelReading:
    """One car's reading, shaped like the payload of a protocol ``wheel_marks`` event.

    Attributes
    ----------
    direction : int
        1 or 2, the zone the car entered from.
    baseline : list of int
        DS samples (ADC codes) of the balancing mode just before the car, frozen at entry.
    axles : list of list of int
        In passing order, the ADC codes read for each wheel (one per mark zone).
    complete : bool
        Every wheel of the car was read.
    faults : list of str
        Out-of-order strobes, a short baseline, missing wheels.
    ignored_strobes : int
        Repeated DOM hits blocked by the latches (back-and-forth motion, oscillation).
    """

    direction: int
    baseline: list[int]
    axles: list[list[int]]
    complete: bool
    faults: list[str]
    ignored_strobes: int = 0

    def as_event(self) -> dict[str, Any]:
        """The ``direction``, ``baseline`` and ``axles`` fields of a ``wheel_marks`` event."""
        return {
            "direction": self.direction,
            "baseline": list(self.baseline),
            "axles": [list(a) for a in self.axles],
        }


_DOM = re.compile(r"^DOM\s*([0-9]+)\s*-\s*([12])$", re.IGNORECASE)


class ReadingSection:
    """The reading-section state machine of §2 (one reading per car).

    - Waiting: DS samples are kept as the balancing baseline (the last ``baseline_length``).
    - A zone-sensor edge while waiting: a car enters from that end; direction j is latched,
      the baseline (zero level) is frozen and the other direction's DOM sensors are blocked.
    - ``DOM k-j`` strobes one read of DS **once** (a latch: back-and-forth motion never
      re-reads a wheel), and only if ``DOM (k-1)-j`` already has (the order check).
    - A zone-sensor edge while a car is inside: the car leaves (through either end); the
      reading is returned, the latches reset and balancing resumes.

    Parameters
    ----------
    axles : int, keyword-only
        Wheels read per car (N = 4 for a metro car).
    baseline_length : int, keyword-only
        DS samples kept while balancing (at least 5, for the five-point filter).

    Examples
    --------
    >>> rs = ReadingSection()
    >>> for code in (2050, 2049, 2051, 2050, 2048):
    ...     rs.sample(code)
    >>> rs.edge("DZ1")
    >>> for k in range(1, 5):
    ...     rs.edge(f"DOM{k}-1", [2170, 1931])
    >>> rs.edge("DZ2").complete
    True
    """

    def __init__(self, *, axles: int = 4, baseline_length: int = 8) -> None:
        if axles < 1:
            raise ValueError(f"axles must be >= 1, got {axles}")
        if baseline_length < 5:
            raise ValueError(
                f"baseline_length must be >= 5 (five-point filter), got {baseline_length}"
            )
        self.axles = axles
        self._baseline: deque[int] = deque(maxlen=baseline_length)
        self._last_ds: int | None = None
        self._start_waiting()

    def _start_waiting(self) -> None:
        self.direction: int | None = None
        self._frozen: list[int] = []
        self._latched = [False] * self.axles
        self._codes: list[list[int]] = []
        self._faults: list[str] = []
        self._ignored = 0

    @property
    def state(self) -> Literal["waiting", "reading"]:
        """``"waiting"`` (balancing, no car) or ``"reading"`` (a car is in the section)."""
        return "waiting" if self.direction is None else "reading"

    def sample(self, code: int) -> None:
        """One DS sample (ADC code). While waiting it joins the balancing baseline; it is also
        the value a DOM strobe reads when the strobe carries none."""
        self._last_ds = int(code)
        if self.direction is None:
            self._baseline.append(int(code))

    def edge(self, sensor: str, value: int | Sequence[int] | None = None) -> WheelReading | None:
        """Feed one sensor edge.

        Parameters
        ----------
        sensor : str
            ``"DS"`` (with ``value``: one ADC code), ``"DZ1"``, ``"DZ2"`` or ``"DOM k-j"``
            (``"DOM2-1"`` is accepted too).
        value : int or sequence of int, optional
            For a DOM strobe: the ADC code(s) read, one per mark zone; default: the latest
            DS sample.

        Returns
        -------
        WheelReading or None
            The car's reading when this edge is the car leaving the section.

        Raises
        ------
        ValueError
            For an unknown sensor name or a DS edge without one integer value.
        """
        name = sensor.strip().upper()
        if name == "DS":
            if not isinstance(value, int | np.integer):
                raise ValueError(f"a DS edge needs one integer ADC code, got {value!r}")
            self.sample(int(value))
            return None
        if name in ("DZ1", "DZ2"):
            return self._zone(int(name[2]))
        m = _DOM.match(name)
        if m is None:
            raise ValueError(f"unknown sensor {sensor!r} (DS, DZ1, DZ2 or 'DOM k-j')")
        self._strobe(int(m.group(1)), int(m.group(2)), value)
        return None

    def feed(self, edges: Iterable[tuple[Any, ...] | str]) -> list[WheelReading]:
        """Feed many edges (``"DZ1"``, ``("DOM1-1", [2170, 1931])``, ``("DS", 2050)``, …) and
        return the readings of the cars that left."""
        out: list[WheelReading] = []
        for e in edges:
            r = self.edge(e) if isinstance(e, str) else self.edge(*e)
            if r is not None:
                out.append(r)
        return out

    def _zone(self, j: int) -> WheelReading | None:
        if self.direction is not None:
            return self._leave()
        self.direction = j
        self._frozen = list(self._baseline)
        if len(self._frozen) < 5:
            self._faults.append(
                f"only {len(self._frozen)} baseline samples before the car (need 5)"
            )
        return None

    def _strobe(self, k: int, j: int, value: int | Sequence[int] | None) -> None:
        if self.direction is None or j != self.direction:
            return  # no car, or the other direction's sensors: blocked
        if not 1 <= k <= self.axles:
            self._faults.append(f"DOM {k}-{j}: no such sensor for a {self.axles}-axle car")
        elif self._latched[k - 1]:
            self._ignored += 1  # the latch: a wheel is never read twice
        elif k > 1 and not self._latched[k - 2]:
            self._faults.append(f"DOM {k}-{j} before DOM {k - 1}-{j}: out of order, ignored")
        elif value is None and self._last_ds is None:
            self._faults.append(f"DOM {k}-{j}: no DS sample to read")
        else:
            if value is None:
                assert self._last_ds is not None
                codes = [self._last_ds]
            elif isinstance(value, int | np.integer):
                codes = [int(value)]
            else:
                codes = [int(v) for v in value]
            self._latched[k - 1] = True
            self._codes.append(codes)

    def _leave(self) -> WheelReading:
        assert self.direction is not None
        read = sum(self._latched)
        faults = list(self._faults)
        if read < self.axles:
            faults.append(f"only {read} of {self.axles} wheels read")
        reading = WheelReading(
            direction=self.direction,
            baseline=self._frozen,
            axles=self._codes,
            complete=read == self.axles,
            faults=faults,
            ignored_strobes=self._ignored,
        )
        self._start_waiting()
        self._baseline.clear()  # balancing starts afresh after the car
        return reading
