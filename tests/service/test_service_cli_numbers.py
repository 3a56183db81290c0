"""Every numeric option of the CLI refuses what would crash or hang it: zero or negative where
that means nothing, NaN, ±inf, and sizes beyond what the command can hold (found by the
independent trial: `optical-speed --pixel-fov 0` divided by zero, `tail-synth --size
100000x100000` asked for 112 GiB). Each refusal is one `depot:` line, exit 2, no traceback."""

from __future__ import annotations

import argparse
from collections.abc import Iterator
from pathlib import Path

import pytest

from service.cli import build_parser, main

NOT_OURS: set[str] = set()  # every command's numeric options are range-checked


def _numeric_actions() -> Iterator[tuple[str, argparse.Action]]:
    def walk(parser: argparse.ArgumentParser, path: str) -> Iterator[tuple[str, argparse.Action]]:
        for action in parser._actions:
            if isinstance(action, argparse._SubParsersAction):
                for name, child in action.choices.items():
                    if name not in NOT_OURS:
                        yield from walk(child, f"{path} {name}".strip())
            elif action.type in (int, float) or getattr(action.type, "__name__", "") in (
                "a number",
                "a whole number",
            ):
                yield path, action

    yield from walk(build_parser(), "")


def test_no_numeric_option_takes_a_bare_float_or_int() -> None:
    bare = [f"{path} {a.option_strings or a.dest}" for path, a in _numeric_actions()
            if a.type in (int, float)]  # fmt: skip
    assert not bare, bare


@pytest.mark.parametrize("text", ["nan", "inf", "-inf", "NaN"])
def test_every_numeric_option_refuses_nan_and_infinity(text: str) -> None:
    actions = list(_numeric_actions())
    assert len(actions) > 30
    for path, action in actions:
        assert callable(action.type)
        with pytest.raises(argparse.ArgumentTypeError):
            action.type(text)
            pytest.fail(f"{path} {action.option_strings} took {text}")


BAD = [
    (["optical-speed", "IMG", "--distance", "2", "--pixel-fov", "0", "--row-time", "1e-5"],
     "--pixel-fov"),
    (["optical-speed", "IMG", "--distance", "-2", "--pixel-fov", "1e-3", "--row-time", "1e-5"],
     "--distance"),
    (["optical-speed", "IMG", "--distance", "2", "--pixel-fov", "1e-3", "--row-time", "nan"],
     "--row-time"),
    (["optical-speed", "IMG", "--distance", "2", "--pixel-fov", "1e-3", "--row-time", "1e-5",
      "--rows", "0"], "--rows"),
    (["braking", "trials", "--p-max", "0", "--beta", "0.9"], "--p-max"),
    (["braking", "trials", "--p-max", "0.01", "--beta", "1"], "--beta"),
    (["braking", "exceedance", "--p-max", "0.1", "-k", "0"], "-k"),
    (["braking", "plan", "--speed", "inf", "--decel", "1"], "--speed"),
    (["braking", "plan", "--speed", "10", "--decel", "1", "--reaction-time", "-1"],
     "--reaction-time"),
    (["braking", "montecarlo", "--runs", "0"], "--runs"),
    (["braking", "montecarlo", "--runs", "10000000000"], "--runs"),
    (["simulate", "--train-every", "0"], "--train-every"),
    (["simulate", "--seed", "-1"], "--seed"),
    (["tail-synth", "DIR", "--count", "-5"], "--count"),
    (["tail-study", "DIR", "--kernel", "0"], "--kernel"),
    (["serve", "--port", "70000"], "--port"),
    (["serve", "--workers", "0"], "--workers"),
    (["user", "add", "olena", "--role", "engineer", "--expires-in-days", "nan"],
     "--expires-in-days"),
]  # fmt: skip


@pytest.mark.parametrize("argv, option", BAD, ids=[" ".join(a[:3]) + " " + o for a, o in BAD])
def test_a_bad_number_is_one_line(
    argv: list[str], option: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    argv = [str(tmp_path / "x") if a in ("IMG", "DIR") else a for a in argv]
    with pytest.raises(SystemExit) as stopped:
        main(argv)
    assert stopped.value.code == 2
    err = capsys.readouterr().err
    last = err.strip().splitlines()[-1]
    assert last.startswith("depot: ") and option in last and "Traceback" not in err, err


@pytest.mark.parametrize("size", ["100000x100000", "4097x480", "640x4097", "0x480"])
def test_tail_synth_bounds_the_size(
    size: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert main(["tail-synth", str(tmp_path / "set"), "--size", size, "--count", "1"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("depot: ") and "4096x4096" in err and len(err.splitlines()) == 1, err
    assert not (tmp_path / "set").exists()
