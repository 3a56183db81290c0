"""A request body that does not arrive in time is cut off (408), and a connection that does
not finish its headers is closed, on a real uvicorn server run as ``depot serve`` runs it.

A client that sends its headers and then its body a byte at a time (slowloris), or a
device whose link dies mid-upload, held a worker's request open for ever: uvicorn has no
body timeout. ``DEPOT_BODY_TIMEOUT_S`` bounds the whole body from the request's start.
Connections that never finished their headers were held for ever too, until an
independent trial's 20,000 of them left the server unable to accept anyone;
``DEPOT_HEADER_TIMEOUT_S`` closes them.
"""

from __future__ import annotations

import json
import logging
import socket
import struct
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any, cast
from urllib.parse import urlsplit

import pytest
from fastapi.testclient import TestClient

from tests.service.linekit import build_line, event
from tests.service.livekit import live_client, live_server

DEADLINE_S = 3.0
"""The body deadline of these tests' server: long enough for a loaded CI machine to pass
a body sent in two parts, short enough that the slow ones end soon."""
HEADERS_S = 2.0
"""The header deadline of these tests' server: shorter than the body's, so a slow body
cut at 3 s (408) also shows that a request whose headers arrived is not cut at 2 s."""
WAIT_S = 15.0
"""How long a test waits for the server's answer (without a deadline it never comes)."""


@pytest.fixture(scope="module")
def server(
    tmp_path_factory: pytest.TempPathFactory,
) -> Iterator[tuple[str, dict[str, dict[str, str]]]]:
    with pytest.MonkeyPatch.context() as patch:
        patch.setenv("DEPOT_BODY_TIMEOUT_S", str(DEADLINE_S))
        patch.setenv("DEPOT_HEADER_TIMEOUT_S", str(HEADERS_S))
        with live_server(tmp_path_factory.mktemp("deadline")) as url:
            with live_client(url) as client:
                keys = build_line(cast(TestClient, client))
            yield url, keys


def _send(url: str, head: str, parts: list[tuple[float, bytes]]) -> tuple[int, bytes, float]:
    """Send ``head`` then each part after its pause; read the answer until the server closes.

    Returns the status, the answer's body and the seconds from the headers to the answer.
    """
    where = urlsplit(url)
    with socket.create_connection((where.hostname, where.port), timeout=WAIT_S) as conn:
        conn.sendall(head.encode("latin-1"))
        started = time.monotonic()
        for pause, data in parts:
            time.sleep(pause)
            try:
                conn.sendall(data)
            except (BrokenPipeError, ConnectionResetError):
                break  # the server answered and closed: read its answer
        answer = b""
        while True:
            chunk = conn.recv(65536)  # socket.timeout here: the server never answered
            if not chunk:
                break
            answer += chunk
            if _complete(answer):
                break
        elapsed = time.monotonic() - started
    status = int(answer.split(b" ", 2)[1])
    return status, answer.split(b"\r\n\r\n", 1)[1], elapsed


def _complete(answer: bytes) -> bool:
    if b"\r\n\r\n" not in answer:
        return False
    head, body = answer.split(b"\r\n\r\n", 1)
    for line in head.lower().split(b"\r\n"):
        if line.startswith(b"content-length:"):
            return len(body) >= int(line.split(b":")[1])
    return False


def _head(path: str, key: dict[str, str], content_type: str, length: int) -> str:
    headers = {"Host": "depot", "Content-Type": content_type, "Content-Length": str(length)}
    headers.update(key)
    return (
        f"POST {path} HTTP/1.1\r\n" + "".join(f"{k}: {v}\r\n" for k, v in headers.items()) + "\r\n"
    )


def _axle_count(
    keys: dict[str, dict[str, str]], event_id: str
) -> tuple[dict[str, str], bytes, str]:
    """The axle counter's key, an event's body and the headers that announce it."""
    key = keys["B-ac"]
    fields: dict[str, Any] = event(event_id, "axle_count", section="AB", axles=212)
    body = json.dumps(fields).encode()
    return key, body, _head("/api/v1/events", key, "application/json", len(body))


def test_an_event_body_that_stops_coming_is_refused_408_and_not_stored(
    server: tuple[str, dict[str, dict[str, str]]],
) -> None:
    url, keys = server
    key, body, head = _axle_count(keys, "slow-1")
    status, answer, elapsed = _send(url, head, [(0.0, body[:10])])
    assert status == 408, answer
    problem = json.loads(answer)
    assert problem["status"] == 408 and "DEPOT_BODY_TIMEOUT_S" in problem["detail"]
    assert DEADLINE_S - 0.5 <= elapsed <= DEADLINE_S + 5
    # Nothing of it was kept: the whole event, sent again, is new (201, not a repeat's 200).
    with live_client(url) as client:
        again = client.post("/api/v1/events", content=body, headers={**key, **_json()})
    assert again.status_code == 201, again.text


