"""Generator C: synthetic photos of the rear end of a freight train's last car.

Each scene shows the end wall of the last car (box car, gondola, hopper, tank car or
container flat) beside converging rails, with or without the red tail disc, under one
of several light/weather conditions, and with hard red negatives when the disc is absent.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from ._render import CONDITIONS, NEGATIVE_KINDS, bbox_of, compose, pick_size

__all__ = ["CONDITIONS", "NEGATIVE_KINDS", "SceneC", "render_scene"]


@dataclass(frozen=True)
class SceneC:
    image: npt.NDArray[np.uint8]
    disc: bool
    bbox: tuple[int, int, int, int] | None
    condition: str
    negative_kind: str | None


def render_scene(
    seed: int,
    *,
    disc: bool | None = None,
    condition: str | None = None,
    size: tuple[int, int] | None = None,
) -> SceneC:
    """Render one deterministic scene; ``size`` is (width, height)."""
    rng = np.random.default_rng(seed)
    has_disc = bool(rng.random() < 0.5) if disc is None else bool(disc)
    if condition is None:
        cond = CONDITIONS[int(rng.integers(len(CONDITIONS)))]
    elif condition in CONDITIONS:
        cond = condition
    else:
        raise ValueError(f"unknown condition {condition!r}")
    wh = pick_size(rng) if size is None else (int(size[0]), int(size[1]))
    neg = None if has_disc else NEGATIVE_KINDS[int(rng.integers(len(NEGATIVE_KINDS)))]
    image, outline = compose(rng, has_disc, cond, wh, neg)
    bbox = bbox_of(outline, wh[0], wh[1]) if outline is not None else None
    return SceneC(image=image, disc=has_disc, bbox=bbox, condition=cond, negative_kind=neg)
