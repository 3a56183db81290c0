"""Speed from on-board optical sensors (seed ``000``, Starovoitov & Vorobiev 2015).

Equations (1)–(16) of the paper, its Table 1, and the rolling-shutter
("smear") speed meter working on real images.

Units: metres, seconds, radians, pixels; speeds in m/s unless a name ends in
``_kmh``.

Conventions
-----------
* ``pixel_fov_rad`` is the paper's β, the angle one pixel subtends (55° over
  1024 pixels ≈ 0.94 mrad).  ``pixel_error_rad`` is its Δω, the discreteness
  of an angle read off the sensor (half a pixel, 0.47 mrad).
* The paper writes the smear angle as ``s·β``: a pixel column maps linearly
  to an angle (an equiangular lens).  :func:`render_stripes` uses that model:
  column ``c`` looks at angle ``(c - cx)·β`` from the optical axis, and a
  point at perpendicular distance ``D`` seen at angle θ lies ``D·tan θ``
  along the track from the axis.  :func:`measure_smear` fits the edges in
  that model and in a rectilinear lens's (column ∝ tan θ, every edge shifted
  alike in pixels) and keeps the one the frame follows; a frame that fails
  the stripe gate in the paper's model is refused in both.
* A CMOS rolling shutter exposes row ``r`` at ``r·t_c`` (``row_time_s``),
  so a vertical stripe passing at speed ``v`` is drawn slanted: its
  along-track position ``D·tan θ`` moves by ``v·t_c`` per row, and over
  ``h`` rows the stripe is smeared by ``s`` pixels with
  ``tan(s·β) = v·h·t_c / D`` — equation (14).

Table 1 notes
-------------
* σ_v in km/h is printed as the *rounded* m/s value times 3.6 (0.93 → 3.35,
  although 0.934 m/s is 3.36 km/h); :func:`table1` gives both.
* The stereo row comes out only when Δω = 0.47e-3 is put into equation (4)
  as a parallax error in metres on the sensor (the paper's convention).  The
  physically consistent parallax error is the pixel pitch expressed on the
  sensor, ``f·Δω`` = 47 µm for f = 0.1 m, which makes σ_D about ten times
  smaller (0.075 m at 20 m).  :func:`table1` reports the paper's row and the
  consistent row beside it (``meter == "stereo_consistent"``).
"""

from __future__ import annotations

from .optical_limits import OPTICAL_LIMITS, OpticalLimits, OpticalRangeError
from .ranging import (
    KMH_PER_MPS,
    PAPER_TABLE1,
    Table1Params,
    Table1Row,
    angle_range,
    angle_range_sigma,
    apparent_angle,
    approach_speed,
    approach_speed_sigma,
    approach_speed_sigma_simple,
    beacon_range_sigma,
    max_second_range,
    min_interval,
    smear_interval,
    stereo_parallax,
    stereo_range,
    stereo_range_sigma,
    table1,
)
from .smear import (
    PAPER_EXAMPLE,
    RollScatterStudy,
    roll_scatter_study,
    rows_for_stripe,
    smear_for_speed,
    speed_from_smear,
    speed_sigma_from_smear,
    speed_sigma_roll_scatter,
)
from .stripes import (
    OpticalSpeed,
    SmearMeasurement,
    measure_smear,
    render_stripes,
    speed_from_image,
)

__all__ = [
    "KMH_PER_MPS",
    "OPTICAL_LIMITS",
    "OpticalLimits",
    "OpticalRangeError",
    "PAPER_TABLE1",
    "PAPER_EXAMPLE",
    "OpticalSpeed",
    "RollScatterStudy",
    "SmearMeasurement",
    "Table1Params",
    "Table1Row",
    "angle_range",
    "angle_range_sigma",
    "apparent_angle",
    "approach_speed",
    "approach_speed_sigma",
    "approach_speed_sigma_simple",
    "beacon_range_sigma",
    "max_second_range",
    "measure_smear",
    "min_interval",
    "render_stripes",
    "roll_scatter_study",
    "rows_for_stripe",
    "smear_for_speed",
    "smear_interval",
    "speed_from_image",
    "speed_from_smear",
    "speed_sigma_from_smear",
    "speed_sigma_roll_scatter",
    "stereo_parallax",
    "stereo_range",
    "stereo_range_sigma",
    "table1",
]
