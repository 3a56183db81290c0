"""CLI commands of the motion package: ``optical-speed``, ``braking`` and
``motion-tables``.

The top-level ``depot`` CLI adds them with :func:`register`::

    sub = parser.add_subparsers(dest="command")
    service.commands.motion.register(sub)
    args = parser.parse_args(argv)
    return args.func(args)          # each command returns an exit code

They also run alone: ``python -m service.commands.motion motion-tables``.

Commands
--------
``depot optical-speed IMAGE --distance M --pixel-fov RAD --row-time S [--rows N] [--json]``
    Speed from the slant of vertical stripes on a rolling-shutter image
    (eq. 14) and its uncertainty (eq. 15).
``depot braking trials --p-max P --beta B``
    Trials needed to claim P at confidence B (eq. 8).
``depot braking exceedance --p-max P -k K [--channels C]``
    Exceedance of the smallest of K measurements in each of C channels.
``depot braking plan --speed V --decel A [--reaction-time S] [--gradient ‰] [...]``
    Braking distance, protective section and braking start point (eq. 6–7).
``depot braking montecarlo [--runs N] [--control deceleration|speed] [--png FILE]``
    Monte Carlo of the braking-distance error with ±10 % speed error (eq. 9),
    the empirical bound, and a histogram PNG (matplotlib, Agg).
``depot motion-tables [--json]``
    Table 1 of both papers and the 40 km/h example as computed, beside the
    printed values.
"""

from __future__ import annotations

import argparse
import json
import math
from pathlib import Path
from typing import Any

from pydantic import ValidationError

from core.errors import Unprocessable
from motion import braking, optical
from service.commands._braking_parsers import add_braking_parsers
from service.commands._common import COUNT, DepotParser, fail, number
from service.commands._motion_reports import render_histogram_png, tables
from service.trains import braking as braking_api

__all__ = ["build_parser", "main", "register", "render_histogram_png"]


def _print_json(obj: Any) -> None:
    print(json.dumps(obj, indent=2, ensure_ascii=False, allow_nan=False, default=_nan_safe))


def _nan_safe(o: Any) -> Any:
    raise TypeError(f"not JSON serialisable: {type(o).__name__}")


def _clean(obj: Any) -> Any:
    """Replace NaN/inf by None so that the output is strict JSON."""
    if isinstance(obj, float):
        return obj if math.isfinite(obj) else None
    if isinstance(obj, dict):
        return {str(k): _clean(v) for k, v in obj.items()}
    if isinstance(obj, list | tuple):
        return [_clean(v) for v in obj]
    return obj


# ------------------------------------------------------------------ optical-speed
# The options of the quantities motion.optical_limits names in a refusal.
_OPTION = {
    "distance_m": "--distance",
    "pixel_fov_rad": "--pixel-fov",
    "row_time_s": "--row-time",
    "pixel_error_rad": "--pixel-error",
    "rows": "--rows",
    "speed": "--distance, --row-time or --pixel-fov",
}
# The ranges of motion.optical_limits (speed_from_image checks them too).
_OPT = optical.OPTICAL_LIMITS
DISTANCE = number(low=0, low_open=True, high=_OPT.max_distance_m)
PIXEL_ANGLE = number(low=_OPT.min_pixel_fov_rad, high=_OPT.max_pixel_fov_rad)
ROW_TIME = number(low=_OPT.min_row_time_s, high=_OPT.max_row_time_s)


def _cmd_optical_speed(args: argparse.Namespace) -> int:
    import cv2

    path = Path(args.image)
    if not path.is_file():
        return fail(f"no such image: {path} (give the path of a PNG or JPEG frame)")
    img = cv2.imread(str(path), cv2.IMREAD_GRAYSCALE)
    if img is None:
        return fail(f"cannot read image: {path} (expected a PNG or JPEG file)")
    try:
        r = optical.speed_from_image(
            img,
            distance_m=args.distance,
            pixel_fov_rad=args.pixel_fov,
            row_time_s=args.row_time,
            rows=args.rows,
            pixel_error_rad=args.pixel_error,
        )
    except optical.OpticalRangeError as e:
        return fail(f"{_OPTION.get(e.field, e.field)}: {e}")
    except ValueError as e:
        return fail(f"{e} (the image must show bright vertical stripes; check --pixel-fov)")
    if args.json:
        _print_json(_clean({"image": str(path), **r.as_dict()}))
    else:
        print(
            f"speed {r.speed_kmh:.2f} km/h ({r.speed_mps:.3f} m/s) "
            f"± {r.sigma_kmh:.2f} km/h (eq. 15); "
            f"smear {r.smear_px:.1f} px over {r.rows} rows; {r.tracks} stripe edges; "
            f"direction {r.direction:+d}"
        )
    return 0


