"""Labelled scenes for training and evaluating the tail check, from three generators.

Generator A is :mod:`tail_check.synth`, generator B :mod:`tail_check.scenes_b`
(written independently), generator C :mod:`tail_check.scenes_c` (written later by a
third author who read neither; evaluation only: no verifier is trained, no threshold
chosen, no stage tuned on it). Seeds are split into named ranges so that training,
validation and held-out evaluation never share a scene. Generator A's ``train`` and
``validation`` scenes come from its domain-randomised mode (:mod:`tail_check.synth_wide`:
every paint, size, turn and light widened, lamps and lettering among the hard
negatives), its ``heldout`` scenes from the reference generator the hand-tuned
detector is measured on (``heldout_wide``: the randomised mode's held-out seeds), so
a verifier trained on A is judged on scenes it was not drawn from either. Rendered scenes can be
cached as lossless PNG (the image already went through the generator's JPEG
round trip, so the cache is exact) because generator B takes seconds per scene.

Real photos (``railsem19_frames``, ``red_wagons``) are read from a folder outside
the repository (``DEPOT_REAL_DATA_DIR``, default ``/work/shared/data/real``); none of
them shows a tail disc.
"""

from __future__ import annotations

import json
import os
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Literal

import cv2
import numpy as np
from numpy.typing import NDArray

from . import synth
from .scenes_b import render_scene
from .scenes_c import render_scene as render_scene_c
from .synth_wide import random_wide_snapshot

__all__ = [
    "GENERATORS",
    "SPLITS",
    "Sample",
    "real_dir",
    "real_photos",
    "scenes",
]

Generator = Literal["A", "B", "C"]
GENERATORS: tuple[Generator, ...] = ("A", "B", "C")
TRAINABLE: tuple[Generator, ...] = ("A", "B")
"""Generators a verifier may be trained or calibrated on; C is kept for evaluation."""
SPLITS: dict[str, int] = {
    "train": 100_000,
    "validation": 200_000,
    "heldout": 300_000,
    "heldout_wide": 300_000,
}
"""First seed of each split; scene ``i`` of a split uses seed ``first + i``."""
WIDE_SPLITS = frozenset({"train", "validation", "heldout_wide"})
"""Splits whose generator-A scenes come from the domain-randomised mode."""
CACHE_TAGS: dict[tuple[str, bool], str] = {
    ("A", False): "A",
    ("A", True): "Aw3",
    ("B", False): "B",
    ("C", False): "C1",
}
"""Cache file prefix per (generator, randomised); a new tag whenever a generator's scenes
change, so a cache written by an older version is never read as the new one."""
SIZES_A: tuple[tuple[int, int], ...] = ((640, 480), (800, 600), (1024, 768), (1280, 720))
"""Sizes drawn for generator A (it renders one size per call)."""
SIZE_B = (640, 480)
"""Generator B renders at this size here (it takes about 1 s per scene at 640x480 on one
core, 4-15 s at its own 800x600..1920x1080; the detector works at a fixed scale)."""
REAL_DIR_DEFAULT = "/work/shared/data/real"
REAL_SETS = ("railsem19_frames", "red_wagons")


@dataclass(frozen=True)
class Sample:
    """One labelled image.

    Attributes
    ----------
    image : ndarray, shape (H, W, 3), uint8, BGR
    disc : bool
        A tail disc is on the car.
    condition : str
        Light / weather condition (each generator's own names; ``real`` for photos).
    kind : str
        ``disc`` for scenes with a disc, else the hard-negative kind (``none`` for a
        plain scene, ``photo`` for a real photo).
    source : str
        ``A``, ``B`` or ``real``.
    name : str
        Seed or file name, to find the scene again.
    bbox : (x, y, w, h) or None
        The disc's box in pixels (None without a disc).
    """

    image: NDArray[np.uint8]
    disc: bool
    condition: str
    kind: str
    source: str
    name: str
    bbox: tuple[int, int, int, int] | None = None


def _scene_a(seed: int, wide: bool = False) -> Sample:
    rng = np.random.default_rng(seed)
    size = SIZES_A[int(rng.integers(len(SIZES_A)))]
    draw = random_wide_snapshot if wide else synth.random_snapshot
    image, label = draw(rng, size=size)
    kind = "disc" if label.disc else (label.distractors[0] if label.distractors else "none")
    return Sample(image, label.disc, label.condition, kind, "A", str(seed), label.bbox)


