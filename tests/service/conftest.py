"""Fixtures the clearance tests share: the demo-like line and a dispatcher's token."""

from __future__ import annotations

import pytest
from fastapi.testclient import TestClient
from sqlalchemy.orm import Session

from service.setup.service import create_user
from tests.service.linekit import build_line
from tests.service.scenario import Line


@pytest.fixture
def line(client: TestClient) -> Line:
    return Line(client, build_line(client))


@pytest.fixture
def dispatcher(session: Session) -> dict[str, str]:
    token = create_user(session, "olena", "dispatcher")
    session.commit()
    return {"Authorization": f"Bearer {token}"}
