"""Hostile numbers on the motion commands (found by the independent trial):
``optical-speed --distance 1e300`` answered 4e301 km/h, ``--rows`` beyond the frame an
extrapolated smear, ``--row-time 1e-300`` 4e300 km/h, ``braking montecarlo --runs 1``
passed the option and was refused by the study in other words.  Each is one ``depot:``
line naming the option and its range (``motion.optical_limits``,
``motion.braking_limits``), exit 2, never a traceback, inf or nan.
"""

from __future__ import annotations

from pathlib import Path

import cv2
import pytest

from motion import optical
from service.commands import motion as cmd

BETA, T_C = "0.00094", "1e-4"


@pytest.fixture(scope="module")
def frame(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("frames") / "stripes.png"
    assert cv2.imwrite(str(path), optical.render_stripes(40 / 3.6, seed=1))
    return path


def _run(argv: list[str], capsys: pytest.CaptureFixture[str]) -> tuple[int, str, str]:
    try:
        rc = cmd.main(argv)
    except SystemExit as stopped:
        rc = int(stopped.code or 0)
    out = capsys.readouterr()
    return rc, out.out, out.err


def _refused(rc: int, out: str, err: str, *named: str) -> None:
    assert rc == 2, (out, err)
    assert err.startswith("depot: ") and len(err.strip().splitlines()) == 1, err
    assert "Traceback" not in err and "km/h" not in out
    for word in named:
        assert word in err, err
    for bad in ("inf", "nan"):
        assert bad not in out.lower() and f" {bad}" not in err.lower(), err


@pytest.mark.parametrize(
    ("option", "value", "named"),
    [
        ("--distance", "1e300", ("--distance", "100")),
        ("--row-time", "1e-300", ("--row-time", "1e-08")),
        ("--pixel-fov", "1e-300", ("--pixel-fov",)),
        ("--pixel-fov", "3", ("--pixel-fov", "0.01")),
        ("--rows", "100000", ("--rows", "1080", "frame")),
    ],
)
def test_optical_speed_refuses_numbers_out_of_range(
    frame: Path,
    option: str,
    value: str,
    named: tuple[str, ...],
    capsys: pytest.CaptureFixture[str],
) -> None:
    argv = {"--distance": "1", "--pixel-fov": BETA, "--row-time": T_C}
    argv[option] = value
    flat = [a for kv in argv.items() for a in kv]
    rc, out, err = _run(["optical-speed", str(frame), *flat, "--json"], capsys)
    _refused(rc, out, err, *named)


def test_a_speed_beyond_any_train_is_refused_naming_the_inputs(
    frame: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """Each input in range, together 40 km/h × 50 / 1e-3: the geometry given is wrong."""
    argv = ["optical-speed", str(frame), "--distance", "50", "--pixel-fov", BETA]
    rc, out, err = _run([*argv, "--row-time", "1e-7"], capsys)
    _refused(rc, out, err, "beyond any train", "--row-time")


def test_the_rows_within_the_frame_are_still_measured(
    frame: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    argv = ["optical-speed", str(frame), "--distance", "1", "--pixel-fov", BETA]
    rc, out, err = _run([*argv, "--row-time", T_C, "--rows", "836"], capsys)
    assert rc == 0 and "km/h" in out, err


def test_the_domain_refuses_as_the_command_does() -> None:
    img = optical.render_stripes(40 / 3.6, seed=1)
    with pytest.raises(optical.OpticalRangeError, match="distance_m") as refused:
        optical.speed_from_image(img, distance_m=1e300, pixel_fov_rad=9.4e-4, row_time_s=1e-4)
    assert refused.value.field == "distance_m"
    with pytest.raises(optical.OpticalRangeError, match=r"rows must .* \[1, 1080\]"):
        optical.speed_from_image(
            img, distance_m=1.0, pixel_fov_rad=9.4e-4, row_time_s=1e-4, rows=5000
        )


@pytest.mark.parametrize(
    ("argv", "named"),
    [
        (["braking", "montecarlo", "--runs", "1"], ("--runs", "at least 2")),
        (["braking", "exceedance", "--p-max", "0.0", "-k", "2"], ("--p-max", "more than 0")),
        (["braking", "trials", "--p-max", "1e-2", "--beta", "0"], ("--beta",)),
        (["braking", "plan", "--speed", "1e300", "--decel", "1"], ("--speed", "150")),
        (["braking", "plan", "--speed", "10", "--decel", "1", "-k", "1000"], ("-k", "100")),
    ],
)
def test_braking_refuses_numbers_out_of_range(
    argv: list[str], named: tuple[str, ...], capsys: pytest.CaptureFixture[str]
) -> None:
    rc, out, err = _run([*argv, "--json"], capsys)
    _refused(rc, out, err, *named)


def test_montecarlo_at_its_smallest_answers_finite_numbers(
    capsys: pytest.CaptureFixture[str],
) -> None:
    rc, out, err = _run(["braking", "montecarlo", "--runs", "2", "--json"], capsys)
    assert rc == 0, err
    assert "NaN" not in out and "Infinity" not in out
