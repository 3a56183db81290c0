"""When a rolling-shutter frame shows stripes at all: the gates of
:func:`motion.stripes.measure_smear` (a frame that fails them gets no speed)."""

from __future__ import annotations

from dataclasses import dataclass

__all__ = ["StripeQuality", "check_agreement", "check_quality"]


@dataclass(frozen=True)
class StripeQuality:
    """When a frame shows stripes at all. Measured: rendered stripes' edges (0–60 m/s, noise
    σ 20 or none) 0.04–0.41 px rms off their lines; photos 1.4–24 px; noise ≤ 1 edge."""

    max_residual_px: float = 1.0  # rms distance of the edge points from their lines, pixels
    min_tracks: int = 3  # stripe edges that agree on the slope, at least
    # A rolling shutter slants every stripe edge alike: the σ of their smear, over the band,
    # within this share of the smear (rendered and degraded stripes ≤ 0.001; photos without
    # stripes 0.17–30, found by the independent trial on resized and cropped RailSem19 and
    # wagon photos, which passed the straightness gate once shrunk), or within the floor
    # (a standing train: no smear; stripes 0.003 px).  Both scale with the frame.
    max_smear_spread: float = 0.05
    smear_spread_floor_px: float = 0.1


def check_agreement(smear_px: float, spread_px: float, quality: StripeQuality) -> None:
    """The edges must agree on one smear, as a rolling shutter's do (see StripeQuality)."""
    allowed = max(quality.max_smear_spread * abs(smear_px), quality.smear_spread_floor_px)
    if not spread_px <= allowed:  # (NaN, a single edge's spread, is no agreement either)
        raise ValueError(
            f"no stripes found: the edges disagree on the smear by {spread_px:.2f} px of"
            f" {abs(smear_px):.1f} px (stripes beside the line slant alike; ≤ {allowed:.2f} px)"
        )


def check_quality(tracks: int, residual_px: float, quality: StripeQuality) -> None:
    if tracks < quality.min_tracks or residual_px > quality.max_residual_px:
        raise ValueError(
            f"no stripes found: {tracks} edge(s) {residual_px:.1f} px rms off straight lines"
            f" (a stripe pattern needs ≥ {quality.min_tracks}, ≤ {quality.max_residual_px} px)"
        )
