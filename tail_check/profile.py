"""Camera profiles: where and what the tail-disc detector looks for on one camera.

A profile is plain data, stored as JSON. Every geometric quantity is relative to
the image (fractions of the width/height, or of the geometric-mean side
``sqrt(W * H)``), so one profile serves any resolution the camera delivers.
"""

from __future__ import annotations

import json
import math
from dataclasses import asdict, dataclass, fields, replace
from pathlib import Path
from typing import Any

__all__ = ["DEFAULT_PROFILE", "CameraProfile", "load_profile"]

PROFILE_FORMAT = 1


def _check_range(name: str, lo: float, hi: float, *, low: float, high: float) -> None:
    if not (math.isfinite(lo) and math.isfinite(hi)):
        raise ValueError(f"profile field {name!r} must be finite numbers, got ({lo}, {hi})")
    if not (low <= lo <= hi <= high):
        raise ValueError(
            f"profile field {name!r} must satisfy {low} <= lo <= hi <= {high}, got ({lo}, {hi})"
        )


def _shown(value: Any) -> str:
    """``value`` as JSON spells it (``true``, ``null``, ``"0.25"``), for a message."""
    try:
        return json.dumps(value)
    except (TypeError, ValueError):
        return repr(value)


def _number(value: Any) -> float | None:
    """A JSON number as a float; None for anything else. ``float()`` took ``true`` for 1.0
    and the string ``"0.25"`` for 0.25, and a string of three digits for three numbers."""
    if isinstance(value, bool) or not isinstance(value, int | float):
        return None
    try:
        return float(value)
    except OverflowError:  # an integer beyond any float: refused as not a usable number
        return None


