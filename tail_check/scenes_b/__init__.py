"""Generator B: independent trackside scenes of a freight train's last car.

Written without reading the project's own generator (``tail_check.synth``), so
that a detector trained on one can be evaluated on the other. A scene is a
pinhole camera on a lineside mast looking at the rear of the last car: sky,
scenery, ballast, sleepers and rails, catenary, the car's end wall and side
wall (box car, gondola, tank, hopper, flat with or without a container) in
many paints, and, when ``disc`` is true, the red tail disc with its reflector
on a bracket just above the end beam, normally on the right. Hard negatives
(red lettering with closed bowls, stripes, logos, red car bodies, red signal
lamps, electric tail lamps, hand wheels, barriers) are painted in perspective.
Light and weather follow the condition; the camera adds a mild tilt, blur,
vignetting, exposure error, noise and a JPEG round trip at quality 50–95.

Public API::

    render_scene(seed, *, disc=None, condition=None, size=None) -> SceneB
    iter_scenes(n, *, seed) -> Iterator[SceneB]
    CONDITIONS, NEGATIVE_KINDS
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from ._config import CONDITIONS, NEGATIVE_KINDS
from ._layout import choose_layout
from ._render import paint

__all__ = ["CONDITIONS", "NEGATIVE_KINDS", "SceneB", "iter_scenes", "render_scene"]

MIN_SIZE = (64, 48)
"""Smallest accepted (width, height); below it a disc cannot be drawn meaningfully."""


@dataclass(frozen=True)
class SceneB:
    """One rendered scene.

    Attributes
    ----------
    image : H×W×3 uint8 BGR, already through a JPEG encode/decode round trip.
    disc : whether the tail disc is on the car.
    bbox : (x, y, w, h) of the whole disc in pixels (occluded parts included),
        clipped to the image; None without a disc.
    condition : one of CONDITIONS.
    negative_kind : for scenes without a disc, the hard negative that was
        placed (one of NEGATIVE_KINDS; ``"none"`` for a plain scene); None
        for scenes with a disc (which may still carry a distractor).
    """

    image: npt.NDArray[np.uint8]
    disc: bool
    bbox: tuple[int, int, int, int] | None
    condition: str
    negative_kind: str | None


def _bbox(mask: npt.NDArray[np.float32]) -> tuple[int, int, int, int] | None:
    """Box of the pixels at least half covered by the disc (tiny discs: the peak)."""
    peak = float(mask.max()) if mask.size else 0.0
    if peak <= 0.0:
        return None
    ys, xs = np.nonzero(mask >= min(0.5, peak * 0.5))
    if xs.size == 0:
        return None
    x0, y0 = int(xs.min()), int(ys.min())
    return x0, y0, int(xs.max()) - x0 + 1, int(ys.max()) - y0 + 1


def render_scene(
    seed: int,
    *,
    disc: bool | None = None,
    condition: str | None = None,
    size: tuple[int, int] | None = None,
) -> SceneB:
    """Render one scene, deterministic for ``seed``.

    Parameters
    ----------
    seed : any non-negative integer; the same seed and overrides give the same scene.
    disc : force a disc (True) or none (False); None draws it with probability 0.5.
    condition : one of CONDITIONS; None draws it uniformly.
    size : (width, height) in pixels; None draws 4:3 or 16:9 from 800×600 to 1920×1080.

    Raises
    ------
    ValueError : unknown condition, negative seed, or a size below MIN_SIZE.
    """
    if seed < 0:
        raise ValueError(f"seed must be non-negative, got {seed}")
    if condition is not None and condition not in CONDITIONS:
        raise ValueError(f"unknown condition {condition!r}; use one of {', '.join(CONDITIONS)}")
    if size is not None and (size[0] < MIN_SIZE[0] or size[1] < MIN_SIZE[1]):
        raise ValueError(f"size {size} is below the minimum {MIN_SIZE} (width, height)")
    rng = np.random.default_rng(seed)
    layout = choose_layout(rng, disc, condition, size)
    image, mask = paint(layout, rng)
    box = None if mask is None else _bbox(mask)
    if layout.disc and box is None:  # cannot happen with the aim jitter; fail loudly if it does
        raise RuntimeError(f"seed {seed}: the disc fell outside the image")
    return SceneB(image=image, disc=layout.disc, bbox=box, condition=layout.condition,
                  negative_kind=layout.negative_kind)


def iter_scenes(n: int, *, seed: int) -> Iterator[SceneB]:
    """``n`` scenes from consecutive seeds derived from ``seed`` (deterministic)."""
    if n < 0:
        raise ValueError(f"n must be non-negative, got {n}")
    for index in range(n):
        yield render_scene(int(np.random.SeedSequence([seed, index]).generate_state(1)[0]))
