"""A letter of red lettering is held ``uncertain``; a disc standing alone is not.

The scenes are generated (cached under ``var/tail_cache``): generator A's randomised
validation seed 201436 (a red Ø ending the word "RRBØ", hand-tuned disc score 1.00, and
every learned verifier above its threshold) was the service's false ``present`` found on
validation seeds 201000-201599, which no one had used before.
"""

from __future__ import annotations

import os
from dataclasses import replace
from pathlib import Path

import cv2
import numpy as np
import pytest
from numpy.typing import NDArray

from tail_check import confirm, detect, detect_snapshot
from tail_check.confirm import hold_lookalikes
from tail_check.dataset import Sample, scenes
from tail_check.lettering import LetteringParams, lettering_reason, row_neighbours
from tests.tail_check.tailkit import hand_presents_on_discs

ROOT = Path(__file__).resolve().parents[2]
BLUE_GREY = (120, 100, 80)  # BGR body paint
SIGNAL_RED = (40, 30, 215)
BBox = tuple[int, int, int, int]


@pytest.fixture(scope="module", autouse=True)
def _cache() -> None:
    os.environ.setdefault("DEPOT_TAIL_CACHE", str(ROOT / "var" / "tail_cache"))


def _scene(generator: str, split: str, offset: int) -> Sample:
    return next(scenes(generator, split, 1, offset=offset))  # type: ignore[arg-type]


def _noisy(image: NDArray[np.uint8], seed: int = 0) -> NDArray[np.uint8]:
    noise = np.random.default_rng(seed).normal(0.0, 4.0, image.shape)
    return np.asarray(np.clip(image + noise, 0, 255), np.uint8)


def _body(paint: tuple[int, int, int] = BLUE_GREY) -> NDArray[np.uint8]:
    """A car's end wall (640x480) with corrugations and a dark buffer beam below."""
    image = np.full((480, 640, 3), paint, np.uint8)
    for x in range(20, 640, 40):
        cv2.line(image, (x, 0), (x, 360), tuple(int(v * 0.6) for v in paint), 2)
    image[360:400] = (25, 25, 25)
    return image


def _word(image: NDArray[np.uint8], text: str, origin: tuple[int, int]) -> None:
    cv2.putText(image, text, origin, cv2.FONT_HERSHEY_DUPLEX, 1.6, SIGNAL_RED, 4, cv2.LINE_AA)


def _letter_box(image: NDArray[np.uint8], near_x: int) -> BBox:
    """The box of the red component whose centre is nearest ``near_x`` (a letter's)."""
    red = ((image[..., 2] > 150) & (image[..., 1] < 90)).astype(np.uint8)
    n, _, stats, centroids = cv2.connectedComponentsWithStats(red)
    k = 1 + int(np.argmin(np.abs(centroids[1:, 0] - near_x)))
    x, y, w, h = (int(v) for v in stats[k][:4])
    return x, y, w, h


def _disc(image: NDArray[np.uint8], centre: tuple[int, int], r: int) -> BBox:
    cv2.circle(image, centre, r + 3, (20, 20, 20), -1, cv2.LINE_AA)
    cv2.circle(image, centre, r, SIGNAL_RED, -1, cv2.LINE_AA)
    return centre[0] - r, centre[1] - r, 2 * r, 2 * r


