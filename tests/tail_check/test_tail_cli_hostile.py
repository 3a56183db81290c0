"""Failures an independent hostile-input trial found in the tail-check CLI and profile loader.

Each test failed before its fix: a traceback after the work was done (``calibrate --out``
naming a folder), a verdict the service would not give (``tail-check`` read files with
``cv2.imread``, which turns EXIF-rotated JPEGs and judges truncated ones), numbers in
profiles that are not numbers, and unclear messages.
"""

from __future__ import annotations

import io
import json
import subprocess
import sys
from pathlib import Path

import cv2
import numpy as np
import pytest
from numpy.typing import NDArray
from PIL import Image

import tail_check
from service.cli import main
from tail_check import (
    CameraProfile,
    calibrate,
    decode_snapshot,
    detect,
    detect_snapshot,
    load_profile,
)
from tests.tail_check.tailkit import plain_disc_scene, run_tail_command

# A blue car end with the disc on it; the disc's reference point in stored pixels.
DISC = "413,361"


_run = run_tail_command


@pytest.fixture(scope="module")
def scene() -> NDArray[np.uint8]:
    return plain_disc_scene()[0]


@pytest.fixture()
def png(scene: NDArray[np.uint8], tmp_path: Path) -> Path:
    path = tmp_path / "cal.png"
    cv2.imwrite(str(path), scene)
    return path


def _jpeg(image: NDArray[np.uint8], orientation: int | None = None) -> bytes:
    """``image`` as JPEG bytes, with an EXIF orientation tag when one is given."""
    pil = Image.fromarray(cv2.cvtColor(image, cv2.COLOR_BGR2RGB))
    exif = Image.Exif()
    if orientation is not None:
        exif[0x0112] = orientation
    buf = io.BytesIO()
    pil.save(buf, "JPEG", quality=92, exif=exif.tobytes())
    return buf.getvalue()


# --- 1. calibrate --out / tail-train --out: checked before the work, the write guarded ---