def test_a_trickled_body_is_cut_off_at_the_deadline_not_per_byte(
    server: tuple[str, dict[str, dict[str, str]]],
) -> None:
    """A byte every half second never lets a per-read timeout fire; the deadline does."""
    url, keys = server
    _, body, head = _axle_count(keys, "slow-2")
    status, _, elapsed = _send(url, head, [(0.5, body[i : i + 1]) for i in range(12)])
    assert status == 408
    assert elapsed <= DEADLINE_S + 5


def test_a_snapshot_upload_that_stops_coming_is_refused_408(
    server: tuple[str, dict[str, dict[str, str]]],
) -> None:
    url, keys = server
    key = keys["B-cam"]
    boundary = "b0undary"
    start = (
        f'--{boundary}\r\nContent-Disposition: form-data; name="image"; filename="t.jpg"\r\n'
        "Content-Type: image/jpeg\r\n\r\n\xff\xd8\xff\xe0"
    ).encode("latin-1")
    head = _head("/api/v1/snapshots", key, f"multipart/form-data; boundary={boundary}", 500_000)
    status, answer, elapsed = _send(url, head, [(0.0, start)])
    assert status == 408, answer
    assert json.loads(answer)["status"] == 408
    assert elapsed <= DEADLINE_S + 5


def test_a_body_sent_in_parts_within_the_deadline_is_accepted(
    server: tuple[str, dict[str, dict[str, str]]],
) -> None:
    url, keys = server
    _, body, head = _axle_count(keys, "parts-1")
    half = len(body) // 2
    status, answer, _ = _send(url, head, [(0.0, body[:half]), (0.5, body[half:])])
    assert status == 201, answer


def _closed_after(url: str, sent: bytes, *, answered_first: bytes = b"") -> float:
    """Seconds until the server closes a connection that sent ``answered_first`` (one whole
    request, answered) and then ``sent``; socket.timeout when it never does."""
    where = urlsplit(url)
    with socket.create_connection((where.hostname, where.port), timeout=WAIT_S) as conn:
        if answered_first:
            conn.sendall(answered_first)
            answer = b""
            while not _complete(answer):
                answer += conn.recv(65536)
            assert answer.startswith(b"HTTP/1.1 200"), answer
        conn.sendall(sent)
        started = time.monotonic()
        while conn.recv(65536):
            pass
        return time.monotonic() - started


@pytest.mark.parametrize(
    "sent",
    [b"", b"POST /api/v1/events HTTP/1.1\r\nHost: depot\r\n", b"GET /heal"],
    ids=["nothing", "half the headers", "half the request line"],
)
def test_a_connection_that_never_finishes_its_headers_is_closed(
    server: tuple[str, dict[str, dict[str, str]]], sent: bytes
) -> None:
    assert HEADERS_S - 0.5 <= _closed_after(server[0], sent) <= HEADERS_S + 5


def test_a_kept_alive_connection_that_stalls_in_its_next_headers_is_closed(
    server: tuple[str, dict[str, dict[str, str]]],
) -> None:
    """uvicorn's keep-alive timeout ends at the first byte of the next request."""
    first = b"GET /healthz HTTP/1.1\r\nHost: depot\r\n\r\n"
    elapsed = _closed_after(server[0], b"GET /healthz HTTP/1.1\r\nHo", answered_first=first)
    assert elapsed <= HEADERS_S + 5


def _json() -> dict[str, str]:
    return {"Content-Type": "application/json"}


def test_the_deadline_is_a_documented_setting_with_a_bound() -> None:
    from pydantic import ValidationError

    from core.settings import Settings

    # 10 MB over a slow station link; this module's server runs with a short one.
    assert Settings.model_fields["body_timeout_s"].default >= 60
    with pytest.raises(ValidationError):
        Settings(body_timeout_s=0)
    readme = (Path(__file__).resolve().parents[2] / "README.md").read_text()
    assert "DEPOT_BODY_TIMEOUT_S" in readme


def test_a_snapshot_upload_whose_client_goes_away_logs_no_traceback(
    server: tuple[str, dict[str, dict[str, str]]], caplog: pytest.LogCaptureFixture
) -> None:
    """A camera on a flaky link that drops mid-upload (a reset): nothing stored, and no
    ERROR traceback ("Exception in ASGI application") for each one, as for events."""
    url, keys = server
    head = _head("/api/v1/snapshots", keys["B-cam"], "multipart/form-data; boundary=b0", 500_000)
    part = b'--b0\r\nContent-Disposition: form-data; name="image"; filename="t.jpg"\r\n\r\n'
    where = urlsplit(url)
    with caplog.at_level(logging.ERROR):
        for _ in range(3):
            conn = socket.create_connection((where.hostname, where.port), timeout=WAIT_S)
            conn.sendall(head.encode("latin-1") + part + b"\xff\xd8" + b"\0" * 200_000)
            time.sleep(0.2)
            conn.setsockopt(socket.SOL_SOCKET, socket.SO_LINGER, struct.pack("ii", 1, 0))
            conn.close()  # a reset, not an orderly close
        time.sleep(1.0)  # the server notices the reset
    tracebacks = [r for r in caplog.records if r.levelno >= logging.ERROR]
    assert not tracebacks, [r.getMessage() for r in tracebacks]
