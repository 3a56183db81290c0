"""Issue 18 (tail part): tail-synth size and output-folder checks, tail-study summary."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from tests.tail_check.tailkit import run_tail_command

_run = run_tail_command


@pytest.mark.parametrize("size", ["640", "640x", "x480", "640x480x3", "axb", "0x480"])
def test_tail_synth_bad_size_is_a_clear_error(
    size: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert _run(["tail-synth", str(tmp_path / "out"), "--count", "1", "--size", size]) == 2
    err = capsys.readouterr().err
    assert err.startswith("depot: ") and "--size" in err and "WIDTHxHEIGHT" in err
    assert "unpack" not in err


def test_tail_synth_refuses_a_non_empty_folder_unless_forced(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "set"
    out.mkdir()
    (out / "old.png").write_bytes(b"old")
    assert _run(["tail-synth", str(out), "--count", "2", "--size", "160x120"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("depot: ") and "--force" in err and "not empty" in err
    assert not (out / "labels.csv").exists()
    assert _run(["tail-synth", str(out), "--count", "2", "--size", "160x120", "--force"]) == 0
    assert (out / "labels.csv").is_file()
    # an existing empty folder and a new folder are fine without --force
    empty = tmp_path / "empty"
    empty.mkdir()
    assert _run(["tail-synth", str(empty), "--count", "1", "--size", "160x120"]) == 0
    assert _run(["tail-synth", str(tmp_path / "new"), "--count", "1", "--size", "160x120"]) == 0


def test_tail_synth_refuses_a_file_as_folder(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    target = tmp_path / "file.txt"
    target.write_text("x", encoding="utf-8")
    assert _run(["tail-synth", str(target), "--count", "1", "--size", "160x120"]) == 2
    assert "not a folder" in capsys.readouterr().err


def test_tail_study_summary_names_the_tables_own_minimum(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    data = tmp_path / "study"
    assert _run(["tail-synth", str(data), "--count", "12", "--seed", "5", "--size", "320x240"]) == 0
    capsys.readouterr()
    assert _run(["tail-study", str(data)]) == 0
    text = capsys.readouterr().out
    lines = text.splitlines()
    header = lines[0].split()
    kinds = header[1 : header.index("(mean")]
    cells: list[tuple[float, str, int]] = []
    for line in lines[1:]:
        row = line.split()
        if len(row) != len(kinds) + 1 or not re.fullmatch(r"\d+", row[0]):
            break
        cells += [(float(c), k, int(row[0])) for k, c in zip(kinds, row[1:], strict=True)]
    assert cells
    low = min(c[0] for c in cells)
    minima = {f"{k} at c_Δ = {d} %" for v, k, d in cells if v == low}
    summary = next(s for s in lines if s.startswith("lowest mean ε in the table"))
    assert any(m in summary for m in minima), (summary, minima)


def test_an_unreadable_image_gives_depot_s_message_only(tmp_path: Path) -> None:
    """An independent trial: OpenCV's own ``[ WARN:0@…] … imread_(…): can't open/read file``
    line came before depot's message (OpenCV writes it to the process's stderr, hence a real
    process here). Only depot's line is shown, and the next file is still checked."""
    import subprocess
    import sys

    missing = tmp_path / "missing.jpg"
    garbage = tmp_path / "garbage.jpg"
    garbage.write_bytes(b"not an image")
    done = subprocess.run(
        [sys.executable, "-m", "service.cli", "tail-check", str(missing), str(garbage), "--json"],
        capture_output=True,
        text=True,
        timeout=120,
        check=False,
    )
    assert done.returncode == 2, done
    lines = done.stderr.strip().splitlines()
    assert [line.split(" (")[0] for line in lines] == [
        f"depot: cannot read image {str(missing)!r}",
        f"depot: cannot read image {str(garbage)!r}",
    ], done.stderr
    assert "WARN" not in done.stderr
