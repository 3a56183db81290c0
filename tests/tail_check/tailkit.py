"""Shared helpers of the tail-check tests: the CLI in-process, the hand-tuned presents."""

from __future__ import annotations

import argparse
from collections.abc import Iterable, Iterator

import numpy as np
from numpy.typing import NDArray

from service.commands.tail_check import register
from tail_check import detect
from tail_check.dataset import Sample
from tail_check.detect import DetectionResult
from tail_check.synth import SnapshotLabel, render_snapshot


def run_tail_command(argv: list[str]) -> int:
    """A tail-check command of ``depot`` run in this process; its exit code."""
    parser = argparse.ArgumentParser()
    sub = parser.add_subparsers(dest="command")
    register(sub)
    args = parser.parse_args(argv)
    return int(args.func(args))


def hand_presents_on_discs(samples: Iterable[Sample]) -> Iterator[tuple[Sample, DetectionResult]]:
    """The scenes with a disc that the hand-tuned detector calls ``present``, with its result."""
    for sample in samples:
        if not sample.disc:
            continue
        hand = detect(sample.image)
        if hand.verdict == "present":
            yield sample, hand


def plain_disc_scene() -> tuple[NDArray[np.uint8], SnapshotLabel]:
    """Generator A's seed 8: a disc on a blue car by day, nothing else red (disc at 413,361)."""
    image, label = render_snapshot(
        8,
        disc=True,
        condition="day",
        car_colour="blue",
        distractors=(),
        occlusion=0.0,
        jpeg_quality=90,
    )
    assert label.reference_point == (413, 361)
    return image, label


def assert_service_holds(image: NDArray[np.uint8], phrase: str) -> None:
    """The hand-tuned detector calls ``image`` ``present`` (the error a hold exists for) and
    the service holds it ``uncertain``, its reason first (containing ``phrase``), the
    detector's reasons and box kept, the image unmodified."""
    from tail_check import confirm

    before = image.copy()
    hand = detect(image)
    assert hand.verdict == "present"
    checked = confirm(image, hand)
    assert checked.verdict == "uncertain"
    assert phrase in checked.reasons[0]
    assert checked.reasons[1:] == hand.reasons and checked.bbox == hand.bbox
    np.testing.assert_array_equal(image, before)
