"""``depot simulate`` keeps the demo line alive against a running server, and stops cleanly."""

from __future__ import annotations

import os
import signal
import socket
import subprocess
import sys
import time
from datetime import UTC, datetime, timedelta
from pathlib import Path

import httpx
import pytest

from core.settings import get_settings
from service.cli import main
from service.demo import load_demo
from tests.conftest import ADMIN
from tests.service.livekit import live_server

FAST = ["--train-every", "1", "--transit", "1", "--heartbeat-every", "1", "--seed", "7"]


POLL_TIMEOUT_S = 30.0
"""How long one poll of the live server may take: it serves the simulator's fast stream on
one worker, and under CI's parallel load an answer took longer than httpx's 5 s default
(a ReadTimeout failed test_simulate_ends_when_the_server_stops once)."""


def _runs(url: str) -> list[dict[str, object]]:
    answer = httpx.get(f"{url}/api/v1/runs", headers=ADMIN, timeout=POLL_TIMEOUT_S)
    items: list[dict[str, object]] = answer.json()["items"]
    return items


def _silent(url: str) -> list[str]:
    """Devices that have not reported within the heartbeat period (the screen's rule)."""
    now = datetime.now(UTC)
    limit = timedelta(seconds=get_settings().heartbeat_s)
    devices = httpx.get(f"{url}/api/v1/devices", headers=ADMIN).json()
    return [
        d["id"]
        for d in devices
        if d["kind"] not in ("marking_station", "test_bench", "onboard_unit")
        and (d["last_seen_at"] is None or now - datetime.fromisoformat(d["last_seen_at"]) > limit)
    ]


def test_simulate_takes_over_the_demo_line_runs_trains_and_stops_on_sigterm(
    tmp_path: Path,
) -> None:
    with live_server(tmp_path) as url:
        assert load_demo(fleet=False) == 0
        before = {r["id"] for r in _runs(url)}
        assert _silent(url), "the demo day ended in the past: its devices are silent"
        # free the demo's two sections, as a dispatcher would, so that trains can run
        for section in ("AB", "BC"):
            run = httpx.get(f"{url}/api/v1/sections/{section}", headers=ADMIN).json()["run"]
            answer = httpx.post(
                f"{url}/api/v1/runs/{run['id']}/decision",
                json={"action": "clear", "reason": "walked the line: empty"},
                headers=ADMIN,
            )
            assert answer.status_code == 200, answer.text
        process = subprocess.Popen(
            [sys.executable, "-m", "service.cli", "simulate", "--url", url, *FAST],
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
            env={**os.environ, "PYTHONPATH": str(Path(__file__).resolve().parents[2])},
        )
        try:
            deadline = time.monotonic() + 60
            new: list[dict[str, object]] = []
            while time.monotonic() < deadline:
                new = [r for r in _runs(url) if r["id"] not in before and r["status"] == "arrived"]
                if len(new) >= 2 and not _silent(url):
                    break
                time.sleep(0.5)
            assert len(new) >= 2, "trains run on the simulated line"
            assert _silent(url) == [], "every device heartbeats"
        finally:
            process.send_signal(signal.SIGTERM)
            out, err = process.communicate(timeout=30)
        assert process.returncode == 0, err
        assert "took over the demo line" in out and "stopped after" in out, out
        assert "Traceback" not in err, err


def test_simulate_ends_when_the_server_stops(tmp_path: Path) -> None:
    with live_server(tmp_path) as url:
        process = subprocess.Popen(
            [sys.executable, "-m", "service.cli", "simulate", "--url", url, *FAST],
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
            env={**os.environ, "PYTHONPATH": str(Path(__file__).resolve().parents[2])},
        )
        deadline = time.monotonic() + 60
        while time.monotonic() < deadline and not _runs(url):
            time.sleep(0.5)
        assert _runs(url), "a built line runs trains"
    try:
        out, err = process.communicate(timeout=60)
    finally:
        process.kill()
    assert process.returncode == 0 and "built the demo line" in out, (out, err)
    assert "server stopped answering" in err, err


def test_simulate_in_process_for_a_short_time(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    with live_server(tmp_path) as url:  # the database only: the simulator runs the app itself
        assert main(["simulate", *FAST, "--duration", "4"]) == 0
        assert len(_runs(url)) >= 1
    out = capsys.readouterr().out
    assert "built the demo line" in out and "departs" in out


def test_simulate_refuses_another_line_and_bad_periods(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert main(["simulate", "--heartbeat-every", "600"]) == 2
    assert "below the heartbeat period" in capsys.readouterr().err
    with live_server(tmp_path) as url:
        httpx.post(f"{url}/api/v1/stations", json={"id": "X", "name": "X"}, headers=ADMIN)
        body = {"id": "X-ilk", "station": "X", "section": None, "kind": "interlocking"}
        assert httpx.post(f"{url}/api/v1/devices", json=body, headers=ADMIN).status_code == 201
        assert main(["simulate", "--url", url, *FAST, "--duration", "2"]) == 2
    assert "drives only the demo line" in capsys.readouterr().err


def test_simulate_without_a_server_says_so(capsys: pytest.CaptureFixture[str]) -> None:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]  # nothing listens there once closed
    assert main(["simulate", "--url", f"http://127.0.0.1:{port}", "--wait", "1"]) == 2
    assert "no server answers" in capsys.readouterr().err


def test_simulate_drives_only_the_demo_sections_beside_others(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """An operator's own free section beside the demo line is left alone (found by the
    independent trial: the simulator died with StopIteration on it)."""
    with live_server(tmp_path) as url:
        assert main(["simulate", "--url", url, *FAST, "--duration", "1"]) == 0
        for station in ("X", "Y"):
            body = {"id": station, "name": station}
            assert httpx.post(f"{url}/api/v1/stations", json=body, headers=ADMIN).status_code == 201
        section = {"id": "XY", "from_station": "X", "to_station": "Y"}
        assert httpx.post(f"{url}/api/v1/sections", json=section, headers=ADMIN).status_code == 201
        assert main(["simulate", "--url", url, *FAST, "--duration", "4"]) == 0
        assert {run["section"] for run in _runs(url)} <= {"AB", "BC"}
    out = capsys.readouterr().out
    assert "departs" in out and "?" not in out.replace("?run", "")