def test_a_round_letter_in_a_word_has_its_neighbours_found() -> None:
    image = _body()
    _word(image, "DOOR", (250, 250))
    image = _noisy(image)
    before = image.copy()
    o = _letter_box(image, 310)
    beside = row_neighbours(image, o)
    assert len(beside) >= 2  # D and the other O at least
    assert all(abs(b[1] - o[1]) < o[3] // 2 for b in beside)  # on the same line
    reason = lettering_reason(image, o)
    assert reason is not None and "a person must look" in reason
    assert np.array_equal(image, before)  # the input is not modified


@pytest.mark.parametrize("paint", [BLUE_GREY, (40, 45, 150), (30, 60, 110)])
def test_a_disc_standing_alone_has_no_neighbours(paint: tuple[int, int, int]) -> None:
    """Beside it a buffer (not its paint), a red stripe (far wider than tall) and, on a
    red or red-brown car, body panels of nearly its paint: none is a letter."""
    image = _body(paint)
    box = _disc(image, (420, 330), 22)
    cv2.circle(image, (500, 380), 22, (60, 60, 60), -1)  # buffer
    cv2.rectangle(image, (180, 315), (380, 345), SIGNAL_RED, -1)  # body stripe
    image = _noisy(image, 1)
    assert row_neighbours(image, box) == []
    assert lettering_reason(image, box) is None


def test_tiny_regions_are_not_judged() -> None:
    image = _body()
    _word(image, "DOOR", (250, 250))
    o = _letter_box(image, 310)
    params = LetteringParams(min_side_px=max(o[2], o[3]) + 1)
    assert row_neighbours(image, o, params=params) == []


def test_only_a_present_is_held_and_nothing_becomes_present() -> None:
    sample = _scene("A", "validation", 1436)
    hand = detect(sample.image)
    for verdict in ("absent", "uncertain"):
        given = replace(hand, verdict=verdict)
        assert hold_lookalikes(sample.image, given) is given


def test_red_lettering_every_verifier_believes_is_held_uncertain() -> None:
    sample = _scene("A", "validation", 1436)
    assert not sample.disc and sample.kind == "red_lettering"
    hand = detect(sample.image)
    assert hand.verdict == "present" and hand.score > 0.99  # the error the check exists for
    checked = confirm(sample.image, hand)
    assert checked.verdict == "uncertain"
    assert "same paint stand beside it" in checked.reasons[0]
    assert checked.reasons[1:] == hand.reasons and checked.bbox == hand.bbox
    # the service's path (reduced JPEG decode) gives the same answer
    ok, buf = cv2.imencode(".jpg", sample.image, [cv2.IMWRITE_JPEG_QUALITY, 92])
    assert ok
    assert detect_snapshot(buf.tobytes()).verdict == "uncertain"


MEASURED_DISCS_HELD = 0
"""Of the hand-tuned ``present`` on true discs, how many the lettering check held
``uncertain`` (measured, with those below: 0 of 138 on generator A's reference seeds
340000-340299; on its randomised validation seeds 0 of 142 on 201600-202399 and 1 of 95
on 201000-201599, A:201242, whose box was on the red lettering "6Q0", not the disc; 0 of
21 on B's 201000-201199 and 0 of 13 on its 100000-100149; 0 of 38 on C's
340000-340119)"""


def test_true_discs_are_not_taken_for_letters() -> None:
    held = total = 0
    for sample, hand in hand_presents_on_discs(scenes("A", "heldout", 120, offset=40000)):
        total += 1
        held += hold_lookalikes(sample.image, hand).verdict == "uncertain"
    assert total >= 50
    assert held == MEASURED_DISCS_HELD, (held, total)


def _text(
    image: NDArray[np.uint8],
    text: str,
    origin: tuple[int, int],
    *,
    scale: float = 1.6,
    paint: tuple[int, int, int] = SIGNAL_RED,
    font: int = cv2.FONT_HERSHEY_DUPLEX,
) -> int:
    """Paint ``text`` at ``origin`` (its baseline's left end); the x just past its end."""
    thickness = max(2, int(round(2.5 * scale)))
    cv2.putText(image, text, origin, font, scale, paint, thickness, cv2.LINE_AA)
    (width, _), _ = cv2.getTextSize(text, font, scale, thickness)
    return origin[0] + width


def _bowl_box(image: NDArray[np.uint8], x0: int, x1: int) -> BBox:
    """The box of the red component whose centre lies between ``x0`` and ``x1``."""
    red = ((image[..., 2] > 150) & (image[..., 1] < 90)).astype(np.uint8)
    n, _, stats, centroids = cv2.connectedComponentsWithStats(red)
    inside = [k for k in range(1, n) if x0 <= centroids[k][0] <= x1]
    assert len(inside) == 1, inside
    x, y, w, h = (int(v) for v in stats[inside[0]][:4])
    return x, y, w, h


def _held(image: NDArray[np.uint8], box: BBox) -> bool:
    return lettering_reason(_noisy(image, 2), box) is not None


@pytest.mark.parametrize("words", [("B", "0", "B"), ("No", "0", "OR"), ("8", "O", "1")])
def test_a_round_letter_a_word_space_from_its_neighbours_is_held(
    words: tuple[str, str, str],
) -> None:
    """Independent trial (880 scenes of its own drawing): "B 0 B" and similar, the
    neighbours a word space (about one letter height) away, were false ``present``
    6 times in 10: a lone neighbour is judged only a letter gap away, a row of them
    farther."""
    image = _body()
    space = 44  # about one letter height of the 1.6 scale
    end = _text(image, words[0], (150, 250)) + space
    bowl_end = _text(image, words[1], (end, 250))
    _text(image, words[2], (bowl_end + space, 250))
    box = _bowl_box(image, end, bowl_end)
    assert _held(image, box)


def test_a_round_letter_after_an_abbreviation_is_held() -> None:
    """'Nr. 0': the neighbours are N, a lower-case r (shorter) and a full stop, a word
    space away (trial: false ``present``)."""
    image = _body()
    end = _text(image, "Nr.", (150, 250)) + 30
    bowl_end = _text(image, "0", (end, 250))
    assert _held(image, _bowl_box(image, end, bowl_end))


def test_a_round_letter_between_thin_characters_is_held() -> None:
    """'1O1' and 'I0I': the neighbours are strokes, narrower than ``width_range``
    admits for a lone neighbour (trial: 3 of 20 false ``present``)."""
    for text in ("1", "I"):
        image = _body()
        end = _text(image, text, (200, 250)) + 8
        bowl_end = _text(image, "O", (end, 250))
        _text(image, text, (bowl_end + 8, 250))
        assert _held(image, _bowl_box(image, end, bowl_end)), text


@pytest.mark.parametrize("darker", [0.7, 0.75])
def test_neighbours_of_worn_darker_paint_are_letters_still(darker: float) -> None:
    """Neighbours 25-30 % darker than the round letter (worn or shaded paint; trial:
    2-3 of 16 false ``present``)."""
    image = _body()
    dim = tuple(int(v * darker) for v in SIGNAL_RED)
    end = _text(image, "D", (200, 250), paint=dim)  # type: ignore[arg-type]
    bowl_end = _text(image, "O", (end, 250))
    _text(image, "R", (bowl_end, 250), paint=dim)  # type: ignore[arg-type]
    assert _held(image, _bowl_box(image, end, bowl_end))


def test_a_big_digit_beside_smaller_text_of_its_paint_is_held() -> None:
    """A big '0' and then '45 t' in smaller letters on the same baseline (trial: 10 of
    30 false ``present``): a row of shorter letters is lettering too."""
    image = _body()
    bowl_end = _text(image, "0", (160, 270), scale=2.6)
    _text(image, "45 t", (bowl_end + 14, 270), scale=1.3)
    assert _held(image, _bowl_box(image, 150, bowl_end))


def test_a_disc_with_its_paint_far_along_its_line_stands_alone() -> None:
    """Red lettering on the disc's line but more than a word space away, and two red
    bolts of a bracket a disc width apart (not a row of letters): the disc is not held."""
    image = _body()
    box = _disc(image, (470, 330), 22)
    _text(image, "ROB 80", (130, 345), scale=1.4)  # ends ~3 disc widths from the disc
    for x in (400, 540):  # the bracket's bolts
        cv2.circle(image, (x, 330), 4, SIGNAL_RED, -1, cv2.LINE_AA)
    image = _noisy(image, 3)
    assert row_neighbours(image, box) == []


YELLOW = (40, 200, 230)
CREAM = (200, 225, 235)


@pytest.mark.parametrize(
    ("body", "ink"), [((60, 100, 40), YELLOW), (BLUE_GREY, CREAM), ((50, 50, 55), YELLOW)]
)
def test_a_red_letter_inside_a_word_of_another_ink_is_held(
    body: tuple[int, int, int], ink: tuple[int, int, int]
) -> None:
    """'ROBOT' with a red O and 'ФОРМА'-like words with one red letter (trial: 9 of 30
    false ``present``): a row of another ink through the region's line is lettering."""
    image = _body(body)
    end = _text(image, "R", (170, 250), paint=ink)
    bowl_end = _text(image, "O", (end, 250))
    _text(image, "BOT", (bowl_end, 250), paint=ink)
    assert _held(image, _bowl_box(image, end, bowl_end))


def test_a_disc_beside_one_lamp_and_above_the_buffer_beam_stands_alone() -> None:
    """One lit lamp beside the disc on its line, the dark buffer beam and a buffer below:
    marks of another colour, but no row of them."""
    image = _body()
    box = _disc(image, (420, 330), 22)
    cv2.circle(image, (490, 330), 16, CREAM, -1, cv2.LINE_AA)  # a lamp
    cv2.circle(image, (330, 385), 22, (60, 60, 60), -1)  # a buffer
    image = _noisy(image, 4)
    assert row_neighbours(image, box) == []


@pytest.mark.parametrize("text", ["1-0", "-0-"])
def test_a_round_letter_joined_by_dashes_is_held(text: str) -> None:
    """'1-0' and '-0-' (independent trial 920210, 920483: false ``present``): a hyphen
    is a member of the row."""
    image = _body()
    start = 200
    for part in text:
        end = _text(image, part, (start, 250))
        if part == "0":
            bowl = (start, end)
        start = end + 6
    assert _held(image, _bowl_box(image, *bowl))


def test_a_round_letter_beside_one_stroke_is_held() -> None:
    """'I0' (trial 920314): one stroke, narrower than a lone neighbour may be, starting
    and ending where the round letter does."""
    image = _body()
    end = _text(image, "I", (200, 250)) + 6
    bowl_end = _text(image, "0", (end, 250))
    assert _held(image, _bowl_box(image, end, bowl_end))


def test_a_round_letter_a_letter_height_from_its_only_neighbour_is_held() -> None:
    """'0  D', the D about a letter height away (as the 1 of the trial's 920626)."""
    image = _body()
    bowl_end = _text(image, "0", (200, 250))
    _text(image, "D", (bowl_end + 28, 250))
    assert _held(image, _bowl_box(image, 190, bowl_end))


def test_a_disc_beside_a_post_of_its_paint_stands_alone() -> None:
    """A red post of the bracket beside the disc runs past it above and below: not a
    stroke of a letter."""
    image = _body()
    box = _disc(image, (420, 300), 22)
    cv2.rectangle(image, (452, 262), (458, 350), SIGNAL_RED, -1)
    image = _noisy(image, 5)
    assert row_neighbours(image, box) == []
