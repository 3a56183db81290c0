"""``depot tail-train``: a model file is never left without its description."""

from __future__ import annotations

from pathlib import Path

import pytest

import service.commands.tail_check as commands
from tail_check.pipeline import load_model
from tests.tail_check.tailkit import run_tail_command


def test_a_failed_write_leaves_neither_file(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    import tail_check.pipeline.train as training

    shipped = load_model("B")
    monkeypatch.setattr(training, "train", lambda *args, **kwargs: shipped)
    plain_write = commands.write_file
    for failing in ("m.json", "m.training.json"):

        def write(out: Path, text: str, option: str, failing: str = failing) -> str | None:
            if out.name == failing:
                return f"cannot write {out}: No space left on device; choose another {option}"
            return plain_write(out, text, option)

        monkeypatch.setattr(commands, "write_file", write)
        assert run_tail_command(["tail-train", "--out", str(tmp_path / "m.json")]) == 2
        assert "No space left on device" in capsys.readouterr().err
        assert sorted(p.name for p in tmp_path.iterdir()) == [], failing
    monkeypatch.setattr(commands, "write_file", plain_write)
    assert run_tail_command(["tail-train", "--out", str(tmp_path / "m.json")]) == 0
    assert sorted(p.name for p in tmp_path.iterdir()) == ["m.json", "m.training.json"]