# ------------------------------------------------------------------ braking
def _cmd_trials(args: argparse.Namespace) -> int:
    try:
        n = braking.trials_needed(args.p_max, args.beta)
    except ValueError as e:
        return fail(str(e))
    printed = braking.PAPER_TABLE1.get((args.p_max, args.beta))
    out = {"p_max": args.p_max, "beta": args.beta, "trials": n, "paper_printed": printed}
    if args.json:
        _print_json(out)
    else:
        note = "" if printed is None or printed == n else f"  (the paper prints {printed})"
        print(
            f"{n} trials without exceedance claim p ≤ {args.p_max:g} "
            f"at confidence {args.beta:g}{note}"
        )
    return 0


def _cmd_exceedance(args: argparse.Namespace) -> int:
    try:
        p = braking.exceedance(args.p_max, args.k, args.channels)
        k_sil4 = braking.measurements_needed(args.p_max, braking.SIL4, args.channels)
    except ValueError as e:
        return fail(str(e))
    out = {
        "p_max": args.p_max,
        "k": args.k,
        "channels": args.channels,
        "exceedance": p,
        "meets_sil4": p <= braking.SIL4 * (1 + 1e-9),
        "k_for_sil4": k_sil4,
    }
    if args.json:
        _print_json(out)
    else:
        print(
            f"smallest of {args.k} measurement(s) in each of {args.channels} channel(s): "
            f"exceedance {p:.3g}; SIL-4 (1e-8) needs k = {k_sil4} per channel"
        )
    return 0


def _speed_arg(args: argparse.Namespace) -> float:
    if args.speed_kmh is not None:
        return float(args.speed_kmh) / 3.6
    return float(args.speed)


def _plan_request(args: argparse.Namespace) -> braking_api.BrakingPlanIn:
    """The endpoint's request from the command's options (their names differ)."""
    errors = braking_api.ErrorModelIn(
        delta_s_max_m=args.delta_s_max,
        p_s=args.p_s,
        delta_l_max_m=args.delta_l_max,
        p_l=args.p_l,
        measurements=args.k,
        channels=args.channels,
        measurement_time_s=args.measurement_time,
    )
    return braking_api.BrakingPlanIn(
        speed_mps=_speed_arg(args),
        deceleration_mps2=args.decel,
        reaction_time_s=args.reaction_time,
        gradient_permille=args.gradient,
        errors=errors,
        obstacle_at_m=args.obstacle_at,
    )


def _cmd_plan(args: argparse.Namespace) -> int:
    try:
        plan = braking_api.plan(_plan_request(args))
    except ValidationError as e:  # the option parsers refuse these first; kept as a refusal
        return fail(e.errors()[0]["msg"])
    except Unprocessable as e:
        return fail(e.detail)
    if args.json:
        _print_json(_clean(plan.model_dump()))
    else:
        print(
            f"braking distance      {plan.braking_distance_m:9.1f} m  "
            f"(reaction {plan.reaction_distance_m:.1f} m)"
        )
        print(f"ΔS_max                {plan.delta_s_max_m:9.1f} m")
        print(f"ΔL_max (+ run during k measurements) {plan.delta_l_max_m:.1f} m")
        print(f"protective section    {plan.protective_section_m:9.1f} m")
        print(f"brake when measured distance ≤ {plan.brake_at_measured_distance_m:.1f} m")
        if plan.brake_start_coordinate_m is not None:
            print(
                f"braking start point   {plan.brake_start_coordinate_m:9.1f} m (track coordinate)"
            )
        print(
            f"collision probability < {plan.collision_probability_bound:.3g} "
            f"({'meets' if plan.meets_sil4 else 'does not meet'} SIL-4 1e-8)"
        )
    return 0


def _cmd_montecarlo(args: argparse.Namespace) -> int:
    try:
        r = braking.braking_error_monte_carlo(
            args.runs,
            control=args.control,
            speed_mps=_speed_arg(args),
            beta=args.beta,
            seed=args.seed,
        )
    except ValueError as e:
        return fail(str(e))
    png = render_histogram_png(r, args.png) if args.png else None
    d = r.as_dict()
    d["png"] = None if png is None else str(png)
    if args.json:
        _print_json(_clean(d))
    else:
        print(
            f"{r.runs} runs, braking by {r.control}, "
            f"nominal braking distance {r.nominal_distance_m:.1f} m"
        )
        print(
            f"error range {r.min_m:.2f} … {r.max_m:.2f} m, "
            f"mean {r.mean_m:.2f} m, sd {r.std_m:.2f} m"
        )
        print(
            f"empirical bound ΔS_max = {r.delta_s_max_m:.2f} m, exceeded with p ≤ {r.p_exceed:.2e} "
            f"at confidence {r.beta:g}"
        )
        print(
            "trials needed at this confidence: "
            + ", ".join(f"p {k}: {v}" for k, v in r.trials_for.items())
        )
        if r.fit is not None:
            print(
                f"Pearson type I fit: α={r.fit.alpha:.2f} β={r.fit.beta:.2f} on "
                f"[{r.fit.lower:.2f}, {r.fit.upper:.2f}] m, χ²={r.fit.chi2:.2f} (dof {r.fit.dof}, "
                f"p={r.fit.p_value:.2f})"
            )
        else:
            print("no Pearson type I fit: the sample moments are outside the type I region")
        if png is not None:
            print(f"histogram written to {png}")
    return 0


