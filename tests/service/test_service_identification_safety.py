"""Reader events never give a confident wrong car: weak or impossible evidence is undetermined.

Found by the independent tester (truncated wheel marks, impossible ADC codes, a single axle,
a single IR read). The safety stance of identification.md: a person must look rather than be
told a wrong car.
"""

from __future__ import annotations

from typing import Any

from fastapi.testclient import TestClient

from identification.rules import RULES
from tests.conftest import ADMIN
from tests.service.linekit import build_line, event

ONE, ZERO, BASELINE = 2170, 1930, [2051, 2049, 2050, 2052, 2048, 2050]


def _axle(code: int, zones: int = 8) -> list[int]:
    return [ONE if c == "1" else ZERO for c in f"{code:08b}"][:zones]


def _post(client: TestClient, key: dict[str, str], body: dict[str, Any]) -> dict[str, Any]:
    response = client.post("/api/v1/events", json=body, headers=key)
    assert response.status_code == 201, response.text
    result: dict[str, Any] = response.json()
    return result


def _wheel(event_id: str, axles: list[list[Any]]) -> dict[str, Any]:
    return event(event_id, "wheel_marks", section="AB", direction=1, baseline=BASELINE, axles=axles)


def test_truncated_wheel_marks_are_undetermined_not_another_car(client: TestClient) -> None:
    keys = build_line(client)
    car = {"id": "0058", "wheel_code": 58, "axles": 4}
    assert client.post("/api/v1/cars", json=car, headers=ADMIN).status_code == 201
    # car 117 (01110101) with every axle cut to 7 zones reads 0111010 = 58
    result = _post(client, keys["B-wm"], _wheel("w-cut", [_axle(117, 7)] * 4))
    assert (result["car_number"], result["car"]) == (None, None), result
    assert f"7 mark zones, {RULES.zones_per_axle} expected" in result["reason"]
    # the whole marks still identify car 117
    assert _post(client, keys["B-wm"], _wheel("w-full", [_axle(117)] * 4))["car"] == "0117"


def test_impossible_adc_codes_are_undetermined(client: TestClient) -> None:
    keys = build_line(client)
    result = _post(client, keys["B-wm"], _wheel("w-huge", [[1e300] * 8] * 4))
    assert result["car_number"] is None, result
    assert "outside the reader's range" in result["reason"]
    below = _post(client, keys["B-wm"], _wheel("w-neg", [[-5000] * 8] * 4))
    assert below["car_number"] is None and "outside the reader's range" in below["reason"]


def test_one_axle_is_not_enough_whether_sent_alone_or_beside_erased_ones(
    client: TestClient,
) -> None:
    keys = build_line(client)
    alone = _post(client, keys["B-wm"], _wheel("w-one", [_axle(119)]))
    erased = [[2050] * 8] * 3
    beside = _post(client, keys["B-wm"], _wheel("w-one-of-four", [_axle(119), *erased]))
    assert alone["car_number"] is None and beside["car_number"] is None, (alone, beside)
    assert "agreeing axles" in alone["reason"] and "agreeing axles" in beside["reason"]
    two = _post(client, keys["B-wm"], _wheel("w-two", [_axle(119), _axle(119), *erased[:2]]))
    assert two["car"] == "0119"


def test_ir_id_needs_as_many_agreeing_reads_as_ir_pulses(client: TestClient) -> None:
    keys = build_line(client)
    need = RULES.min_agreeing_reads
    single = _post(client, keys["B-ir"], event("i-1", "ir_id", section="AB", reads=[119]))
    assert single["car_number"] is None, single
    assert f"{need} needed" in single["reason"]
    enough = _post(client, keys["B-ir"], event("i-2", "ir_id", section="AB", reads=[119] * need))
    assert enough["car"] == "0119"
    # the raw-timing reader: one start/stop pair is one read of 119, too few as well
    pulses = event(
        "p-1",
        "ir_pulses",
        section="AB",
        query_period_us=1000,
        reflection_window_us=200,
        reply_times_us=[262.5, 119262.0],
    )
    one_pair = _post(client, keys["B-ir"], pulses)
    assert one_pair["car_number"] is None and f"{need} needed" in one_pair["reason"]
