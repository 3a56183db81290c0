"""Confusion matrices of a tail-disc detector on labelled samples.

Truth is ``present`` (a disc is on the car) or ``absent``; the detector answers
``present`` / ``uncertain`` / ``absent``. A verdict is *correct* when it equals the
truth; ``uncertain`` is never correct but never dangerous; a ``present`` on a scene
without a disc is the dangerous error (a false ``present`` can clear a section with
cars still in it).
"""

from __future__ import annotations

from collections import Counter, defaultdict
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field

from .dataset import Sample

__all__ = ["Confusion", "Tally", "tally"]

VERDICTS = ("present", "uncertain", "absent")


@dataclass
class Confusion:
    """Counts of (truth, verdict) pairs."""

    counts: Counter[tuple[str, str]] = field(default_factory=Counter)

    def add(self, truth: str, verdict: str) -> None:
        """Count one answer."""
        self.counts[(truth, verdict)] += 1

    @property
    def total(self) -> int:
        """Number of answers."""
        return sum(self.counts.values())

    @property
    def correct(self) -> float:
        """Share of answers equal to the truth (0 when empty)."""
        hits = self.counts[("present", "present")] + self.counts[("absent", "absent")]
        return hits / self.total if self.total else 0.0

    @property
    def uncertain(self) -> float:
        """Share of ``uncertain`` answers."""
        n = self.counts[("present", "uncertain")] + self.counts[("absent", "uncertain")]
        return n / self.total if self.total else 0.0

    @property
    def false_present(self) -> int:
        """Number of ``present`` answers on scenes without a disc."""
        return self.counts[("absent", "present")]

    @property
    def missed(self) -> int:
        """Number of ``absent`` answers on scenes with a disc."""
        return self.counts[("present", "absent")]

    def by_verdict(self, verdict: str) -> int:
        """Number of answers equal to ``verdict``, whatever the truth."""
        return sum(n for (_, v), n in self.counts.items() if v == verdict)

    def row(self, truth: str) -> str:
        """``p/u/a`` counts for one truth."""
        return "/".join(str(self.counts[(truth, v)]) for v in VERDICTS)

    def summary(self) -> str:
        """One line: correct, uncertain, false present, missed, and both rows."""
        return (
            f"n={self.total:4d} correct {100 * self.correct:5.1f} % "
            f"uncertain {100 * self.uncertain:4.1f} % false-present {self.false_present} "
            f"missed {self.missed}  disc p/u/a {self.row('present'):>9s}  "
            f"no-disc p/u/a {self.row('absent'):>9s}"
        )


@dataclass
class Tally:
    """Overall confusion plus one per condition and one per hard-negative kind."""

    overall: Confusion = field(default_factory=Confusion)
    by_condition: dict[str, Confusion] = field(default_factory=lambda: defaultdict(Confusion))
    by_kind: dict[str, Confusion] = field(default_factory=lambda: defaultdict(Confusion))
    false_present_names: list[str] = field(default_factory=list)

    def add(self, sample: Sample, verdict: str) -> None:
        """Count one sample's answer."""
        truth = "present" if sample.disc else "absent"
        self.overall.add(truth, verdict)
        self.by_condition[sample.condition].add(truth, verdict)
        self.by_kind[sample.kind].add(truth, verdict)
        if verdict == "present" and not sample.disc:
            self.false_present_names.append(f"{sample.source}:{sample.name}")

    def lines(self, title: str) -> list[str]:
        """Printable report."""
        out = [f"== {title}", f"  all            {self.overall.summary()}"]
        out += [f"  cond {k:9s} {c.summary()}" for k, c in sorted(self.by_condition.items())]
        out += [f"  kind {k:14s} {c.summary()}" for k, c in sorted(self.by_kind.items())]
        if self.false_present_names:
            out.append(f"  false present on: {', '.join(self.false_present_names)}")
        return out


def tally(samples: Iterable[Sample], verdict_of: Callable[[Sample], str]) -> Tally:
    """Run ``verdict_of`` on every sample and count the answers."""
    result = Tally()
    for sample in samples:
        result.add(sample, verdict_of(sample))
    return result