def _cmd_tables(args: argparse.Namespace) -> int:
    t = tables()
    if args.json:
        _print_json(_clean(t))
        return 0
    print("000 (Starovoitov & Vorobiev), Table 1 — computed [printed]")
    print(
        f"{'meter':18s} {'D1':>6s} {'σD1':>12s} {'D2':>6s} {'σD2':>12s} "
        f"{'σv m/s':>14s} {'σv km/h':>14s}"
    )
    for r in t["000_table1"]:
        p = r["printed"]

        def cell(v: float, key: str, p: dict[str, float] | None = p) -> str:
            return f"{v:.2f} [{p[key]:.2f}]" if p else f"{v:.3f}"

        print(
            f"{r['meter']:18s} {r['d1_m']:6.2f} {cell(r['sigma_d1_m'], 'sigma_d1_m'):>12s} "
            f"{r['d2_m']:6.2f} {cell(r['sigma_d2_m'], 'sigma_d2_m'):>12s} "
            f"{cell(r['sigma_v_mps'], 'sigma_v_mps'):>14s} "
            f"{cell(r['sigma_v_kmh_paper_style'], 'sigma_v_kmh'):>14s}"
        )
    print("  stereo: the paper's convention (Δω in metres in eq. 4); stereo_consistent: f·Δω.")
    print("  σv km/h as printed = rounded m/s × 3.6.")
    e = t["000_example_40kmh"]
    print(
        f"40 km/h on 1 m stripes at 1 m: h = {e['rows']} rows, smear {e['smear_px']:.1f} px "
        f"[{e['smear_px_printed']}]; eq. 15 σv {e['sigma15_mps']:.4f} m/s; eq. 16 over 45 s "
        f"max {e['max_sigma16_mps']:.3f} m/s = {e['max_sigma16_kmh']:.3f} km/h "
        f"[≤ {e['bound_printed_mps']} m/s, {e['bound_printed_kmh']} km/h]"
    )
    print()
    print("001 (Baranov et al.), Table 1 — trials n = ⌈lg(1-β)/lg(1-p)⌉ [printed]")
    for r in t["001_table1"]:
        flag = "" if r["matches"] else "   ← differs from the printed table"
        print(
            f"  p_max {r['p_max']:.0e}  β {r['beta']:<6g} "
            f"{r['computed']:>9d} [{r['printed']}]{flag}"
        )
    return 0


# ------------------------------------------------------------------ wiring
def register(sub: Any) -> None:
    """Add ``optical-speed``, ``braking`` and ``motion-tables`` to an
    ``argparse`` sub-parsers object."""
    p = sub.add_parser(
        "optical-speed", help="speed from a rolling-shutter image of vertical stripes"
    )
    p.add_argument("image", metavar="IMAGE", help="the frame: JPEG or PNG, rows read top to bottom")
    p.add_argument(
        "--distance", type=DISTANCE, required=True, metavar="M", help="distance to the stripes, m"
    )
    p.add_argument(
        "--pixel-fov",
        type=PIXEL_ANGLE,
        required=True,
        metavar="RAD",
        help="angle of one pixel β, rad",
    )
    p.add_argument(
        "--row-time", type=ROW_TIME, required=True, metavar="S", help="row read-out time t_c, s"
    )
    p.add_argument(
        "--rows",
        type=COUNT,
        default=None,
        metavar="N",
        help="rows h, at most the frame's height (default: the stripe band's height)",
    )
    p.add_argument(
        "--pixel-error",
        type=PIXEL_ANGLE,
        default=None,
        metavar="RAD",
        help="pixel discreteness Δω, rad (default: β/2)",
    )
    p.add_argument("--json", action="store_true", help="print JSON instead of text")
    p.set_defaults(func=_cmd_optical_speed)

    _register_braking(sub)

    mt = sub.add_parser(
        "motion-tables", help="both papers' tables as computed, beside the printed values"
    )
    mt.add_argument("--json", action="store_true", help="print JSON instead of text")
    mt.set_defaults(func=_cmd_tables)


def _register_braking(sub: Any) -> None:
    parsers = add_braking_parsers(sub)
    parsers["trials"].set_defaults(func=_cmd_trials)
    parsers["exceedance"].set_defaults(func=_cmd_exceedance)
    parsers["plan"].set_defaults(func=_cmd_plan)
    parsers["montecarlo"].set_defaults(func=_cmd_montecarlo)


def build_parser() -> argparse.ArgumentParser:
    parser = DepotParser(prog="depot", description="depot motion commands")
    register(parser.add_subparsers(dest="command", required=True))
    return parser


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    rc: int = args.func(args)
    return rc


if __name__ == "__main__":
    raise SystemExit(main())