@dataclass(frozen=True)
class CameraProfile:
    """Per-camera settings of the tail-disc detector.

    Attributes
    ----------
    name : str
        Camera or profile name (free text).
    reference_rgb : tuple of 3 float
        ``c_ref`` of the paper: the disc colour as ``[r, g, b]`` in 0..255 (RGB order,
        as in the paper; images themselves are BGR).
    c_delta : float
        Half-width of the per-channel band as a fraction of ``mean(c_ref)``
        (the paper's ``c_Δ``; 0.25 = 25 %).
    sigma : float
        Gaussian low-pass σ as a fraction of the geometric-mean side ``sqrt(W*H)``.
    gain_range : tuple of 2 float
        Exposure gains ``k`` tried for the band ``k * (c_ref ± c_Δ)``: the camera's
        exposure is not known at dusk or night. ``(1, 1)`` is the paper's fixed band.
    search_region : tuple of 4 float
        ``(x0, y0, x1, y1)`` as fractions of width and height: where the disc can be.
    disc_diameter_range : tuple of 2 float
        Expected disc diameter as a fraction of ``sqrt(W*H)``.
    fill_range : tuple of 2 float
        Accepted region-area / bounding-box-area (a disc: π/4 ≈ 0.785).
    min_ellipse_iou : float
        Minimum overlap of a region with the ellipse of equal second moments
        (a disc ≈ 1, a rectangle ≈ 0.83, a ring far less).
    max_aspect : float
        Maximum long/short side of the region's box (perspective squashes the disc).
    present_threshold : float
        Disc score at or above which the verdict is ``present``.
    uncertain_threshold : float
        Disc score at or above which (below ``present_threshold``) the verdict is
        ``uncertain`` rather than ``absent``.
    absent_confidence : float
        Score an ``absent`` verdict must exceed to count as proof of a lost rear part
        (used by the block-clearance rules, not by the detector itself).
    """

    name: str = "default"
    reference_rgb: tuple[float, float, float] = (200.0, 35.0, 38.0)
    c_delta: float = 0.25
    sigma: float = 0.004
    gain_range: tuple[float, float] = (0.22, 1.35)
    search_region: tuple[float, float, float, float] = (0.30, 0.25, 1.0, 1.0)
    disc_diameter_range: tuple[float, float] = (0.03, 0.20)
    fill_range: tuple[float, float] = (0.66, 0.84)
    min_ellipse_iou: float = 0.88
    max_aspect: float = 1.6
    present_threshold: float = 0.75
    uncertain_threshold: float = 0.05
    absent_confidence: float = 0.8

    def __post_init__(self) -> None:
        ref = self.reference_rgb
        if len(ref) != 3 or not all(math.isfinite(v) and 0 <= v <= 255 for v in ref):
            raise ValueError(
                f"profile field 'reference_rgb' must be 3 numbers in 0..255, got {ref}"
            )
        if sum(ref) <= 0:
            raise ValueError("profile field 'reference_rgb' must not be black")
        if not 0 < self.c_delta <= 2:
            raise ValueError(f"profile field 'c_delta' must be in (0, 2], got {self.c_delta}")
        if not 0 <= self.sigma <= 0.05:
            raise ValueError(f"profile field 'sigma' must be in [0, 0.05], got {self.sigma}")
        _check_range("gain_range", *self.gain_range, low=0.01, high=10.0)
        x0, y0, x1, y1 = self.search_region
        _check_range("search_region x", x0, x1, low=0.0, high=1.0)
        _check_range("search_region y", y0, y1, low=0.0, high=1.0)
        if x1 - x0 < 0.01 or y1 - y0 < 0.01:
            raise ValueError(f"profile field 'search_region' is empty: {self.search_region}")
        _check_range("disc_diameter_range", *self.disc_diameter_range, low=1e-3, high=1.0)
        _check_range("fill_range", *self.fill_range, low=0.0, high=1.0)
        for name in ("min_ellipse_iou", "present_threshold", "uncertain_threshold"):
            value = float(getattr(self, name))
            if not 0 <= value <= 1:
                raise ValueError(f"profile field {name!r} must be in [0, 1], got {value}")
        if not 0 <= self.absent_confidence <= 1:
            raise ValueError(
                f"profile field 'absent_confidence' must be in [0, 1], got {self.absent_confidence}"
            )
        if self.uncertain_threshold > self.present_threshold:
            raise ValueError("profile: 'uncertain_threshold' must not exceed 'present_threshold'")
        if self.max_aspect < 1:
            raise ValueError(f"profile field 'max_aspect' must be >= 1, got {self.max_aspect}")

    @property
    def band_halfwidth(self) -> float:
        """Absolute half-width ``c_Δ · mean(c_ref)`` of the band at gain 1 (0..255 units)."""
        return self.c_delta * sum(self.reference_rgb) / 3.0

    def to_dict(self) -> dict[str, Any]:
        """Plain JSON-ready dict (tuples become lists), with a format number."""
        data: dict[str, Any] = {"format": PROFILE_FORMAT}
        for key, value in asdict(self).items():
            data[key] = list(value) if isinstance(value, tuple) else value
        return data

    def to_json(self) -> str:
        """The profile as indented JSON text."""
        return json.dumps(self.to_dict(), indent=2)

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> CameraProfile:
        """Build a profile from a dict; missing fields take the default profile's values.

        Raises
        ------
        ValueError
            On unknown fields, a wrong format number or invalid values.
        """
        if not isinstance(data, dict):
            raise ValueError("a camera profile must be a JSON object")
        data = dict(data)
        fmt = data.pop("format", PROFILE_FORMAT)
        if isinstance(fmt, bool) or fmt != PROFILE_FORMAT:  # true == 1 in Python
            raise ValueError(
                f"unsupported camera profile format {_shown(fmt)} (expected {PROFILE_FORMAT})"
            )
        known = {f.name: f for f in fields(cls)}
        unknown = sorted(set(data) - set(known))
        if unknown:
            raise ValueError(f"unknown camera profile field(s): {', '.join(unknown)}")
        kwargs: dict[str, Any] = {}
        for key, value in data.items():
            default = getattr(DEFAULT_PROFILE, key)
            if isinstance(default, tuple):
                listed = isinstance(value, list | tuple) and len(value) == len(default)
                numbers = [_number(v) for v in value] if listed else [None]
                if None in numbers:
                    raise ValueError(
                        f"profile field {key!r} must be a list of {len(default)} numbers,"
                        f" got {_shown(value)}"
                    )
                kwargs[key] = tuple(numbers)
            elif isinstance(default, str):
                if not isinstance(value, str):
                    raise ValueError(f"profile field {key!r} must be a string, got {_shown(value)}")
                kwargs[key] = value
            else:
                number = _number(value)
                if number is None:
                    raise ValueError(f"profile field {key!r} must be a number, got {_shown(value)}")
                kwargs[key] = number
        return replace(DEFAULT_PROFILE, **kwargs)

    @classmethod
    def from_json(cls, text: str) -> CameraProfile:
        """Parse a profile from JSON text (see :meth:`from_dict`)."""
        try:
            data = json.loads(text)
        except json.JSONDecodeError as exc:
            raise ValueError(f"camera profile is not valid JSON: {exc}") from None
        return cls.from_dict(data)


DEFAULT_PROFILE = CameraProfile()
"""Profile for an uncalibrated camera: standard signal red, typical tail-camera framing
(disc on the right half, at buffer-beam height in the lower three quarters)."""


def load_profile(path: str | Path) -> CameraProfile:
    """Read a camera profile from a JSON file.

    Raises
    ------
    ValueError
        If the file cannot be read, is not UTF-8 text or holds an invalid profile.
    """
    try:
        text = Path(path).read_text(encoding="utf-8")
    except OSError as exc:
        raise ValueError(f"cannot read camera profile {str(path)!r}: {exc.strerror}") from None
    except UnicodeDecodeError:
        raise ValueError(f"profile {str(path)!r} is not UTF-8 JSON text") from None
    return CameraProfile.from_json(text)
