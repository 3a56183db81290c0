"""CLI commands (tail-check, calibrate, tail-study, tail-synth) and the generator."""

from __future__ import annotations

import csv
import json
from pathlib import Path

import cv2
import numpy as np
import pytest

from tail_check import CameraProfile
from tail_check.synth import CONDITIONS, render_snapshot, write_study_set
from tests.tail_check.tailkit import plain_disc_scene, run_tail_command

_run = run_tail_command


@pytest.fixture(scope="module")
def study_dir(tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("study")
    assert _run(["tail-synth", str(out), "--count", "24", "--seed", "3", "--size", "480x360"]) == 0
    return out


def test_tail_synth_writes_images_and_labels(study_dir: Path) -> None:
    rows = list(csv.DictReader((study_dir / "labels.csv").open(encoding="utf-8")))
    assert len(rows) == 24 and all((study_dir / r["file"]).is_file() for r in rows)
    with_disc = [r for r in rows if r["disc"] == "1"]
    assert with_disc and all(float(r["s_ref"]) > 0 for r in with_disc)


def test_tail_check_json_prints_one_object_per_file(study_dir: Path, capsys) -> None:
    files = sorted(str(p) for p in study_dir.glob("snap_000*.png"))
    assert _run(["tail-check", *files, "--json"]) == 0
    lines = capsys.readouterr().out.strip().splitlines()
    assert len(lines) == len(files)
    for line, name in zip(lines, files, strict=True):
        record = json.loads(line)
        assert record["file"] == name
        assert record["verdict"] in ("present", "absent", "uncertain")
        assert 0 <= record["score"] <= 1 and record["pixel_fraction"] >= 0
        assert record["bbox"] is None or len(record["bbox"]) == 4


def test_tail_check_errors_return_2(tmp_path: Path, capsys) -> None:
    assert _run(["tail-check", str(tmp_path / "missing.jpg"), "--json"]) == 2
    assert "cannot read image" in capsys.readouterr().err
    bad = tmp_path / "p.json"
    bad.write_text('{"c_delta": -1}', encoding="utf-8")
    assert _run(["tail-check", "x.jpg", "--profile", str(bad)]) == 2
    assert "c_delta" in capsys.readouterr().err


def test_calibrate_prints_a_profile_that_detects(tmp_path: Path, capsys) -> None:
    image, label = plain_disc_scene()
    path = tmp_path / "cal.png"
    cv2.imwrite(str(path), image)
    x, y = label.reference_point  # type: ignore[misc]
    out = tmp_path / "cam.json"
    assert _run(["calibrate", str(path), "--disc", f"{x},{y}", "--out", str(out)]) == 0
    profile = CameraProfile.from_json(capsys.readouterr().out)
    assert profile == CameraProfile.from_json(out.read_text(encoding="utf-8"))
    assert _run(["tail-check", str(path), "--profile", str(out), "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["verdict"] == "present"
    assert _run(["calibrate", str(path), "--disc", "3,3"]) == 2
    with pytest.raises(SystemExit):
        _run(["calibrate", str(path), "--disc", "12"])


def test_tail_study_prints_table_and_writes_plot(study_dir: Path, capsys) -> None:
    plot = study_dir / "eps.png"
    assert (
        _run(
            [
                "tail-study",
                str(study_dir),
                "--labels",
                str(study_dir / "labels.csv"),
                "--plot",
                str(plot),
            ]
        )
        == 0
    )
    text = capsys.readouterr().out
    assert "gaussian" in text and "lowest mean" in text
    png = cv2.imread(str(plot))
    assert png is not None and png.shape[0] > 100
    assert _run(["tail-study", str(study_dir / "nowhere")]) == 2


def test_generator_is_reproducible_and_labels_are_consistent() -> None:
    a, la = render_snapshot(123, disc=True, condition="night", weak_disc=True, size=(320, 240))
    b, lb = render_snapshot(123, disc=True, condition="night", weak_disc=True, size=(320, 240))
    assert np.array_equal(a, b) and la == lb
    assert a.shape == (240, 320, 3) and a.dtype == np.uint8
    x, y, w, h = la.bbox  # type: ignore[misc]
    assert x >= 0 and x + w <= 320 and y >= 0 and y + h <= 240
    assert la.disc_fraction == pytest.approx(0, abs=0.05) and la.disc_fraction > 0
    _, none = render_snapshot(5, disc=False, condition="fog")
    assert not none.disc and none.bbox is None and none.disc_fraction == 0


@pytest.mark.parametrize("condition", CONDITIONS)
def test_every_condition_renders(condition: str) -> None:
    image, label = render_snapshot(9, disc=True, condition=condition, size=(160, 120))
    assert image.shape == (120, 160, 3) and label.condition == condition


def test_generator_rejects_bad_arguments(tmp_path: Path) -> None:
    with pytest.raises(ValueError, match="condition"):
        render_snapshot(1, disc=True, condition="hail")
    with pytest.raises(ValueError, match="car colour"):
        render_snapshot(1, disc=True, condition="day", car_colour="purple")
    with pytest.raises(ValueError, match="size"):
        render_snapshot(1, disc=True, condition="day", size=(10, 10))
    with pytest.raises(ValueError, match="count"):
        write_study_set(tmp_path, 0)
