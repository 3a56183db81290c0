"""CLI commands of the tail check: tail-check, calibrate, tail-study, tail-synth.

Registered into ``depot`` by ``service.cli`` through :func:`register`.
"""

from __future__ import annotations

import argparse
import csv
import json
import re
from collections.abc import Iterator
from pathlib import Path

import numpy as np

from service.commands._common import (
    SEED,
    fail,
    number,
    values_may_look_negative,
    writable,
    write_file,
)
from service.commands._image_files import decoders_quiet, read_bytes, read_image, unreadable
from tail_check import (
    DEFAULT_PROFILE,
    CameraProfile,
    DetectionResult,
    UndecodableImage,
    calibrate,
    detect_snapshot,
    load_profile,
)
from tail_check.study import StudyResult, StudySample, epsilon_curves
from tail_check.synth import write_study_set

__all__ = ["register"]


def _profile(path: str | None) -> CameraProfile:
    return DEFAULT_PROFILE if path is None else load_profile(path)


def _judge(path: str, profile: CameraProfile) -> DetectionResult:
    """The service's verdict on the file's bytes: ``detect_snapshot`` (a JPEG decoded at
    reduced size, EXIF orientation ignored, a ``present`` confirmed by the learned verifiers,
    as ``detect_confirmed``). ``cv2.imread`` turned EXIF-rotated JPEGs and judged truncated
    ones (filled grey), which the service refuses.

    Raises
    ------
    ValueError
        With depot's message: the file cannot be read, decoded or judged.
    """
    data = read_bytes(path)
    try:
        with decoders_quiet():
            return detect_snapshot(data, profile)
    except UndecodableImage as exc:
        raise unreadable(path, exc) from None
    except ValueError as exc:
        raise ValueError(f"cannot judge image {path!r}: {exc}") from None


def _tail_check(args: argparse.Namespace) -> int:
    try:
        profile = _profile(args.profile)
    except ValueError as exc:
        return fail(f"{exc}; pass a profile written by `depot calibrate`")
    failed = False
    for name in args.files:
        try:
            result = _judge(name, profile)
        except ValueError as exc:
            fail(str(exc))
            failed = True
            continue
        record = {"file": name, **result.to_dict()}
        if args.json:
            print(json.dumps(record))
        else:
            box = "-" if result.bbox is None else "x".join(str(v) for v in result.bbox)
            print(
                f"{name}: {result.verdict} score={result.score:.2f} bbox={box} "
                f"s^={result.pixel_fraction:.5f}"
            )
    return 2 if failed else 0


def _parse_point(text: str) -> tuple[float, float]:
    parts = text.split(",")
    try:
        if len(parts) != 2:
            raise ValueError
        return float(parts[0]), float(parts[1])
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected X,Y pixel coordinates, got {text!r}") from None


def _profile_name(text: str) -> str:
    if not text.strip():
        raise argparse.ArgumentTypeError(
            f"{text!r} is empty; name the camera, e.g. --name platform-3-east"
        )
    return text


# "-1,10" is a point for --disc (then refused as outside the image): calibrate has no option
# that looks like a number.
_NEGATIVE_VALUE = re.compile(r"^-\.?\d")


def _calibrate(args: argparse.Namespace) -> int:
    out = Path(args.out) if args.out else None
    problem = None if out is None else writable(out, "--out", "camera.json")
    if problem is not None:
        return fail(problem)
    try:
        base = _profile(args.base)
    except ValueError as exc:
        return fail(
            f"{exc}; --base must be a profile written by `depot calibrate`"
            " (leave it out for the standard signal red)"
        )
    try:
        profile = calibrate(read_image(args.image), args.disc, base=base, name=args.name)
    except ValueError as exc:
        return fail(f"{exc}; give a snapshot with the disc visible and --disc X,Y inside it")
    text = profile.to_json()
    problem = None if out is None else write_file(out, text + "\n", "--out")
    if problem is not None:
        return fail(problem)
    print(text)
    return 0


def _study_samples(directory: Path, labels: Path) -> Iterator[StudySample]:
    with labels.open(newline="", encoding="utf-8") as fh:
        for row in csv.DictReader(fh):
            missing = {"file", "s_ref", "ref_x", "ref_y", "x", "y", "w", "h"} - set(row)
            if missing:
                raise ValueError(f"labels file lacks column(s) {', '.join(sorted(missing))}")
            if not row["ref_x"] or float(row["s_ref"] or 0) <= 0:
                continue
            image = read_image(str(directory / row["file"]))
            point = (int(float(row["ref_x"])), int(float(row["ref_y"])))
            box = (int(row["x"]), int(row["y"]), int(row["w"]), int(row["h"]))
            yield StudySample(image, float(row["s_ref"]), point, box, row.get("condition", ""))


