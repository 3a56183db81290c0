"""Samples of an image along rays from a point (the lamp and housing checks' profiles)."""

from __future__ import annotations

import cv2
import numpy as np
from numpy.typing import NDArray

__all__ = ["sample_rays"]


def sample_rays(
    image: NDArray[np.float32],
    centre: tuple[float, float],
    distances: NDArray[np.float32],
    rays: int,
) -> NDArray[np.float32]:
    """Bilinear samples of ``image`` along ``rays`` rays from ``centre``.

    Parameters
    ----------
    image : ndarray, shape (H, W) or (H, W, C), float32
        The image (not modified); outside it, its edge pixels repeat.
    centre : (x, y)
        Where the rays start, in pixels (pixel centres at integer coordinates).
    distances : ndarray, shape (N,), float32
        Distances from the centre sampled on each ray, pixels.
    rays : int
        Directions, evenly spaced: the first points right (+x), the next turn towards +y.

    Returns
    -------
    ndarray, shape (rays, N) or (rays, N, C), float32
    """
    angles = np.linspace(0.0, 2.0 * np.pi, rays, endpoint=False)
    xs = centre[0] + distances[None, :] * np.cos(angles)[:, None]
    ys = centre[1] + distances[None, :] * np.sin(angles)[:, None]
    return np.asarray(
        cv2.remap(
            image,
            xs.astype(np.float32),
            ys.astype(np.float32),
            cv2.INTER_LINEAR,
            borderMode=cv2.BORDER_REPLICATE,
        ),
        np.float32,
    )
