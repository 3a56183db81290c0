"""Wheel marks and infrared must name the same cars (identification.md §5: "when a car is read
by both technologies, both must agree (a disagreement is reported)").

Each technology's consist is compared departure against arrival on its own
(``evidence.compare_families``); this module compares the two technologies at each end. A
position where both identified a car, but not the same one, or ends where they read a
different number of cars, leave it unknown which cars ran: neither consist proves the train
complete, and neither proves a car lost. A car that one reader could not identify (``None``)
is no disagreement: its own consist already leaves that position unknown.
"""

from __future__ import annotations

Families = dict[str, dict[str, list[str | None]]]
SIDES = ("departure", "arrival")


def reader_disagreements(families: Families) -> list[str]:
    """Where the wheel-mark and infrared consists of one end disagree, in words."""
    wheel, infrared = families.get("wheel", {}), families.get("ir", {})
    found: list[str] = []
    for side in SIDES:
        marks, ir = wheel.get(side), infrared.get(side)
        if not marks or not ir:
            continue
        if len(marks) != len(ir):
            found.append(
                f"at the {side} the wheel marks read {len(marks)} cars, the infrared {len(ir)} cars"
            )
            continue
        found.extend(
            f"{side} position {position}: wheel marks read {by_marks}, infrared {by_ir}"
            for position, (by_marks, by_ir) in enumerate(zip(marks, ir, strict=True), 1)
            if by_marks is not None and by_ir is not None and by_marks != by_ir
        )
    return found


def disagreement_reason(found: list[str]) -> str:
    return (
        f"the wheel-mark and infrared readers disagree ({'; '.join(found)}): which cars ran"
        " is not known; a person must look"
    )
