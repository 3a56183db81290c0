"""Writing wheel marks at the marking station (spec §1; thesis 002, chapter 2.2, fig. 2.1–2.3).

A writing unit sits between wheel detectors W1 and W2 and writes register k onto the wheels of
the k-th axle. Content and order must not depend on the direction of motion, and the car may
reverse at any moment, even with an axle inside the section. Public entry point:
:func:`identification.wheel_marks.simulate_marking` (re-exported there).
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass, field
from typing import Literal

__all__ = ["MarkingResult", "simulate_marking"]

MarkingState = Literal["marked", "partial", "lost"]


@dataclass(frozen=True)
class MarkingResult:
    """Outcome of one marking session.

    Attributes
    ----------
    state : {"marked", "partial", "lost"}
        ``marked``: every axle is written. ``lost``: the car backed wholly out after an axle
        had been written, and no axle was written since (its mark is lost; it is treated as
        new if it comes again). ``partial``: anything else (some or no axles written).
    written : list of bool, length ``axles``
        ``written[k]``: axle k+1 carries a complete mark of register k+1 (it wholly passed the
        section, seen by both detectors, with the writer on its register). Cleared when the
        car is lost.
    faults : list of str
        Hit patterns that no physical motion produces, and an unfinished session.
    forward : str or None
        The detector hit first (``"W1"`` or ``"W2"``).
    log : list of str
        One line per hit, saying what the control unit did.
    """

    state: MarkingState
    written: list[bool]
    faults: list[str]
    forward: str | None = None
    log: list[str] = field(default_factory=list)


class _ControlUnit:
    """The marking control unit's state between hits (i, the forward detector, the axle inside)."""

    def __init__(self, axles: int) -> None:
        self.axles = axles
        self.forward: str | None = None
        self.first_forward: str | None = None
        self.i = 0  # number of the last axle that entered forwards and did not back out
        self.inside: Literal["F", "R", "X"] | None = None  # how the axle inside entered
        self.written = [False] * axles
        self.lost = False
        self.faults: list[str] = []
        self.log: list[str] = []

    def hit(self, n: int, name: str) -> None:
        if name not in ("W1", "W2"):
            self.faults.append(f"hit {n}: unknown detector {name!r} ignored")
            return
        if self.forward is None:
            self.forward = name
            self.first_forward = self.first_forward or name
        side = "F" if name == self.forward else "R"
        prefix = f"{n} {name}: "
        if self.inside is None:
            self.log.append(prefix + self._enter(n, name, side))
        elif self.inside == "F":
            self.log.append(prefix + self._leave_forward_entry(side))
        elif self.inside == "R":
            self.log.append(prefix + self._leave_reverse_entry(side))
        else:
            self.inside = None
            self.log.append(prefix + "the extra axle leaves the section")
        if self.i == 0 and self.inside is None:
            self.forward = None  # wholly on the entry side: a new car if it comes again

    def _enter(self, n: int, name: str, side: str) -> str:
        if side == "R":
            # F is reset whenever i == 0 with the section empty, so i >= 1 here: the car
            # reversed and its last written axle comes back; the mark is written again.
            self.inside = "R"
            return f"axle {self.i} comes back, writer on with register {self.i} again"
        if self.i >= self.axles:
            self.faults.append(
                f"hit {n}: {name} after all {self.axles} axles passed: more axles than the car has"
            )
            self.inside = "X"
            return "extra axle enters, writer stays off"
        self.i += 1
        self.inside = "F"
        return f"axle {self.i} enters forwards, writer on with register {self.i}"

    def _leave_forward_entry(self, side: str) -> str:
        self.inside = None
        if side == "R":
            self.written[self.i - 1] = True
            self.lost = False
            done = " — the car is marked" if self.i == self.axles else ""
            return f"axle {self.i} passed through, writer off, axle {self.i} written{done}"
        self.i -= 1
        return f"axle {self.i + 1} backed out before finishing, writer off, not counted"

    def _leave_reverse_entry(self, side: str) -> str:
        self.inside = None
        if side == "R":
            return f"axle {self.i} went forwards out again, writer off (still written)"
        self.i -= 1
        if self.i > 0:
            return f"axle {self.i + 1} passed backwards through, writer off"
        self.lost = any(self.written)
        self.written = [False] * self.axles
        return "axle 1 passed backwards through: the car backed wholly out and lost its mark"

    def result(self) -> MarkingResult:
        faults = list(self.faults)
        if self.inside in ("F", "R"):
            faults.append(f"detections end with axle {self.i} inside the writing section")
        state: MarkingState = "marked" if all(self.written) else "lost" if self.lost else "partial"
        return MarkingResult(state, list(self.written), faults, self.first_forward, self.log)


def simulate_marking(detections: Iterable[str], *, axles: int = 4) -> MarkingResult:
    """Run the writing algorithm of §1 over the wheel-detector hits of one marking session.

    Parameters
    ----------
    detections : iterable of str
        Ordered hits, each ``"W1"`` or ``"W2"`` (the ``detections`` of a
        ``wheel_marks_written`` event). The first hit fixes the forward detector F.
    axles : int, keyword-only
        Axles of the car (N = 4 for a metro car).

    Returns
    -------
    MarkingResult
        Per-axle written flags, final state and faults. Hit patterns that no physical motion
        produces (an axle beyond the car's ``axles``, an unknown detector name) become
        faults; the function does not raise for them.

    Raises
    ------
    ValueError
        If ``axles`` < 1.
    """
    if axles < 1:
        raise ValueError(f"axles must be >= 1, got {axles}")
    unit = _ControlUnit(axles)
    for n, name in enumerate(detections, 1):
        unit.hit(n, name)
    return unit.result()