def _scene_b(seed: int) -> Sample:
    scene = render_scene(seed, size=SIZE_B)
    kind = "disc" if scene.disc else str(scene.negative_kind)
    return Sample(scene.image, scene.disc, scene.condition, kind, "B", str(seed), scene.bbox)


def _scene_c(seed: int) -> Sample:
    # Generator C's own sizes (640x480 to 1920x1080): it renders fast enough.
    scene = render_scene_c(seed)
    kind = "disc" if scene.disc else str(scene.negative_kind)
    return Sample(scene.image, scene.disc, scene.condition, kind, "C", str(seed), scene.bbox)


_RENDER_PLAIN = {"B": _scene_b, "C": _scene_c}


def _cache_dir() -> Path | None:
    text = os.environ.get("DEPOT_TAIL_CACHE", "")
    return Path(text) if text else None


def _cached(generator: Generator, seed: int, wide: bool = False) -> Sample:
    wide = wide and generator == "A"

    def render(seed: int) -> Sample:
        return _scene_a(seed, wide) if generator == "A" else _RENDER_PLAIN[generator](seed)

    cache = _cache_dir()
    if cache is None:
        return render(seed)
    tag = CACHE_TAGS[(generator, wide)]
    png, meta = cache / f"{tag}_{seed}.png", cache / f"{tag}_{seed}.json"
    if png.is_file() and meta.is_file():
        image = cv2.imread(str(png), cv2.IMREAD_COLOR)
        info = json.loads(meta.read_text(encoding="utf-8"))
        if image is not None:
            box = info.get("bbox")
            return Sample(
                np.asarray(image, np.uint8),
                bool(info["disc"]),
                str(info["condition"]),
                str(info["kind"]),
                generator,
                str(seed),
                None if box is None else (int(box[0]), int(box[1]), int(box[2]), int(box[3])),
            )
    sample = render(seed)
    cache.mkdir(parents=True, exist_ok=True)
    cv2.imwrite(str(png), sample.image)
    fields = {
        "disc": sample.disc,
        "condition": sample.condition,
        "kind": sample.kind,
        "bbox": None if sample.bbox is None else list(sample.bbox),
    }
    meta.write_text(json.dumps(fields), encoding="utf-8")
    return sample


def scenes(generator: Generator, split: str, count: int, *, offset: int = 0) -> Iterator[Sample]:
    """``count`` scenes of one generator's split (deterministic).

    Raises
    ------
    ValueError
        Unknown generator or split, or a negative count.
    """
    if generator not in GENERATORS:
        raise ValueError(f"unknown generator {generator!r}; use one of {GENERATORS}")
    if split not in SPLITS:
        raise ValueError(f"unknown split {split!r}; use one of {sorted(SPLITS)}")
    if count < 0 or offset < 0:
        raise ValueError(f"count and offset must be non-negative, got {count}, {offset}")
    first = SPLITS[split] + offset
    for seed in range(first, first + count):
        yield _cached(generator, seed, split in WIDE_SPLITS)


def real_dir() -> Path:
    """Folder of the real photos (may not exist on this machine)."""
    return Path(os.environ.get("DEPOT_REAL_DATA_DIR", REAL_DIR_DEFAULT))


RealPart = Literal["all", "train", "report"]


def real_photos(part: RealPart = "all") -> Iterator[Sample]:
    """Real photos under :func:`real_dir` (none shows a disc); nothing if absent.

    ``part`` splits each folder by the position of the file in name order: ``train`` is
    the 1st, 3rd, 5th ... photo (a verifier may learn from them as negatives), ``report``
    the 2nd, 4th ... (never trained or tuned on; the benchmark and tests report them).
    """
    if part not in ("all", "train", "report"):
        raise ValueError(f"unknown real-photo part {part!r}; use all, train or report")
    root = real_dir()
    for name in REAL_SETS:
        folder = root / name
        if not folder.is_dir():
            continue
        paths = sorted(folder.glob("*.jpg"))
        if part != "all":
            paths = paths[0 if part == "train" else 1 :: 2]
        for path in paths:
            image = cv2.imread(str(path), cv2.IMREAD_COLOR)
            if image is None:
                raise ValueError(f"cannot decode real photo {path}")
            yield Sample(np.asarray(image, np.uint8), False, "real", name, "real", path.name)
