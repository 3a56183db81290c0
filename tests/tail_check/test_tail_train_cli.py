"""`depot tail-train` refuses out-of-range numbers before any scene is rendered.

Every numeric option goes through the shared range checker
(:func:`service.commands._common.number`), as every other command's.
"""

from __future__ import annotations

import argparse

import pytest

from service.cli import build_parser, main

BAD = [
    ("--seed", "-1"),
    ("--seed", "nan"),
    ("--seed", str(2**32)),
    ("--count", "0"),
    ("--count", "-5"),
    ("--count", "1e12"),
    ("--count", "inf"),
    ("--validation", "0"),
    ("--validation", "100000000"),
]


def _tail_train() -> argparse.ArgumentParser:
    for action in build_parser()._actions:
        if isinstance(action, argparse._SubParsersAction):
            return action.choices["tail-train"]
    raise AssertionError("no tail-train command")


@pytest.mark.parametrize("option, value", BAD, ids=[f"{o} {v}" for o, v in BAD])
def test_tail_train_refuses_out_of_range_numbers(
    option: str, value: str, capsys: pytest.CaptureFixture[str], tmp_path: object
) -> None:
    with pytest.raises(SystemExit) as exc:
        main(["tail-train", "--out", "/nonexistent/m.json", option, value])
    assert exc.value.code == 2
    err = capsys.readouterr().err
    assert err.startswith("depot: ") and option in err, err


def test_every_numeric_tail_train_option_uses_the_shared_checker() -> None:
    numeric = [a for a in _tail_train()._actions if a.dest in ("seed", "count", "validation")]
    assert len(numeric) == 3
    for action in numeric:
        assert action.type not in (int, float), action.dest
        assert getattr(action.type, "__name__", "") == "a whole number", action.dest
