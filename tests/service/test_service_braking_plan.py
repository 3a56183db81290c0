"""POST /api/v1/motion/braking-plan: the braking calculator of seed 001 over the
API, refusing what the CLI refuses (the same domain checks, problem+json)."""

from __future__ import annotations

import json

import pytest
from fastapi.testclient import TestClient

from service.commands import motion as cli
from service.trains import braking as braking_api
from tests.conftest import ADMIN

URL = "/api/v1/motion/braking-plan"
# Two channels of two measurements at 1e-2 (SIL-4), 8 ‰ downhill, an obstacle at 5 km: the
# request of the first test, and the one the CLI's options below stand for.
TWO_CHANNEL_PLAN = {
    "speed_mps": 20.0,
    "deceleration_mps2": 1.0,
    "gradient_permille": -8.0,
    "errors": {"delta_l_max_m": 400.0, "measurements": 2, "channels": 2},
    "obstacle_at_m": 5000.0,
}


def test_a_plan_with_two_channels_meets_sil4(client: TestClient) -> None:
    answer = client.post(URL, json=TWO_CHANNEL_PLAN, headers=ADMIN)
    assert answer.status_code == 200, answer.text
    plan = answer.json()
    assert plan["meets_sil4"] is True and plan["protective_section_m"] == 403.0
    assert plan["brake_start_coordinate_m"] < 5000.0 - 403.0


def test_an_inverted_margin_is_refused_as_problem_json(client: TestClient) -> None:
    for body, named in (
        (
            {
                "speed_mps": 20.0,
                "deceleration_mps2": 1.0,
                "errors": {"delta_l_max_m": 400.0, "measurements": 3, "measurement_time_s": -10},
            },
            "measurement time",
        ),
        ({"speed_mps": 20.0, "deceleration_mps2": 1.0, "gradient_permille": 2000}, "gradient"),
        ({"speed_mps": 20.0, "deceleration_mps2": 1.0, "errors": {"p_s": 0}}, "p_s"),
        ({"speed_mps": 1e200, "deceleration_mps2": 1.0}, "speed"),
        ({"speed_mps": 10.0, "deceleration_mps2": 0.1, "gradient_permille": -30}, "downhill"),
    ):
        answer = client.post(URL, json=body, headers=ADMIN)
        assert answer.status_code == 422, (body, answer.text)
        assert answer.headers["content-type"].startswith("application/problem+json")
        assert named in answer.text, answer.text


def test_readers_only(client: TestClient) -> None:
    assert client.post(URL, json={"speed_mps": 1, "deceleration_mps2": 1}).status_code == 401


def test_the_cli_and_the_api_answer_from_one_builder(
    client: TestClient, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    """``depot braking plan --json`` and the endpoint built the answer each their own way;
    now both go through service.trains.braking.plan and answer alike."""
    built: list[braking_api.BrakingPlanIn] = []
    real = braking_api.plan

    def counted(body: braking_api.BrakingPlanIn) -> braking_api.BrakingPlanOut:
        built.append(body)
        return real(body)

    monkeypatch.setattr(braking_api, "plan", counted)
    argv = ["braking", "plan", "--speed", "20", "--decel", "1", "--gradient", "-8"]
    argv += ["--delta-l-max", "400", "-k", "2", "--channels", "2", "--obstacle-at", "5000"]
    assert cli.main([*argv, "--json"]) == 0
    from_cli = json.loads(capsys.readouterr().out)
    answer = client.post(URL, json=TWO_CHANNEL_PLAN, headers=ADMIN)
    assert answer.status_code == 200, answer.text
    assert len(built) == 2 and built[0] == built[1]
    assert from_cli == answer.json()


def test_a_plan_reads_numbers_strictly(client: TestClient) -> None:
    """Found by an independent trial: ``"speed_mps": true`` planned at 1 m/s, ``"20"`` and
    ``"measurements": "3"`` were taken as numbers. The people's APIs read JSON strictly (as
    device events do): a boolean, a string or a fractional count is refused, naming the field."""
    for field, value in (("speed_mps", True), ("speed_mps", "20"), ("deceleration_mps2", "1")):
        body = {"speed_mps": 20, "deceleration_mps2": 1.0, field: value}
        answer = client.post(URL, json=body, headers=ADMIN)
        assert answer.status_code == 422, (field, value, answer.text)
        assert answer.headers["content-type"].startswith("application/problem+json")
        assert field in answer.text
    for field, value in (("measurements", "3"), ("channels", 2.5), ("p_s", False)):
        body = {"speed_mps": 20, "deceleration_mps2": 1.0, "errors": {field: value}}
        answer = client.post(URL, json=body, headers=ADMIN)
        assert answer.status_code == 422, (field, value, answer.text)
        assert field in answer.text
    whole = {"speed_mps": 20, "deceleration_mps2": 1, "errors": {"measurements": 3}}
    assert client.post(URL, json=whole, headers=ADMIN).status_code == 200
