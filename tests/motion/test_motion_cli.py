"""The motion CLI commands (service/commands/motion.py)."""

from __future__ import annotations

import json
from pathlib import Path

import cv2
import pytest

from motion import optical
from service.commands import motion as cmd


def _run(capsys: pytest.CaptureFixture[str], *argv: str) -> tuple[int, str]:
    rc = cmd.main(list(argv))
    return rc, capsys.readouterr().out


def test_optical_speed_json(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    img = optical.render_stripes(60 / 3.6, seed=9)
    path = tmp_path / "stripes.png"
    assert cv2.imwrite(str(path), img)
    rc, out = _run(
        capsys,
        "optical-speed",
        str(path),
        "--distance",
        "1",
        "--pixel-fov",
        "0.00094",
        "--row-time",
        "1e-4",
        "--json",
    )
    assert rc == 0
    d = json.loads(out)
    assert d["speed_kmh"] == pytest.approx(60, rel=0.02)
    assert d["sigma_mps"] > 0 and d["rows"] > 800
    rc, out = _run(
        capsys,
        "optical-speed",
        str(path),
        "--distance",
        "1",
        "--pixel-fov",
        "0.00094",
        "--row-time",
        "1e-4",
    )
    assert rc == 0 and "km/h" in out


def test_optical_speed_bad_input(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert (
        cmd.main(
            [
                "optical-speed",
                str(tmp_path / "none.png"),
                "--distance",
                "1",
                "--pixel-fov",
                "1e-3",
                "--row-time",
                "1e-4",
            ]
        )
        == 2
    )
    junk = tmp_path / "junk.png"
    junk.write_bytes(b"not an image")
    assert (
        cmd.main(
            [
                "optical-speed",
                str(junk),
                "--distance",
                "1",
                "--pixel-fov",
                "1e-3",
                "--row-time",
                "1e-4",
            ]
        )
        == 2
    )
    flat = tmp_path / "flat.png"
    cv2.imwrite(str(flat), (optical.render_stripes(0.0, seed=1) * 0).astype("uint8"))
    assert (
        cmd.main(
            [
                "optical-speed",
                str(flat),
                "--distance",
                "1",
                "--pixel-fov",
                "1e-3",
                "--row-time",
                "1e-4",
            ]
        )
        == 2
    )


def test_braking_subcommands(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    rc, out = _run(capsys, "braking", "trials", "--p-max", "0.01", "--beta", "0.9", "--json")
    assert rc == 0 and json.loads(out) == {
        "p_max": 0.01,
        "beta": 0.9,
        "trials": 230,
        "paper_printed": 229,
    }
    rc, out = _run(
        capsys, "braking", "exceedance", "--p-max", "0.01", "-k", "2", "--channels", "2", "--json"
    )
    d = json.loads(out)
    assert d["exceedance"] == pytest.approx(1e-8) and d["meets_sil4"]
    rc, out = _run(
        capsys,
        "braking",
        "plan",
        "--speed-kmh",
        "72",
        "--decel",
        "0.8",
        "--reaction-time",
        "2",
        "--delta-l-max",
        "40",
        "-k",
        "3",
        "--measurement-time",
        "0.5",
        "--obstacle-at",
        "5000",
        "--json",
    )
    d = json.loads(out)
    assert d["protective_section_m"] == pytest.approx(3.0 + 40.0 + 20.0 * 1.5)
    assert d["meets_sil4"]
    png = tmp_path / "hist.png"
    rc, out = _run(capsys, "braking", "montecarlo", "--runs", "230", "--png", str(png), "--json")
    assert rc == 0
    d = json.loads(out)
    assert d["runs"] == 230 and d["png"] == str(png) and d["p_exceed"] <= 0.01
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert cv2.imread(str(png)) is not None
    assert _refused(["braking", "trials", "--p-max", "2", "--beta", "0.9"]) == 2


def test_motion_tables(capsys: pytest.CaptureFixture[str]) -> None:
    rc, out = _run(capsys, "motion-tables")
    assert rc == 0
    assert "0.93 [0.93]" in out and "3.35 [3.35]" in out and "1.91 [1.91]" in out
    assert "230 [229]" in out and "2302584 [2302534]" in out
    assert "796" in out
    rc, out = _run(capsys, "motion-tables", "--json")
    d = json.loads(out)
    assert sum(not r["matches"] for r in d["001_table1"]) == 2
    assert round(d["000_example_40kmh"]["smear_px"]) == 796
    assert d["000_example_40kmh"]["max_sigma16_kmh"] <= 0.47


def test_register_into_an_existing_parser() -> None:
    import argparse

    parser = argparse.ArgumentParser(prog="depot")
    sub = parser.add_subparsers(dest="command")
    sub.add_parser("serve")
    cmd.register(sub)
    args = parser.parse_args(["braking", "trials", "--p-max", "1e-4", "--beta", "0.99"])
    assert args.func(args) == 0


# shared/data/real beside the repository (its checkout, or a worktree of it further down:
# parents[2].parent found nothing from /work/wt/<branch>, and the real frames went untested)
REAL_FRAMES = next(
    (p / "shared" / "data" / "real" for p in Path(__file__).resolve().parents
     if (p / "shared" / "data" / "real").is_dir()),
    Path("/nonexistent"),
)  # fmt: skip


def _scene_without_stripes(seed: int) -> object:
    """A photo-like frame: blurred blobs and edges at every angle, no stripe pattern."""
    import numpy as np

    rng = np.random.default_rng(seed)
    img = np.full((720, 1280), 90, np.uint8)
    for _ in range(60):
        centre = (int(rng.integers(0, 1280)), int(rng.integers(0, 720)))
        axes = (int(rng.integers(10, 200)), int(rng.integers(10, 200)))
        cv2.ellipse(
            img, centre, axes, float(rng.uniform(0, 180)), 0, 360, int(rng.integers(0, 256)), -1
        )
    return cv2.GaussianBlur(img, (0, 0), 2.0)


def test_optical_speed_refuses_a_photo_without_stripes(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """Found by the trial: a photo with no stripes was answered '1.80 km/h ± 0.19'."""
    images = [tmp_path / f"scene{seed}.png" for seed in (1, 2, 3)]
    for seed, path in zip((1, 2, 3), images, strict=True):
        assert cv2.imwrite(str(path), _scene_without_stripes(seed))
    real = sorted((REAL_FRAMES / "railsem19_frames").glob("*.jpg"))[:6]  # real photos
    assert real or not REAL_FRAMES.exists()
    images += real
    for path in images:
        argv = ["optical-speed", str(path), "--distance", "1", "--pixel-fov", "0.00094"]
        rc = cmd.main([*argv, "--row-time", "1e-4"])
        captured = capsys.readouterr()
        assert rc == 2, f"{path.name}: answered {captured.out!r}"
        assert captured.err.startswith("depot: no stripes found"), captured.err
        assert "km/h" not in captured.out


def test_plan_names_why_a_train_would_not_stop(capsys: pytest.CaptureFixture[str]) -> None:
    """``--decel 0`` on the level blamed "the downhill gradient" (found by the second trial)."""
    assert _refused(["braking", "plan", "--speed", "10", "--decel", "0"]) == 2
    err = capsys.readouterr().err
    assert "--decel" in err or "deceleration must be a finite number in (0, " in err, err
    downhill = ["braking", "plan", "--speed", "10", "--decel", "0.1", "--gradient", "-30"]
    assert cmd.main(downhill) == 2
    assert "downhill gradient (-30 ‰)" in capsys.readouterr().err


def _refused(argv: list[str]) -> int:
    """The exit code of a refusal, whether the option's range (argparse) or the command said it."""
    try:
        return cmd.main(argv)
    except SystemExit as stopped:
        return int(stopped.code or 0)
