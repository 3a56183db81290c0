"""The identification rules of the fleet and its readers: one documented place (spec §2–§3).

A wrong car number given confidently is worse than none (a person must look), so every decoder
takes from here how much agreeing evidence a number needs and what a reader can physically
send. Decoders accept a ``rules`` argument for another fleet; the service uses :data:`RULES`.
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Sequence
from dataclasses import dataclass

__all__ = ["RULES", "IdentificationRules", "agreed_number"]


@dataclass(frozen=True)
class IdentificationRules:
    """What a car number needs before it is given.

    Attributes
    ----------
    zones_per_axle : int
        B, the mark zones on each axle of the fleet's cars: in the ``duplicate`` layout the
        wheel code has B bits. A ``wheel_marks`` axle with another number of zones was read
        truncated (or belongs to another fleet) and gives no code: decoding 7 zones of an
        8-bit code as a 7-bit code names another car. Default 8, as in the protocol's example.
    adc_min, adc_max : int
        The wheel-mark reader's ADC range (a 12-bit converter, zero ≈ 2048: 0…4095). A code
        outside it was not produced by the reader (a corrupted or forged payload) and gives no
        car; the reason names the first such value.
    min_agreeing_axles : int
        Readable axles that must agree on each bit of a ``duplicate`` wheel code (on top of
        the spec's majority over the readable axles). The mark is repeated on every axle so
        that one axle is checked by another: one axle alone, whether the only one sent or the
        only readable one of four, never names a car. Default 2.
    min_agreeing_reads : int
        Agreeing IR reads of the passage a car number needs, the same for ``ir_id`` (reads
        decoded on the device) and ``ir_pulses`` (reads paired from raw timings) — on top of
        the strict majority of the reads. Default 2 (repeated reading, thesis §3.3).
    """

    zones_per_axle: int = 8
    adc_min: int = 0
    adc_max: int = 4095
    min_agreeing_axles: int = 2
    min_agreeing_reads: int = 2

    def __post_init__(self) -> None:
        for name in ("zones_per_axle", "min_agreeing_axles", "min_agreeing_reads"):
            if getattr(self, name) < 1:
                raise ValueError(f"{name} must be >= 1, got {getattr(self, name)}")
        if self.adc_min >= self.adc_max:
            raise ValueError(f"adc_min must be below adc_max, got {self.adc_min}, {self.adc_max}")


#: The rules the service applies.
RULES = IdentificationRules()


def agreed_number(
    reads: Sequence[int], *, needed: int | None = None, rules: IdentificationRules = RULES
) -> tuple[int | None, str]:
    """The car number of one passage's repeated reads, with the reason when there is none.

    The strict majority of the reads, read at least ``needed`` times (default
    ``rules.min_agreeing_reads``; a decoder may ask for more, never for fewer).

    Returns
    -------
    (int or None, str)
        The number and ``"ok"``, or None and why (no reads, no strict majority, too few).
    """
    need = max(rules.min_agreeing_reads, needed or 0)
    if not reads:
        return None, "no reads"
    value, count = Counter(reads).most_common(1)[0]
    if 2 * count <= len(reads):
        return None, "no strict majority among the reads"
    if count < need:
        return None, f"only {count} read(s) of {value}; {need} needed"
    return value, "ok"
