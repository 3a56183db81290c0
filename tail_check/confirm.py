"""A hand-tuned ``present`` must be confirmed by the learned verifier.

The hand-tuned detector (:func:`tail_check.detect`) reaches 96-97 % on the generator it
was tuned on, but on scenes made otherwise it calls some lamps and lights discs: on the
tuning seeds 330000-330199 of generator A's randomised mode, 3 of 108 scenes without a
disc (an unlit tail lamp of disc size, a lit tail lamp on a red car at night, a road
vehicle's tail lights) and on generator B's 330000-330149 1 of 78 (a signal light).
Every one is the dangerous error: a false ``present`` can free a section with cars still
in it.

The learned verifier (:mod:`tail_check.pipeline`) was not better alone, but as a second
opinion on the one region the hand-tuned detector called a disc it removes 3 of those 4
(the fourth, the unlit tail lamp, is a red disc with a dark rim to any eye). The cost:
some true discs are held ``uncertain`` (a person looks). So a ``present`` stays
``present`` only when a candidate on that region reaches the abstention threshold (chosen
on validation scenes by ``depot tail-train``) of *every* shipped verifier: the one trained
on both independently written generators and the two trained on one each, so a false
``present`` must fool models learnt from different drawings of the world. Any one alone
lets a lamp through: ``AB`` a lit lamp on a red car (generator A's randomised seed 320037,
0.79 above its 0.65; A's verifier gave it 0.21), A's and B's a road vehicle's tail lights
decoded at half size (seed 330168, 0.77 and 0.78 above 0.57 and 0.50; ``AB`` 0.42). On
the tuning seeds 310000-330149 of A, A's randomised mode and B (313 hand-tuned
``present``, 5 of them false), all three together hold the 5 ``uncertain`` and keep 233
of 271 true discs of A and 19 of 37 of B; ``AB`` alone kept 241 and 24 with one false.
The verifiers never turn anything into ``present``, and run only on ``present``
verdicts, so the other verdicts cost nothing more.

Before the verifiers, a ``present`` whose region has letter-like neighbours of its own
paint on its line is held ``uncertain`` (:mod:`tail_check.lettering`): the verifiers
describe a region and its rings only, and on generator A's randomised validation seeds
201000-201599 (never used before) all three believed a red Ø ending a word. So is a
region with lettering inside, a roundel (:mod:`tail_check.emblem`): all three believed
generator C's "RD" roundel; and a lens in a lamp's housing
(:mod:`tail_check.housing`), and one of a pair of lamps (:mod:`tail_check.pair`).
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from dataclasses import dataclass, replace

import numpy as np
from numpy.typing import NDArray

from .detect import DetectionResult, detect
from .emblem import EMBLEM, EmblemParams, emblem_reason
from .housing import HOUSING, HousingParams, housing_reason
from .lettering import LETTERING, LetteringParams, lettering_reason
from .pair import PAIR, PairParams, pair_reason
from .pipeline import PIPELINE_PROFILE, Candidate, TreeModel, load_model
from .pipeline.candidates import iter_candidates
from .pipeline.proposals import make_maps
from .profile import CameraProfile

__all__ = [
    "CONFIRM_PARAMS",
    "ConfirmParams",
    "confirm",
    "confirm_with",
    "detect_confirmed",
    "hold_lookalikes",
]


@dataclass(frozen=True)
class ConfirmParams:
    """How a hand-tuned ``present`` is confirmed.

    Attributes
    ----------
    models : shipped verifiers (by training set: ``AB``, ``A``, ``B``; each also learnt
        the real photos' training part as negatives) or paths to model files, that must
        all believe one candidate.
    near : a verifier candidate speaks for the hand-tuned region when its centre lies in
        the region's box grown by this fraction of the box's width and height on each side.
    lettering : what counts as a row of letters beside the region (the ``present`` is
        then held ``uncertain`` before any verifier runs).
    emblem : what counts as lettering inside the region (a roundel's; held likewise).
    housing : what counts as a lamp's housing around the region (held likewise).
    pair : what counts as the region's twin light at its height (a pair of lamps; held
        likewise).
    enabled : False returns every result unchanged (for the comparison in
        ``bench.tail_accuracy``, never in the service).
    """

    models: tuple[str, ...] = ("AB", "A", "B")
    near: float = 0.5
    lettering: LetteringParams = LETTERING
    emblem: EmblemParams = EMBLEM
    housing: HousingParams = HOUSING
    pair: PairParams = PAIR
    enabled: bool = True


CONFIRM_PARAMS = ConfirmParams()


def _checked(result: DetectionResult, params: ConfirmParams) -> bool:
    """Whether ``result`` is a ``present`` the verifier must confirm."""
    return params.enabled and result.verdict == "present" and result.bbox is not None


def _grown(result: DetectionResult, scale: float, grow: float) -> tuple[float, ...]:
    """``result``'s box in pixels ``scale`` times its own, grown by ``grow`` of its width and
    height on each side, as (x0, y0, x1, y1)."""
    assert result.bbox is not None
    x, y, w, h = (v * scale for v in result.bbox)
    gx, gy = w * grow, h * grow
    return x - gx, y - gy, x + w + gx, y + h + gy


def detect_confirmed(
    image_bgr: NDArray[np.uint8],
    profile: CameraProfile | None = None,
    params: ConfirmParams = CONFIRM_PARAMS,
) -> DetectionResult:
    """The service's verdict of one image: :func:`~.detect.detect`, then :func:`confirm`."""
    return confirm(image_bgr, detect(image_bgr, profile), params)


def confirm(
    image_bgr: NDArray[np.uint8],
    result: DetectionResult,
    params: ConfirmParams = CONFIRM_PARAMS,
) -> DetectionResult:
    """``result`` unchanged, or its ``present`` held ``uncertain`` when the verifier doubts it.

    Parameters
    ----------
    image_bgr : ndarray, shape (H, W, 3), uint8, BGR
        The image ``result`` was detected on, at any scale: ``result``'s box is in pixels
        of ``result.image_size`` and is scaled to this image.
    result : the hand-tuned detector's answer.
    params : the verifier and the neighbourhood searched.

    Returns
    -------
    DetectionResult
        ``result`` itself unless it is a ``present`` the verifier does not confirm; then
        the same with verdict ``uncertain`` and the verifier's reason first.
    """
    if not _checked(result, params):
        return result
    held = hold_lookalikes(image_bgr, result, params)
    if held is not result:
        return held
    scale = image_bgr.shape[1] / max(1, result.image_size[0])
    maps = make_maps(image_bgr, PIPELINE_PROFILE)
    # The whole frame's candidates, as the verifiers were trained and their thresholds
    # chosen on (the strongest ``max_candidates``, merged): describing only the proposals
    # near the region let weak ones through that the whole frame leaves out, and one of
    # them fooled every verifier (generator C's fresh seed 380229, a lit signal). Lazily:
    # the first near candidate every verifier believes ends the search, with the verdict
    # all of them would give (a present stays present; only a doubt needs them all).
    candidates = iter_candidates(maps)
    models = [load_model(name) for name in params.models]
    return confirm_with(candidates, scale, result, models, params)


def hold_lookalikes(
    image_bgr: NDArray[np.uint8],
    result: DetectionResult,
    params: ConfirmParams = CONFIRM_PARAMS,
) -> DetectionResult:
    """``result`` unchanged, or its ``present`` held ``uncertain`` when the region stands in
    a row of letters of its paint (:func:`~.lettering.lettering_reason`) or carries
    lettering inside, as a roundel does (:func:`~.emblem.emblem_reason`), or sits in a
    lamp's housing (:func:`~.housing.housing_reason`), or has a twin light at its height
    (:func:`~.pair.pair_reason`); ``image_bgr`` at any scale, as in :func:`confirm`."""
    if not _checked(result, params):
        return result
    x0, y0, x1, y1 = _grown(result, image_bgr.shape[1] / max(1, result.image_size[0]), 0.0)
    box = (int(round(x0)), int(round(y0)), int(round(x1 - x0)), int(round(y1 - y0)))
    reason = (
        lettering_reason(image_bgr, box, params=params.lettering)
        or emblem_reason(image_bgr, box, params=params.emblem)
        or housing_reason(image_bgr, box, params=params.housing)
        or pair_reason(image_bgr, box, params=params.pair)
    )
    if reason is None:
        return result
    return replace(result, verdict="uncertain", reasons=(reason, *result.reasons))


def _trained_on(model: TreeModel) -> str:
    """The generators a verifier was trained on, as its shipped name (``AB``, ``A``...)."""
    return "".join(str(g) for g in model.meta.get("trained_on", ())) or "model"


def confirm_with(
    candidates: Iterable[Candidate],
    scale: float,
    result: DetectionResult,
    models: Sequence[TreeModel],
    params: ConfirmParams = CONFIRM_PARAMS,
) -> DetectionResult:
    """:func:`confirm` given the verifier's candidates of the image (their boxes in pixels
    ``scale`` times ``result``'s), so one set of candidates can be judged by other models.

    ``candidates`` is consumed only until a candidate near the region reaches every
    model's abstention threshold: the verdict is then ``result`` whatever the rest would
    say. Otherwise the reason names the candidate that came closest (highest of its
    probabilities over their thresholds, taken at the least convinced model).
    """
    if not _checked(result, params):
        return result
    if not models:
        raise ValueError("confirming needs at least one verifier model")
    x0, y0, x1, y1 = _grown(result, scale, params.near)
    needed = np.array([float(m.meta["uncertain_threshold"]) for m in models])
    closest = np.zeros(len(models))
    for c in candidates:
        cx, cy = c.bbox[0] + c.bbox[2] / 2, c.bbox[1] + c.bbox[3] / 2
        if not (x0 <= cx <= x1 and y0 <= cy <= y1):
            continue
        probs = np.array([float(m.probability(c.features[None, :])[0]) for m in models])
        if bool((probs >= needed).all()):
            return result
        if (probs / needed).min() > (closest / needed).min():
            closest = probs
    said = ", ".join(
        f"{_trained_on(m)} {p:.2f} of {t:.2f}"
        for m, p, t in zip(models, closest, needed, strict=True)
    )
    reason = (
        "disc-shaped, but the learned verifiers doubt it (disc probability by training "
        f"set, of the one needed: {said}); a person must look"
    )
    return replace(result, verdict="uncertain", reasons=(reason, *result.reasons))
