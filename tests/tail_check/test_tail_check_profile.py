"""Camera profiles: JSON round trip, defaults and validation."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from tail_check import DEFAULT_PROFILE, CameraProfile, load_profile


def test_default_profile_is_signal_red_with_paper_band() -> None:
    p = DEFAULT_PROFILE
    r, g, b = p.reference_rgb
    assert r > 4 * g and r > 4 * b  # a saturated red
    assert p.c_delta == 0.25  # the paper's c_Δ ≈ 25 % of mean c_ref
    assert p.band_halfwidth == pytest.approx(0.25 * (r + g + b) / 3)
    assert 0 < p.absent_confidence <= 1


def test_json_round_trip(tmp_path: Path) -> None:
    p = CameraProfile(
        name="cam-B",
        reference_rgb=(190.0, 30.0, 35.0),
        c_delta=0.3,
        search_region=(0.5, 0.4, 0.9, 0.9),
        absent_confidence=0.9,
    )
    path = tmp_path / "cam.json"
    path.write_text(p.to_json(), encoding="utf-8")
    assert load_profile(path) == p
    data = json.loads(p.to_json())
    assert data["format"] == 1 and data["reference_rgb"] == [190.0, 30.0, 35.0]


def test_missing_fields_take_defaults() -> None:
    p = CameraProfile.from_dict({"name": "x", "c_delta": 0.2})
    assert p.c_delta == 0.2 and p.search_region == DEFAULT_PROFILE.search_region


@pytest.mark.parametrize(
    ("data", "word"),
    [
        ({"c_delta": 0}, "c_delta"),
        ({"reference_rgb": [300, 0, 0]}, "reference_rgb"),
        ({"reference_rgb": [1, 2]}, "reference_rgb"),
        ({"search_region": [0.8, 0.2, 0.3, 0.9]}, "search_region"),
        ({"colour": 1}, "unknown"),
        ({"format": 7}, "format"),
        ({"uncertain_threshold": 0.9, "present_threshold": 0.5}, "uncertain_threshold"),
        ({"c_delta": "wide"}, "c_delta"),
    ],
)
def test_invalid_profiles_are_refused_with_the_field_named(data: dict, word: str) -> None:
    with pytest.raises(ValueError, match=word):
        CameraProfile.from_dict(data)


def test_bad_files(tmp_path: Path) -> None:
    with pytest.raises(ValueError, match="cannot read"):
        load_profile(tmp_path / "none.json")
    bad = tmp_path / "bad.json"
    bad.write_text("{not json", encoding="utf-8")
    with pytest.raises(ValueError, match="not valid JSON"):
        load_profile(bad)