def test_calibrate_out_a_folder_is_refused_before_the_work(
    png: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert _run(["calibrate", str(png), "--disc", DISC, "--out", str(tmp_path)]) == 2
    out, err = capsys.readouterr()
    assert out == ""  # refused before the profile is made, so nothing is printed
    assert err.startswith("depot: ") and "is a folder" in err and "--out" in err, err
    assert len(err.strip().splitlines()) == 1


def test_calibrate_out_in_a_missing_folder_is_refused_before_the_work(
    png: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    target = tmp_path / "missing" / "dir" / "p.json"
    assert _run(["calibrate", str(png), "--disc", DISC, "--out", str(target)]) == 2
    out, err = capsys.readouterr()
    assert out == ""
    assert err.startswith("depot: ") and f"folder {target.parent} does not exist" in err, err
    assert "create it or choose another --out" in err


def test_calibrate_out_under_a_file_is_refused(
    png: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert _run(["calibrate", str(png), "--disc", DISC, "--out", str(png / "p.json")]) == 2
    assert "is not a folder" in capsys.readouterr().err


def test_calibrate_write_failure_is_one_clear_line(
    png: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    def full_disk(*args: object, **kwargs: object) -> int:
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(Path, "write_text", full_disk)
    target = tmp_path / "p.json"
    assert _run(["calibrate", str(png), "--disc", DISC, "--out", str(target)]) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"depot: cannot write {target}: No space left on device"), err


def test_tail_train_out_a_folder_is_refused_before_training(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    import tail_check.pipeline.train as training

    def no_training(*args: object, **kwargs: object) -> None:
        raise AssertionError("tail-train trained before checking --out")

    monkeypatch.setattr(training, "train", no_training)
    folder = tmp_path / "adir.json"
    folder.mkdir()
    assert _run(["tail-train", "--out", str(folder)]) == 2
    err = capsys.readouterr().err
    assert err.startswith("depot: ") and "is a folder" in err, err
    (tmp_path / "m.training.json").mkdir()  # the description's file is checked too
    assert _run(["tail-train", "--out", str(tmp_path / "m.json")]) == 2
    assert "m.training.json is a folder" in capsys.readouterr().err


def test_tail_study_plot_a_folder_is_refused_before_the_study(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    data = tmp_path / "study"
    assert _run(["tail-synth", str(data), "--count", "2", "--size", "160x120"]) == 0
    capsys.readouterr()
    assert _run(["tail-study", str(data), "--plot", str(tmp_path)]) == 2
    out, err = capsys.readouterr()
    assert out == "" and "is a folder" in err and "--plot" in err, err


# --- 2. tail-check judges a file as the service judges its bytes ---


def test_undecodable_image_is_a_value_error_raised_where_decoding_fails(
    scene: NDArray[np.uint8],
) -> None:
    undecodable = tail_check.UndecodableImage
    assert issubclass(undecodable, ValueError)
    assert "UndecodableImage" in tail_check.__all__
    data = _jpeg(scene)
    for bad in (b"", b"not an image", data[: len(data) // 2]):
        with pytest.raises(undecodable):
            detect_snapshot(bad)
        with pytest.raises(undecodable):
            decode_snapshot(bad)
    with pytest.raises(ValueError) as exc:
        decode_snapshot(data, reduce=3)
    assert not isinstance(exc.value, undecodable)  # a wrong argument, not a bad file


def test_decode_snapshot_ignores_exif_orientation_as_detect_snapshot_does(
    scene: NDArray[np.uint8],
) -> None:
    rotated = _jpeg(scene, orientation=6)
    assert decode_snapshot(rotated).shape == scene.shape
    assert np.array_equal(decode_snapshot(rotated), decode_snapshot(_jpeg(scene)))


def test_tail_check_judges_an_exif_rotated_jpeg_as_the_service(
    scene: NDArray[np.uint8], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    for orientation in (6, 8, 3):
        data = _jpeg(scene, orientation)
        path = tmp_path / f"rot{orientation}.jpg"
        path.write_bytes(data)
        assert _run(["tail-check", str(path), "--json"]) == 0
        record = json.loads(capsys.readouterr().out)
        assert record == {"file": str(path), **detect_snapshot(data).to_dict()}
        assert record["image_size"] == [640, 480] and record["verdict"] == "present"


def test_tail_check_png_is_judged_as_the_service(
    png: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert _run(["tail-check", str(png), "--json"]) == 0
    record = json.loads(capsys.readouterr().out)
    assert record == {"file": str(png), **detect_snapshot(png.read_bytes()).to_dict()}
    assert record == {
        "file": str(png),
        **tail_check.detect_confirmed(cv2.imread(str(png))).to_dict(),
    }


def test_calibrate_reads_the_stored_pixels_as_the_service(
    scene: NDArray[np.uint8], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """--disc X,Y is in the stored image's pixels, which the service judges (EXIF ignored)."""
    data = _jpeg(scene, orientation=6)
    path = tmp_path / "rot.jpg"
    path.write_bytes(data)
    assert _run(["calibrate", str(path), "--disc", DISC]) == 0
    printed = CameraProfile.from_json(capsys.readouterr().out)
    assert printed == calibrate(decode_snapshot(data), (413, 361), name="calibrated")


def test_a_folder_given_as_image_is_a_clear_error(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert _run(["tail-check", str(tmp_path)]) == 2
    assert capsys.readouterr().err.startswith(
        f"depot: cannot read image {str(tmp_path)!r} (missing, or not a JPEG/PNG file"
    )


def test_too_small_an_image_names_the_file(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    path = tmp_path / "strip.png"
    cv2.imwrite(str(path), np.zeros((200, 10, 3), np.uint8))
    assert _run(["tail-check", str(path)]) == 2
    err = capsys.readouterr().err
    assert err.startswith(
        f"depot: cannot read image {str(path)!r} (the image is 10×200 pixels; a snapshot must"
        " be at least 16×16"
    ), err


def test_damaged_snapshots_give_depot_s_messages_only(
    scene: NDArray[np.uint8], tmp_path: Path
) -> None:
    """A real process: libjpeg and libpng write to the process's stderr themselves.

    A truncated JPEG was judged (``cv2.imread`` fills the missing part grey), with libjpeg's
    ``Premature end of JPEG file`` above the verdict; the service refuses it. A JPEG with
    stray bytes before its end decodes (as in the service) without libjpeg's warning."""
    data = _jpeg(scene)
    truncated, cut_png, stray = (tmp_path / n for n in ("cut.jpg", "cut.png", "stray.jpg"))
    truncated.write_bytes(data[: len(data) // 2])
    ok, encoded = cv2.imencode(".png", scene)
    assert ok
    cut_png.write_bytes(encoded.tobytes()[:5000])
    stray.write_bytes(data[:-2] + b"\x00" * 94 + b"\xff\xd9")
    done = subprocess.run(
        [sys.executable, "-m", "service.cli", "tail-check", *map(str, (truncated, cut_png, stray))],
        capture_output=True,
        text=True,
        timeout=120,
        check=False,
    )
    assert done.returncode == 2, done
    said = done.stderr.strip().splitlines()
    assert len(said) == 2, done.stderr
    for line, name in zip(said, (truncated, cut_png), strict=True):
        assert line.startswith(
            f"depot: cannot read image {str(name)!r} (the image is damaged or truncated"
        ), line
    verdict = detect_snapshot(stray.read_bytes())
    assert done.stdout.splitlines() == [
        f"{stray}: {verdict.verdict} score={verdict.score:.2f} "
        f"bbox={'x'.join(map(str, verdict.bbox or ())) or '-'} s^={verdict.pixel_fraction:.5f}"
    ], done.stdout


# --- 3. profiles: numbers must be JSON numbers, the file UTF-8 ---


@pytest.mark.parametrize(
    ("data", "message"),
    [
        ({"c_delta": True}, "profile field 'c_delta' must be a number, got true"),
        ({"c_delta": "0.25"}, "profile field 'c_delta' must be a number, got \"0.25\""),
        ({"sigma": None}, "profile field 'sigma' must be a number, got null"),
        ({"max_aspect": [2]}, "profile field 'max_aspect' must be a number, got [2]"),
        (
            {"reference_rgb": [200, True, 38]},
            "profile field 'reference_rgb' must be a list of 3 numbers, got [200, true, 38]",
        ),
        (
            {"reference_rgb": "200"},  # three characters were three channels
            "profile field 'reference_rgb' must be a list of 3 numbers, got \"200\"",
        ),
        (
            {"gain_range": [0.5, "1"]},
            "profile field 'gain_range' must be a list of 2 numbers, got [0.5, \"1\"]",
        ),
        ({"name": 5}, "profile field 'name' must be a string, got 5"),
        ({"format": True}, "unsupported camera profile format true"),
    ],
)
def test_profile_numbers_must_be_json_numbers(data: dict[str, object], message: str) -> None:
    with pytest.raises(ValueError) as exc:
        CameraProfile.from_dict(data)
    assert str(exc.value).startswith(message), exc.value


def test_profile_integers_are_still_numbers() -> None:
    p = CameraProfile.from_dict({"c_delta": 1, "reference_rgb": [200, 35, 38], "format": 1})
    assert p.c_delta == 1.0 and isinstance(p.c_delta, float)
    assert p.reference_rgb == (200.0, 35.0, 38.0)


def test_a_non_utf8_profile_names_the_file(tmp_path: Path) -> None:
    path = tmp_path / "cam.json"
    path.write_bytes(b'{"name": "caf\xe9"}')
    with pytest.raises(ValueError) as exc:
        load_profile(path)
    assert str(exc.value) == f"profile {str(path)!r} is not UTF-8 JSON text"


# --- 4. minor: hints and messages ---


def test_calibrate_bad_base_hint_is_about_the_base_profile(
    png: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert _run(["calibrate", str(png), "--disc", DISC, "--base", str(png)]) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"depot: profile {str(png)!r} is not UTF-8 JSON text"), err
    assert "--base" in err and "disc visible" not in err, err


@pytest.mark.parametrize(
    ("shape", "words"),
    [
        ((20000, 10, 3), "image is too narrow (10x20000), need at least 16 pixels across"),
        ((10, 20000, 3), "image is too short (20000x10), need at least 16 pixels high"),
        ((10, 10, 3), "image is too small (10x10), need at least 16x16"),
    ],
)
def test_too_small_says_which_side(shape: tuple[int, int, int], words: str) -> None:
    with pytest.raises(ValueError) as exc:
        detect(np.zeros(shape, np.uint8))
    assert str(exc.value) == words


def test_uint16_values_are_refused_not_clipped() -> None:
    image = np.full((64, 64, 3), 60000, np.uint16)
    with pytest.raises(ValueError, match=r"0\.\.255.*uint16.*60000"):
        detect(image)
    with pytest.raises(ValueError, match=r"0\.\.255.*float64.*-3"):
        detect(np.full((64, 64, 3), -3.0))
    # values that fit are still accepted, as before (test_float_images_are_accepted)
    fits = np.full((64, 64, 3), 200, np.uint16)
    assert detect(fits) == detect(fits.astype(np.uint8))


def test_seed_bound_is_printed_as_an_integer(capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit):
        main(["tail-train", "--out", "/nonexistent/m.json", "--seed", "-1"])
    err = capsys.readouterr().err
    assert "at most 4294967295" in err and "e+09" not in err, err


@pytest.mark.parametrize("name", ["", "   "])
def test_calibrate_refuses_an_empty_name(
    name: str, png: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    with pytest.raises(SystemExit) as exc:
        main(["calibrate", str(png), "--disc", DISC, "--name", name])
    assert exc.value.code == 2
    out, err = capsys.readouterr()
    assert out == "" and err.startswith("depot: calibrate: argument --name: "), err
    assert "empty" in err


def test_negative_disc_coordinates_are_refused_as_outside_the_image(
    png: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """argparse took ``-1,10`` for an option ("expected one argument")."""
    for argv in (["--disc", "-1,10"], ["--disc=-1,10"], ["--disc", "-.5,10"]):
        try:
            code = main(["calibrate", str(png), *argv])
        except SystemExit as exc:  # argparse's refusal
            code = int(exc.code or 0)
        assert code == 2
        err = capsys.readouterr().err
        assert "is outside the 640x480 image" in err and "expected one argument" not in err, err
