"""The ``depot braking`` argument parsers (options, defaults and units of each sub-command).

Kept apart from :mod:`service.commands.motion`, which binds each parser to its command.
Every range is read from :data:`motion.braking_limits.BRAKING_LIMITS`, the ranges
``POST /api/v1/motion/braking-plan`` applies: the command and the endpoint accept and
refuse the same values (found by the independent trial: speed 0 and a probability of 1
were planned by the endpoint and refused here).
"""

from __future__ import annotations

import argparse
import re
from typing import Any

from motion.braking_limits import BRAKING_LIMITS as LIM
from motion.ranging import KMH_PER_MPS
from service.commands._common import PROBABILITY, SEED, number, values_may_look_negative

# Monte Carlo runs: a million takes minutes on a 2-core host; more is a typing slip.
MAX_RUNS = LIM.max_monte_carlo_runs
RUNS = number(int, low=LIM.min_monte_carlo_runs, high=MAX_RUNS)
SPEED = number(low=0, high=LIM.max_speed_mps)  # a standing train has a plan too
SPEED_KMH = number(low=0, high=LIM.max_speed_mps * KMH_PER_MPS)
MOVING = number(low=0, low_open=True, high=LIM.max_speed_mps)  # Monte Carlo brakes from it
MOVING_KMH = number(low=0, low_open=True, high=LIM.max_speed_mps * KMH_PER_MPS)
DECELERATION = number(low=0, low_open=True, high=LIM.max_deceleration_mps2)
REACTION = number(low=0, high=LIM.max_reaction_time_s)
GRADIENT = number(low=-LIM.max_abs_gradient_permille, high=LIM.max_abs_gradient_permille)
MARGIN = number(low=0, high=LIM.max_margin_m)
# The probability of exceeding a margin: 1 claims nothing, and is allowed; 0 would claim certainty.
EXCEEDING = number(low=0, low_open=True, high=1)
MEASUREMENTS = number(int, low=1, high=LIM.max_measurements)
CHANNELS = number(int, low=1, high=LIM.max_channels)
MEASUREMENT_TIME = number(low=0, high=LIM.max_measurement_time_s)
COORDINATE = number(low=-LIM.max_abs_coordinate_m, high=LIM.max_abs_coordinate_m)

# Any number may be negative (``-1e6``, ``-inf``): these parsers have no option that looks
# like a number.
_NEGATIVE_NUMBER = re.compile(r"^-(\d+\.?\d*|\.\d+)([eE][-+]?\d+)?$|^-(inf|infinity|nan)$", re.I)


def add_braking_parsers(sub: Any) -> dict[str, argparse.ArgumentParser]:
    """Add ``braking`` and its sub-commands; the parsers by name, for the caller to bind."""
    b = sub.add_parser(
        "braking", help="braking safety: trials, exceedance, protective section, Monte Carlo"
    )
    bs = b.add_subparsers(dest="braking_command", required=True)

    t = bs.add_parser("trials", help="trials needed for p_max at confidence β (eq. 8)")
    t.add_argument("--p-max", type=PROBABILITY, required=True, help="largest allowed probability")
    t.add_argument("--beta", type=PROBABILITY, required=True, help="confidence β, 0 to 1")
    t.add_argument("--json", action="store_true", help="print JSON instead of text")

    x = bs.add_parser(
        "exceedance", help="exceedance of the smallest of k measurements over channels"
    )
    x.add_argument(
        "--p-max", type=PROBABILITY, required=True, help="probability that one measurement exceeds"
    )
    x.add_argument("-k", type=MEASUREMENTS, required=True, help="measurements per channel")
    x.add_argument("--channels", type=CHANNELS, default=1, help="independent channels")
    x.add_argument("--json", action="store_true", help="print JSON instead of text")

    pl = bs.add_parser("plan", help="protective section and braking start point (eq. 6–7)")
    sp = pl.add_mutually_exclusive_group(required=True)
    sp.add_argument("--speed", type=SPEED, help="speed, m/s (or --speed-kmh)")
    sp.add_argument("--speed-kmh", type=SPEED_KMH, help="speed, km/h (or --speed)")
    pl.add_argument("--decel", type=DECELERATION, required=True, help="braking deceleration, m/s²")
    pl.add_argument("--reaction-time", type=REACTION, default=0.0, help="reaction time, s")
    pl.add_argument(
        "--gradient",
        type=GRADIENT,
        default=0.0,
        help="gradient, ‰, positive uphill, negative downhill (e.g. --gradient -8), within ±70",
    )
    pl.add_argument(
        "--delta-s-max", type=MARGIN, default=3.0, help="largest negative braking error, m"
    )
    pl.add_argument(
        "--p-s", type=EXCEEDING, default=1e-2, help="probability of exceeding --delta-s-max"
    )
    pl.add_argument(
        "--delta-l-max", type=MARGIN, default=0.0, help="largest positive range error, m"
    )
    pl.add_argument(
        "--p-l", type=EXCEEDING, default=1e-2, help="probability of exceeding --delta-l-max"
    )
    pl.add_argument(
        "-k", type=MEASUREMENTS, default=1, help="measurements per channel (the smallest is used)"
    )
    pl.add_argument("--channels", type=CHANNELS, default=1, help="independent channels")
    pl.add_argument(
        "--measurement-time", type=MEASUREMENT_TIME, default=0.0, help="time per measurement, s"
    )
    pl.add_argument(
        "--obstacle-at",
        type=COORDINATE,
        default=None,
        help="obstacle track coordinate, m (default: none, no braking start point)",
    )
    pl.add_argument("--json", action="store_true", help="print JSON instead of text")

    m = bs.add_parser(
        "montecarlo", help="Monte Carlo of the braking-distance error (±10 %% speed error)"
    )
    m.add_argument("--runs", type=RUNS, default=230, help="simulated brakings")
    m.add_argument(
        "--control",
        choices=["deceleration", "speed"],
        default="deceleration",
        help="what the brake controller holds",
    )
    ms = m.add_mutually_exclusive_group()
    ms.add_argument("--speed", type=MOVING, default=16.7, help="initial speed, m/s")
    ms.add_argument(
        "--speed-kmh", type=MOVING_KMH, default=None, help="initial speed, km/h (default: --speed)"
    )
    m.add_argument(
        "--beta", type=PROBABILITY, default=0.9, help="confidence β of the reported bound"
    )
    m.add_argument("--seed", type=SEED, default=0, help="random seed")
    m.add_argument(
        "--png", default=None, metavar="FILE", help="write the histogram here (default: none)"
    )
    m.add_argument("--json", action="store_true", help="print JSON instead of text")
    for parser in (pl, m):
        values_may_look_negative(parser, _NEGATIVE_NUMBER)
    return {"trials": t, "exceedance": x, "plan": pl, "montecarlo": m}
