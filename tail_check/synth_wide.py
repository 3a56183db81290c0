"""Generator A with domain randomisation: the scenes the verifier is trained on.

:func:`tail_check.synth.render_snapshot` draws the project's reference scenes (the
hand-tuned detector's own set, the ε(c_Δ) study) and stays as it is. This module draws
the same kind of last-car scene with every quantity the issue names as a failure
widened (:class:`~tail_check._wide_draw.WideRanges`): body and disc paints across the
reds, faded pink discs, discs turned edge-on, far cameras (small discs), darker dusk,
white balance and exposure errors, poles and snow on the disc, red lettering with
closed bowls and red/white barriers (round red logos with white letters on request:
``WideRanges.roundel_share``) among the hard negatives, and lit reflectors from
deep red to white glare. A verifier trained on these scenes should not depend on one
paint, one size or one light.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from ._distractors import DISTRACTORS, draw_distractor
from ._scene import background, draw_car
from ._wide_draw import (
    WIDE,
    WideRanges,
    add_glow,
    car_paint,
    draw_barrier,
    draw_disc_wide,
    draw_lettering,
    draw_roundel,
    red_paint,
    snow_clump,
)
from ._wide_lamps import LAMP_KINDS, Emitter, draw_lamp, emit
from .synth import _CONDITION_WEIGHTS, _SKY, CONDITIONS, SnapshotLabel, _camera, _label, _light
from .synth import _occlude as _pole

__all__ = ["WIDE_DISTRACTORS", "random_wide_snapshot"]

WIDE_DISTRACTORS = (*DISTRACTORS, "red_lettering", "red_barrier", *LAMP_KINDS)
_DISTRACTOR_COUNTS = ((0, 1, 2), (0.35, 0.45, 0.2))


def _distract(
    rng: np.random.Generator, img: NDArray[np.float32], geo: object, kind: str
) -> list[Emitter]:
    """Draw one hard negative; the lit lenses whose light is added after the lighting."""
    from ._scene import CarGeometry

    assert isinstance(geo, CarGeometry)
    if kind in LAMP_KINDS:
        return draw_lamp(rng, img, geo, kind)
    if kind == "red_lettering":
        draw_lettering(rng, img, geo)
    elif kind == "red_roundel":
        draw_roundel(rng, img, geo)
    elif kind == "red_barrier":
        draw_barrier(rng, img, geo)
    else:
        draw_distractor(rng, img, geo, kind, red_paint(rng))
    return []


def _expose(rng: np.random.Generator, img: NDArray[np.float32], c: WideRanges) -> None:
    """White balance and exposure errors of the camera (in place)."""
    gains = rng.uniform(*c.white_balance, 3) * rng.uniform(*c.exposure)
    img *= gains.astype(np.float32)[None, None, :]


def random_wide_snapshot(
    seed_or_rng: int | np.random.Generator,
    *,
    size: tuple[int, int] = (640, 480),
    disc_share: float = 0.5,
    c: WideRanges = WIDE,
) -> tuple[NDArray[np.uint8], SnapshotLabel]:
    """A domain-randomised snapshot and its label (as :func:`synth.random_snapshot`)."""
    rng = (
        seed_or_rng
        if isinstance(seed_or_rng, np.random.Generator)
        else np.random.default_rng(seed_or_rng)
    )
    w, h = int(size[0]), int(size[1])
    condition = str(rng.choice(CONDITIONS, p=_CONDITION_WEIGHTS))
    disc = bool(rng.random() < disc_share)
    family, paint = car_paint(rng, c)
    counts, weights = _DISTRACTOR_COUNTS
    n = int(rng.choice(counts, p=weights))
    kinds = tuple(str(k) for k in rng.choice(WIDE_DISTRACTORS, n, replace=False))
    if rng.random() < c.lamp_share:
        lamp = str(rng.choice(LAMP_KINDS))
        kinds = kinds if lamp in kinds else (*kinds, lamp)
    img = background(rng, h, w, _SKY[condition])
    geo = draw_car(rng, img, paint, width=c.car_width)
    # Checked before drawing so that with no roundels (the default) the random stream,
    # and so every scene the shipped verifiers were trained on, stays the same.
    if c.roundel_share > 0 and rng.random() < c.roundel_share:
        kinds = (*kinds, "red_roundel")
    lit = [e for kind in kinds for e in _distract(rng, img, geo, kind)]
    mask = np.zeros((h, w), bool)
    drawn = draw_disc_wide(rng, img, geo, c) if disc else None
    if drawn is not None:
        mask = drawn.mask
    img = _light(rng, img, condition, [])
    if condition == "dusk":
        img *= np.float32(rng.uniform(*c.dusk_gain))
    if condition == "night" and drawn is not None:
        img = add_glow(rng, img, drawn, c)
    img = emit(img, lit)
    visible = mask
    if drawn is not None and condition == "snow" and rng.random() < c.clump_share:
        visible = visible & ~snow_clump(rng, img, drawn, c)
    if rng.random() < c.pole_share:
        share = rng.uniform(*c.pole_cover) if drawn is not None else 0.0
        centre = drawn.centre if drawn is not None else None
        visible = visible & ~_pole(rng, img, centre, drawn.radius if drawn else 0.0, share)
    _expose(rng, img, c)
    quality = int(rng.integers(c.jpeg[0], c.jpeg[1] + 1))
    image = _camera(rng, img, condition, quality)
    centre = drawn.centre if drawn is not None else None
    radius = drawn.radius if drawn is not None else 0.0
    label = _label(visible, mask, centre, radius, condition, f"wide_{family}", kinds, False)
    if drawn is not None and not visible.any():
        # Hidden entirely (a pole over a small disc): the disc is there, nothing shows.
        return random_wide_snapshot(rng, size=size, disc_share=disc_share, c=c)
    return image, label