def _plot(result: StudyResult, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6.4, 4.2), dpi=110)
    x = [100 * d for d in result.deltas]
    for kind, errors in result.mean_error.items():
        ax.plot(x, [100 * e for e in errors], marker="o", ms=3, label=kind)
    ax.set_xlabel("c_Δ, % of mean c_ref")
    ax.set_ylabel("mean ε = |s_ref − ŝ|, % of disc neighbourhood")
    ax.set_title(f"ε(c_Δ) for box / disk / Gaussian low-pass, {result.count} images")
    ax.axvline(25, color="grey", lw=0.8, ls="--")
    ax.grid(alpha=0.3)
    ax.legend()
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)


def _tail_study(args: argparse.Namespace) -> int:
    directory = Path(args.directory)
    labels = Path(args.labels) if args.labels else directory / "labels.csv"
    if not directory.is_dir():
        return fail(f"{directory} is not a folder; give the folder of labelled snapshots")
    if not labels.is_file():
        return fail(f"labels file {labels} not found; pass --labels (or run `depot tail-synth`)")
    plot = Path(args.plot) if args.plot else directory / "epsilon.png"
    problem = writable(plot, "--plot", "epsilon.png")
    if problem is not None:
        return fail(problem)
    try:
        result = epsilon_curves(_study_samples(directory, labels), kernel_fraction=args.kernel)
    except (ValueError, KeyError) as exc:
        return fail(f"{exc}; the labels need columns file,x,y,w,h,s_ref,ref_x,ref_y")
    _plot(result, plot)
    print(result.table())
    print(f"\nimages: {result.count}; filter size N = {result.kernel_size} px (working scale)")
    # The summary is computed from the printed (rounded) table, so it always names the
    # table's own minimum.
    cells = [
        (round(100 * e, 4), kind, round(100 * d))
        for kind, errors in result.mean_error.items()
        for d, e in zip(result.deltas, errors, strict=True)
    ]
    low, low_kind, low_delta = min(cells)
    print(f"lowest mean ε in the table: {low_kind} at c_Δ = {low_delta} % ({low:.4f} %)")
    print(f"best filter at the paper's c_Δ = 25 %: {result.best_filter(0.25)}")
    for kind, errors in result.mean_error.items():
        i = int(np.argmin(errors))
        print(
            f"  {kind:8s} minimum mean ε {100 * errors[i]:.4f} % at c_Δ = "
            f"{100 * result.deltas[i]:.0f} %"
        )
    print(f"plot: {plot}")
    return 0


# tail-synth's bounds: a 4096x4096 scene is 48 MiB per working image (100000x100000 asked for
# 112 GiB); more than this many images is a typing slip rather than a study set.
MAX_SYNTH_SIDE = 4096
MAX_SYNTH_COUNT = 100_000
SYNTH_COUNT = number(int, low=1, high=MAX_SYNTH_COUNT)
KERNEL = number(low=0, high=1, low_open=True)  # a fraction of sqrt(W*H)
# tail-train's bounds: generator B renders about one scene a second, so 100000 scenes per
# split is already a day of rendering.
MAX_TRAIN_COUNT = 100_000
TRAIN_COUNT = number(int, low=1, high=MAX_TRAIN_COUNT)


def _parse_size(text: str) -> tuple[int, int] | None:
    """``WIDTHxHEIGHT`` as two integers from 1 to MAX_SYNTH_SIDE, or None when it is not."""
    match = re.fullmatch(r"\s*(\d+)\s*[xX×]\s*(\d+)\s*", text)
    if match is None:
        return None
    w, h = int(match.group(1)), int(match.group(2))
    return (w, h) if 0 < w <= MAX_SYNTH_SIDE and 0 < h <= MAX_SYNTH_SIDE else None


def _tail_synth(args: argparse.Namespace) -> int:
    size = _parse_size(args.size)
    if size is None:
        return fail(
            f"--size {args.size!r} is not WIDTHxHEIGHT in pixels from 1x1 to"
            f" {MAX_SYNTH_SIDE}x{MAX_SYNTH_SIDE}; e.g. --size 640x480"
        )
    out = Path(args.directory)
    if out.exists() and not out.is_dir():
        return fail(f"{out} is not a folder; give a folder for the snapshots")
    if out.is_dir() and any(out.iterdir()) and not args.force:
        return fail(
            f"{out} is not empty (old snapshots would mix with the new set); "
            "choose an empty folder or pass --force to write into it"
        )
    try:
        labels = write_study_set(out, args.count, seed=args.seed, size=size)
    except ValueError as exc:
        return fail(f"{exc}; e.g. --count 100 --size 640x480")
    print(f"wrote {args.count} snapshots and {labels}")
    return 0


