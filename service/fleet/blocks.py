"""A car's stored tests of one layout, as arrays: what the history readers produce."""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray


class Block(NamedTuple):
    """A car's tests of one layout, in (time, id) order."""

    layout_id: int
    epoch_s: NDArray[np.float64]
    ids: NDArray[np.int64]
    readings: NDArray[np.float64]  # (n_tests, n_names of the layout)
