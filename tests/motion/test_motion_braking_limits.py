"""Braking calculators refuse inputs outside their documented ranges (found by
the independent trial: a negative measurement time inverted the margin and
still "met SIL-4"; p_s = 0 claimed probability < 0; NaN speeds gave NaN
braking distances with exit 0; 1e200 a traceback)."""

from __future__ import annotations

import math

import pytest

from motion import braking
from service.commands import motion as cmd

NAN, INF = math.nan, math.inf


def _cli(capsys: pytest.CaptureFixture[str], *argv: str) -> tuple[int, str, str]:
    try:
        rc = cmd.main(list(argv))
    except SystemExit as e:  # argparse's own refusals
        rc = int(e.code or 0)
    out, err = capsys.readouterr()
    return rc, out, err


@pytest.mark.parametrize(
    ("kwargs", "named"),
    [
        ({"speed_mps": NAN}, "speed"),
        ({"speed_mps": INF}, "speed"),
        ({"speed_mps": -5.0}, "speed"),
        ({"speed_mps": 1e200}, "speed"),
        ({"deceleration_mps2": NAN}, "deceleration"),
        ({"deceleration_mps2": 0.0}, "deceleration"),
        ({"gradient_permille": NAN}, "gradient"),
        ({"gradient_permille": 1e6}, "gradient"),
        ({"gradient_permille": 2000.0}, "gradient"),
        ({"gradient_permille": -1e6}, "gradient"),
        ({"reaction_time_s": -1.0}, "reaction time"),
    ],
)
def test_braking_distance_refuses_naming_the_quantity(kwargs: dict[str, float], named: str) -> None:
    args = {"speed_mps": 20.0, "deceleration_mps2": 1.0} | kwargs
    with pytest.raises(ValueError, match=named):
        braking.braking_plan(
            args.pop("speed_mps"),
            args.pop("deceleration_mps2"),
            **args,  # type: ignore[arg-type]
        )


@pytest.mark.parametrize(
    ("kwargs", "named"),
    [
        ({"measurement_time_s": -10.0}, "measurement time"),
        ({"delta_s_max_m": -3.0}, "ΔS_max"),
        ({"delta_l_max_m": -10.0}, "ΔL_max"),
        ({"p_s": 0.0}, "p_s"),
        ({"p_s": 2.0}, "p_s"),
        ({"p_l": NAN}, "p_l"),
        ({"measurements": 0}, "measurements"),
        ({"channels": 0}, "channels"),
    ],
)
def test_error_model_refuses_an_inverted_margin(kwargs: dict[str, float], named: str) -> None:
    with pytest.raises(ValueError, match=named):
        braking.ErrorModel(**kwargs)  # type: ignore[arg-type]


def test_the_message_states_unit_and_range() -> None:
    with pytest.raises(ValueError) as e:
        braking.braking_distance(20.0, 1.0, 0.0, 2000.0)
    assert str(e.value) == ("gradient must be a finite number in [-70, 70] ‰ (got 2000)")


def test_monte_carlo_refuses_a_speed_that_cannot_brake() -> None:
    for v in (-5.0, 0.0, NAN, 1e200):
        with pytest.raises(ValueError, match="speed"):
            braking.braking_error_monte_carlo(10, speed_mps=v)


@pytest.mark.parametrize(
    ("argv", "named"),
    [
        (["--measurement-time", "-10", "--delta-l-max", "400", "-k", "3"], "measurement time"),
        (["--delta-s-max", "-3"], "ΔS_max"),
        (["--delta-l-max", "-10"], "ΔL_max"),
        (["--p-s", "0"], "p_s"),
        (["--p-s", "2"], "p_s"),
        (["--gradient", "nan"], "gradient"),
        (["--gradient", "1e6"], "gradient"),
        (["--gradient", "2000"], "gradient"),
        (["--gradient", "-1e6"], "gradient"),
        (["--gradient=-1e6"], "gradient"),
        (["--decel", "nan"], "deceleration"),
    ],
)
def test_plan_cli_refuses_in_one_line(
    capsys: pytest.CaptureFixture[str], argv: list[str], named: str
) -> None:
    base = ["braking", "plan", "--speed", "20", "--decel", "1", "--json"]
    rc, out, err = _cli(capsys, *base, *argv)
    assert rc == 2 and out == ""
    # Refused by the option's own range (naming the option) or by the calculation (naming the
    # quantity): either way one line.
    option = argv[0].split("=")[0]
    assert err.count("\n") == 1 and err.startswith("depot: "), err
    assert named in err or option in err, err


@pytest.mark.parametrize("speed", ["nan", "inf", "1e200", "-5"])
def test_plan_and_montecarlo_cli_refuse_the_speed(
    capsys: pytest.CaptureFixture[str], speed: str
) -> None:
    for argv in (
        ["braking", "plan", "--speed", speed, "--decel", "1"],
        ["braking", "montecarlo", "--runs", "10", "--speed", speed],
    ):
        rc, out, err = _cli(capsys, *argv)
        assert rc == 2 and out == "", (argv, out)
        assert err.count("\n") == 1 and err.startswith("depot: ") and "speed" in err, err


def test_a_valid_plan_still_meets_sil4(capsys: pytest.CaptureFixture[str]) -> None:
    rc, out, _ = _cli(
        capsys,
        "braking",
        "plan",
        "--speed",
        "20",
        "--decel",
        "1",
        "--delta-l-max",
        "400",
        "-k",
        "2",
        "--channels",
        "2",
        "--gradient",
        "-8",
    )
    assert rc == 0 and "meets SIL-4" in out
