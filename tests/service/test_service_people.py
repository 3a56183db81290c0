"""People and devices as a railway operator meets them (found by the independent trial, each
test written first): a person who left and came back is added again under their own name, staff
names in Ukrainian or Russian are names, and a decommissioned device is told so."""

from __future__ import annotations

import json
import unicodedata
from pathlib import Path

import pytest
from fastapi.testclient import TestClient
from sqlalchemy.orm import Session, sessionmaker

from core.errors import Unprocessable
from service.cli import main
from service.setup.credentials import add_user, revoke_user
from tests.conftest import ADMIN
from tests.service.linekit import build_line, event
from tests.service.test_service_cli import cli_data_dir  # noqa: F401  (the CLI's fixture)
from transports.envelope import Message, handle_batch


def _bearer(token: str) -> dict[str, str]:
    return {"Authorization": f"Bearer {token}"}


def test_a_revoked_person_who_comes_back_is_added_again(client: TestClient) -> None:
    """`user add` on a revoked name gives a fresh token (the old one stays dead), audited."""
    first = client.post("/api/v1/users", json={"name": "petro", "role": "engineer"}, headers=ADMIN)
    old = first.json()["token"]
    assert client.post("/api/v1/users/petro/revoke", headers=ADMIN).status_code == 200
    back = client.post("/api/v1/users", json={"name": "petro", "role": "dispatcher"}, headers=ADMIN)
    assert back.status_code == 201, back.text
    assert back.json()["revoked_at"] is None and back.json()["role"] == "dispatcher"
    new = back.json()["token"]
    assert new != old
    assert client.get("/api/v1/sections", headers=_bearer(new)).status_code == 200
    assert client.get("/api/v1/sections", headers=_bearer(old)).status_code == 401
    changes = client.get("/api/v1/credential-changes?subject=petro", headers=ADMIN).json()
    assert [c["action"] for c in changes] == ["user_readded", "user_revoked", "user_added"]
    assert "dispatcher" in changes[0]["detail"] and "revoked" in changes[0]["detail"]
    # An active person is still not added twice: their token is rotated instead.
    again = client.post("/api/v1/users", json={"name": "petro", "role": "engineer"}, headers=ADMIN)
    assert again.status_code == 409 and "rotate" in again.json()["detail"]


def test_a_revoked_person_is_added_again_from_the_cli(
    cli_data_dir: Path,  # noqa: F811
    capsys: pytest.CaptureFixture[str],
) -> None:
    assert main(["migrate"]) == 0
    assert main(["user", "add", "Олена Коваль", "--role", "dispatcher"]) == 0
    assert main(["user", "revoke", "Олена Коваль"]) == 0
    capsys.readouterr()
    assert main(["user", "rotate", "Олена Коваль"]) == 2
    assert "depot user add" in capsys.readouterr().err
    assert main(["user", "add", "Олена Коваль", "--role", "engineer"]) == 0
    out = capsys.readouterr().out
    assert "added again" in out and "Олена Коваль" in out
    assert main(["user", "list"]) == 0
    listed = [line for line in capsys.readouterr().out.splitlines() if "Олена" in line]
    assert len(listed) == 1 and "engineer" in listed[0] and listed[0].endswith("active")


GOOD_NAMES = ["Олена Коваль", "Petro-Ivanenko", "Мар'яна Петрук", "Анна-Марія О. Шевченко",
              "ölena", "olena.p-2", "Ivan_2", "Сергій Ковальчук-Горбань",
              "Łukasz Żółw"]  # fmt: skip
BAD_NAMES = [
    "",
    " ",
    "a" * 65,
    "Олена\tКоваль",  # a control character
    "Олена\u202eКоваль",  # a right-to-left override
    "Оле\u200bна",  # a zero-width space
    "Олeна",  # Cyrillic with a Latin 'e' inside one word: a look-alike
    "Ivan/admin",
    "x;drop",
    "---",
    "'.'",
    "12 34",  # no letter at all
    "-x",
]


def test_staff_names_in_any_alphabet_are_names(client: TestClient, session: Session) -> None:
    """One rule, the API's and the CLI's: letters of one script per word, digits, single spaces,
    '-', '.', '_' and apostrophes; stored in NFC."""
    for name in GOOD_NAMES:
        answer = client.post(
            "/api/v1/users", json={"name": name, "role": "engineer"}, headers=ADMIN
        )
        assert answer.status_code == 201, (name, answer.text)
        assert answer.json()["name"] == unicodedata.normalize("NFC", name)
        token = answer.json()["token"]
        assert client.get("/api/v1/sections", headers=_bearer(token)).status_code == 200
    for name in BAD_NAMES:
        answer = client.post(
            "/api/v1/users", json={"name": name, "role": "engineer"}, headers=ADMIN
        )
        assert answer.status_code == 422, name
        assert answer.headers["content-type"].startswith("application/problem+json")
        assert "name" in answer.json()["detail"]
        with pytest.raises(Unprocessable, match="name"):
            add_user(session, name, "engineer", actor="test")


def test_names_are_stored_in_one_normal_form(client: TestClient, session: Session) -> None:
    decomposed = unicodedata.normalize("NFD", "Йосип Ґудзь")  # И + combining breve, Г + mark
    assert decomposed != "Йосип Ґудзь"
    user, _ = add_user(session, decomposed, "engineer", actor="test")
    assert user.name == "Йосип Ґудзь"
    session.commit()  # a refused request rolls its session back
    answer = client.post("/api/v1/users", json={"name": "Йосип Ґудзь", "role": "engineer"},
                         headers=ADMIN)  # fmt: skip
    assert answer.status_code == 409
    # The same person in another case is the same name: refused, not a look-alike second user.
    upper = client.post("/api/v1/users", json={"name": "ЙОСИП ҐУДЗЬ", "role": "engineer"},
                        headers=ADMIN)  # fmt: skip
    assert upper.status_code == 409
    revoke_user(session, decomposed, actor="test")  # the NFD spelling finds the NFC row


DECOMMISSIONED = "is decommissioned"


def test_a_decommissioned_device_is_told_so(client: TestClient, session: Session) -> None:
    """Its 401 said the key was 'not known'; it names the decommissioning, on HTTP and in the
    MQTT/NATS answers (the same problem+json detail, http_status 401)."""
    keys = build_line(client)
    key = keys["A-ac"]["X-Device-Key"]
    assert client.post("/api/v1/devices/A-ac/decommission", headers=ADMIN).status_code == 200
    body = event("dec-1", "heartbeat")
    answer = client.post("/api/v1/events", json=body, headers=keys["A-ac"])
    assert answer.status_code == 401
    assert answer.headers["content-type"].startswith("application/problem+json")
    detail = answer.json()["detail"]
    assert DECOMMISSIONED in detail and "A-ac" in detail, detail
    batch = client.post("/api/v1/events", json={"events": [body]}, headers=keys["A-ac"])
    assert batch.status_code == 401 and DECOMMISSIONED in batch.json()["detail"]

    sessions = sessionmaker(bind=session.connection(), join_transaction_mode="create_savepoint")
    answers = handle_batch(
        sessions, [Message("A-ac", key, json.dumps(body).encode())], transport="mqtt",
        max_bytes=1 << 20,
    )  # fmt: skip
    sent = json.loads(answers[0].to_json())
    assert sent["http_status"] == 401 and sent["detail"] == detail, sent