def _tail_train(args: argparse.Namespace) -> int:
    from tail_check.dataset import Generator
    from tail_check.pipeline.train import TrainParams, train

    generators: tuple[Generator, ...] = tuple(g for g in args.generators.upper() if g in ("A", "B"))
    if not generators or len(generators) != len(args.generators):
        return fail(f"--generators must be A, B or AB, got {args.generators!r}")
    out = Path(args.out)
    if out.suffix != ".json":
        return fail(f"--out {out} must end in .json (the model is stored as JSON, never pickle)")
    described = out.with_suffix(".training.json")
    for path in (out, described):
        problem = writable(path, "--out", "model.json")
        if problem is not None:
            return fail(problem)
    params = TrainParams(train_count=args.count, validation_count=args.validation)
    try:
        model = train(generators, seed=args.seed, params=params)
    except ValueError as exc:
        return fail(f"{exc}; train on more scenes (--count)")
    description = json.dumps(model.meta, indent=2)
    written: list[Path] = []
    for path, text in ((out, model.to_json()), (described, description)):
        problem = write_file(path, text + "\n", "--out")
        if problem is not None:
            # a model is never left without the description of what it was trained on
            for done in written:
                done.unlink(missing_ok=True)
            return fail(problem)
        written.append(path)
    print(description)
    print(f"wrote {out} and {described}")
    return 0


def register(subparsers: argparse._SubParsersAction) -> None:  # type: ignore[type-arg]
    """Add the tail-check commands to ``depot``'s sub-command parser."""
    p = subparsers.add_parser("tail-check", help="detect the red tail disc on snapshots")
    p.add_argument("files", nargs="+", metavar="FILE", help="JPEG/PNG snapshots")
    p.add_argument("--profile", help="camera profile JSON (default: standard signal red)")
    p.add_argument("--json", action="store_true", help="one JSON object per file")
    p.set_defaults(func=_tail_check)

    p = subparsers.add_parser("calibrate", help="print a camera profile from a snapshot")
    p.add_argument("image", help="snapshot with the disc visible")
    p.add_argument(
        "--disc",
        required=True,
        type=_parse_point,
        metavar="X,Y",
        help="a pixel inside the disc, in the stored image (EXIF orientation ignored, as the"
        " service does)",
    )
    p.add_argument(
        "--base", help="profile whose other settings to keep (default: standard signal red)"
    )
    p.add_argument("--name", type=_profile_name, default="calibrated", help="profile name")
    p.add_argument("--out", help="also write the profile to this file (default: print only)")
    p.set_defaults(func=_calibrate)
    values_may_look_negative(p, _NEGATIVE_VALUE)

    p = subparsers.add_parser("tail-study", help="ε(c_Δ) study for box/disk/Gaussian filters")
    p.add_argument("directory", metavar="DIR", help="folder of labelled snapshots")
    p.add_argument("--labels", help="labels CSV (default DIR/labels.csv)")
    p.add_argument("--plot", help="PNG plot path (default DIR/epsilon.png)")
    p.add_argument(
        "--kernel",
        type=KERNEL,
        default=0.02,
        help="filter size as a fraction of sqrt(W*H) (default 0.02)",
    )
    p.set_defaults(func=_tail_study)

    p = subparsers.add_parser("tail-synth", help="write generated labelled snapshots")
    p.add_argument("directory", metavar="DIR", help="an empty (or new) folder for the images")
    p.add_argument("--count", type=SYNTH_COUNT, default=100, help="labelled images to write")
    p.add_argument("--seed", type=SEED, default=0, help="random seed of the scenes")
    p.add_argument(
        "--size",
        default="640x480",
        help=f"WIDTHxHEIGHT in pixels, at most {MAX_SYNTH_SIDE}x{MAX_SYNTH_SIDE} (default 640x480)",
    )
    p.add_argument(
        "--force", action="store_true", help="write into a folder that already holds files"
    )
    p.set_defaults(func=_tail_synth)

    p = subparsers.add_parser("tail-train", help="train the tail-disc verifier (JSON model)")
    p.add_argument("--out", required=True, help="model file to write (.json)")
    p.add_argument("--seed", type=SEED, default=0, help="random seed of the training")
    p.add_argument("--generators", default="AB", help="scene generators to train on: A, B or AB")
    p.add_argument("--count", type=TRAIN_COUNT, default=200, help="training scenes per generator")
    p.add_argument(
        "--validation", type=TRAIN_COUNT, default=100, help="validation scenes per generator"
    )
    p.set_defaults(func=_tail_train)
