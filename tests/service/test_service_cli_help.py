"""Every command's ``--help`` renders and names every option with its default; errors from
argparse carry the one ``depot:`` prefix."""

from __future__ import annotations

import argparse
import re

import pytest

from service.cli import build_parser, main

# Commands another helper owns (service/commands/tail_check.py): left to them.


def _commands() -> list[tuple[list[str], argparse.ArgumentParser]]:
    found: list[tuple[list[str], argparse.ArgumentParser]] = []

    def walk(path: list[str], parser: argparse.ArgumentParser) -> None:
        found.append((path, parser))
        for action in parser._actions:
            if isinstance(action, argparse._SubParsersAction):
                for name, sub in action.choices.items():
                    walk([*path, name], sub)

    walk([], build_parser())
    return found


COMMANDS = _commands()


@pytest.mark.parametrize("path", [p for p, _ in COMMANDS], ids=lambda p: " ".join(p) or "depot")
def test_help_renders_and_names_every_option_with_its_default(
    path: list[str], capsys: pytest.CaptureFixture[str]
) -> None:
    with pytest.raises(SystemExit) as done:
        main([*path, "--help"])
    assert done.value.code == 0
    text = capsys.readouterr().out
    assert text.startswith("usage: depot"), text[:200]
    assert "{'" not in text and "%(" not in text, "a raw dict or format string leaked"
    parser = dict((tuple(p), q) for p, q in COMMANDS)[tuple(path)]
    for action in parser._actions:
        if isinstance(action, argparse._HelpAction | argparse._SubParsersAction):
            continue
        if not action.option_strings:
            assert action.help, f"{path}: argument {action.dest} has no help"
            continue
        assert action.help, f"{path}: {action.option_strings[0]} has no help"
        if isinstance(action, argparse._StoreTrueAction | argparse._StoreFalseAction):
            continue
        chosen = any(
            group.required and action in group._group_actions
            for group in parser._mutually_exclusive_groups
        )
        if action.required or chosen:
            continue
        formatter = parser.formatter_class(prog="depot")
        shown = str(getattr(formatter, "_get_help_string")(action))  # noqa: B009
        assert re.search(r"default", shown, re.I), (
            f"{path}: {action.option_strings[0]} does not say its default: {shown!r}"
        )


def test_argparse_errors_carry_the_depot_prefix(capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit) as done:
        main(["user", "add", "ivan", "--role", "driver"])
    assert done.value.code == 2
    err = capsys.readouterr().err
    assert "depot: " in err and "error:" not in err, err
    assert "invalid choice" in err


@pytest.mark.parametrize(
    ("command", "actions"),
    [("user", ("add", "list", "rotate", "revoke")), ("device", ("key", "decommission"))],
)
def test_a_command_without_its_action_shows_its_own_help_and_fails(
    command: str, actions: tuple[str, ...], capsys: pytest.CaptureFixture[str]
) -> None:
    """An independent trial: ``depot user`` printed the top-level help and exited 2 without
    saying what was missing. It shows that command's help and names the missing action."""
    code = main([command])
    shown = capsys.readouterr()
    assert code != 0
    assert f"usage: depot {command}" in shown.err, shown
    assert "serve" not in shown.out + shown.err, "not the top-level help"
    message = shown.err.strip().splitlines()[-1]
    assert message.startswith(f"depot: {command}: "), message
    assert "ACTION" in message and all(a in message for a in actions), message
