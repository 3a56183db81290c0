"""``depot braking plan`` and ``POST /api/v1/motion/braking-plan`` give one answer for one
question (found by the independent trial: at speed 0 and at a probability of 1 the endpoint
planned and the command refused, its option ranges written apart from the domain's).

The command's option ranges are read from ``motion.braking_limits.BRAKING_LIMITS``, the
ranges the endpoint applies: at every boundary both accept, or both refuse.
"""

from __future__ import annotations

import json
from typing import Any

import pytest
from fastapi.testclient import TestClient

from motion.braking_limits import BRAKING_LIMITS as LIM
from service.commands import motion as cli
from tests.conftest import ADMIN

URL = "/api/v1/motion/braking-plan"
BASE = {"speed_mps": 20.0, "deceleration_mps2": 1.0}

# (CLI option, where it goes in the request, value)
EDGES: list[tuple[str, str, float]] = [
    ("--speed", "speed_mps", 0.0),
    ("--speed", "speed_mps", LIM.max_speed_mps),
    ("--speed", "speed_mps", LIM.max_speed_mps * 1.001),
    ("--speed", "speed_mps", -0.5),
    ("--decel", "deceleration_mps2", LIM.max_deceleration_mps2),
    ("--decel", "deceleration_mps2", LIM.max_deceleration_mps2 * 1.01),
    ("--decel", "deceleration_mps2", 0.0),
    ("--reaction-time", "reaction_time_s", LIM.max_reaction_time_s),
    ("--reaction-time", "reaction_time_s", LIM.max_reaction_time_s + 1),
    ("--gradient", "gradient_permille", LIM.max_abs_gradient_permille),
    ("--gradient", "gradient_permille", -LIM.max_abs_gradient_permille - 1),
    ("--p-s", "errors.p_s", 1.0),
    ("--p-s", "errors.p_s", 1.5),
    ("--p-s", "errors.p_s", 0.0),
    ("--p-l", "errors.p_l", 1.0),
    ("--delta-s-max", "errors.delta_s_max_m", LIM.max_margin_m),
    ("--delta-s-max", "errors.delta_s_max_m", LIM.max_margin_m + 1),
    ("--delta-l-max", "errors.delta_l_max_m", LIM.max_margin_m + 1),
    ("-k", "errors.measurements", LIM.max_measurements),
    ("-k", "errors.measurements", LIM.max_measurements + 1),
    ("--channels", "errors.channels", LIM.max_channels),
    ("--channels", "errors.channels", LIM.max_channels + 1),
    ("--measurement-time", "errors.measurement_time_s", LIM.max_measurement_time_s + 1),
    ("--obstacle-at", "obstacle_at_m", LIM.max_abs_coordinate_m),
    ("--obstacle-at", "obstacle_at_m", -LIM.max_abs_coordinate_m - 1),
]


def _body(where: str, value: float) -> dict[str, Any]:
    body: dict[str, Any] = {**BASE, "errors": {"delta_l_max_m": 50.0}}
    is_count = where in ("errors.measurements", "errors.channels")
    v: float = int(value) if is_count else value
    if where.startswith("errors."):
        body["errors"][where.removeprefix("errors.")] = v
    else:
        body[where] = v
    return body


def _argv(option: str, value: float) -> list[str]:
    argv = ["braking", "plan", "--speed", "20", "--decel", "1", "--delta-l-max", "50"]
    text = str(int(value)) if option in ("-k", "--channels") else repr(value)
    if option in ("--speed", "--decel"):
        i = argv.index(option)
        argv[i + 1] = text
    else:
        argv += [f"{option}={text}"]
    return [*argv, "--json"]


def _cli(argv: list[str], capsys: pytest.CaptureFixture[str]) -> tuple[int, str, str]:
    try:
        rc = cli.main(argv)
    except SystemExit as stopped:
        rc = int(stopped.code or 0)
    out = capsys.readouterr()
    return rc, out.out, out.err


@pytest.mark.parametrize(("option", "where", "value"), EDGES)
def test_the_command_and_the_endpoint_agree_at_every_edge(
    option: str,
    where: str,
    value: float,
    client: TestClient,
    capsys: pytest.CaptureFixture[str],
) -> None:
    rc, out, err = _cli(_argv(option, value), capsys)
    answer = client.post(URL, json=_body(where, value), headers=ADMIN)
    assert answer.status_code in (200, 422), answer.text
    assert (rc == 0) == (answer.status_code == 200), (rc, err, answer.text)
    if rc == 0:
        assert json.loads(out) == answer.json()
    else:
        assert err.startswith("depot: ") and "Traceback" not in err, err


def test_a_standing_train_and_a_probability_of_one_are_planned_alike(
    client: TestClient, capsys: pytest.CaptureFixture[str]
) -> None:
    argv = ["braking", "plan", "--speed", "0", "--decel", "1", "--p-s", "1", "--p-l", "1"]
    rc, out, err = _cli([*argv, "--delta-l-max", "50", "--json"], capsys)
    assert rc == 0, err
    body = {**BASE, "speed_mps": 0.0, "errors": {"p_s": 1.0, "p_l": 1.0, "delta_l_max_m": 50.0}}
    answer = client.post(URL, json=body, headers=ADMIN)
    assert answer.status_code == 200, answer.text
    plan = json.loads(out)
    assert plan == answer.json()
    assert plan["braking_distance_m"] == 0.0 and plan["collision_probability_bound"] == 1.0
    assert plan["meets_sil4"] is False
