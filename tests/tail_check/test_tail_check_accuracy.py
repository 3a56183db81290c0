"""Accuracy on generated snapshots (issue 4 targets), default profile, fixed seeds.

Issue targets, asserted here: >= 97 % correct verdicts, `uncertain` <= 5 %, and no
`present` on an image without a disc. 500 images at 640x480, seed 2026.

Measured (seed 2026): 97.8 % correct (disc images 220 present / 5 uncertain / 4
absent; no-disc 0 present / 2 uncertain / 269 absent), 1.4 % uncertain. The
remaining misses are mostly discs on cars of their own colour. On another seed
(7) the same detector gives 96.4 %, so the margin over 97 % is not large; on
320x240 images (seed 2026) 91.8 %, with no false `present`.
"""

from __future__ import annotations

from collections import Counter

from tail_check import detect
from tail_check.synth import iter_snapshots

COUNT = 500
SEED = 2026


def test_accuracy_targets_on_generated_snapshots() -> None:
    confusion: Counter[tuple[str, str]] = Counter()
    for image, label in iter_snapshots(SEED, COUNT, size=(640, 480)):
        truth = "present" if label.disc else "absent"
        confusion[(truth, detect(image).verdict)] += 1
    correct = confusion[("present", "present")] + confusion[("absent", "absent")]
    uncertain = confusion[("present", "uncertain")] + confusion[("absent", "uncertain")]
    table = {f"{t}->{v}": n for (t, v), n in sorted(confusion.items())}
    print("confusion:", table)
    assert sum(confusion.values()) == COUNT
    assert confusion[("absent", "present")] == 0, table
    assert correct / COUNT >= 0.97, table
    assert uncertain / COUNT <= 0.05, table
