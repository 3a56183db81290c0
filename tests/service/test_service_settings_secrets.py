"""A weak admin (or metrics) token is refused in production even when it is long: 'aaaa…',
a short pattern repeated, a run of the keyboard (found by the independent trial, test first).
The message is one line naming the setting and how to make a good one, never the value."""

from __future__ import annotations

import secrets

import pytest
from pydantic import ValidationError

from core.settings import Settings
from service.cli import settings_problem

PG = "postgresql+psycopg://db/depot"
WEAK = ["a" * 40, "Zq7" * 15, "abcd1234" * 4, "abcdefghijklmnopqrstuvwxyz", "0123456789" * 3,
        "aaaaaaaaaaaaaaaaaaaaaaaaaaaaab", "password" * 4]  # fmt: skip


@pytest.mark.parametrize("token", WEAK)
def test_a_weak_long_admin_token_is_refused(token: str) -> None:
    with pytest.raises(ValidationError) as caught:
        Settings(environment="production", admin_token=token, database_url=PG)
    message = settings_problem(caught.value)
    assert "DEPOT_ADMIN_TOKEN" in message and "openssl rand" in message, message
    assert token[:6] not in message and "\n" not in message, message


@pytest.mark.parametrize("token", WEAK[:3])
def test_a_weak_metrics_token_is_refused(token: str) -> None:
    with pytest.raises(ValidationError) as caught:
        Settings(
            environment="production", admin_token=secrets.token_urlsafe(32), database_url=PG,
            metrics_token=token,
        )  # fmt: skip
    message = settings_problem(caught.value)
    assert "DEPOT_METRICS_TOKEN" in message and token[:6] not in message, message


def test_a_random_hex_token_with_seven_distinct_digits_is_accepted() -> None:
    """One 24-digit random hex token in about 40,000 shows only 7 distinct digits; the
    thousand-token test below met one in CI and the token was refused."""
    Settings(environment="production", admin_token="3a9f0c73fa9c07a3f97c0a93", database_url=PG)


def test_generated_tokens_are_accepted() -> None:
    """What the message tells people to run always passes (a thousand of each kind)."""
    for _ in range(1000):
        for token in (secrets.token_urlsafe(32), secrets.token_hex(16), secrets.token_hex(12)):
            Settings(environment="production", admin_token=token, database_url=PG,
                     metrics_token=secrets.token_urlsafe(24))  # fmt: skip


@pytest.mark.parametrize("period", [1.0, 5.0, 19.9])
def test_a_heartbeat_period_near_the_liveness_step_is_refused(period: float) -> None:
    """``last_seen_at`` moves in 5 s steps: with a period of 5 s a device heard every second
    was shown stale every 5 s (an independent trial). The message names the setting."""
    with pytest.raises(ValidationError) as caught:
        Settings(heartbeat_s=period)
    assert "DEPOT_HEARTBEAT_S" in settings_problem(caught.value)
