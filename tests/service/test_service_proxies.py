"""DEPOT_TRUSTED_PROXIES: behind a trusted reverse proxy the app sees the client's address and
the TLS scheme (so the review login's Secure cookie is right); anyone else's headers are ignored."""

from __future__ import annotations

import pytest
from fastapi import Request
from fastapi.testclient import TestClient
from pydantic import ValidationError

from core.settings import Settings, get_settings

FORWARDED = {"X-Forwarded-For": "10.20.30.40", "X-Forwarded-Proto": "https"}


def test_a_trusted_proxy_passes_the_client_address_and_scheme(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    for peer, want in (
        ("127.0.0.1", ("10.20.30.40", "https")),
        ("172.18.0.5", ("10.20.30.40", "https")),  # a compose network
        ("192.0.2.7", ("192.0.2.7", "http")),  # not a proxy we trust: headers ignored
    ):
        assert _where(monkeypatch, "127.0.0.1,172.16.0.0/12", peer) == want, peer


def test_no_trusted_proxy_ignores_the_headers(monkeypatch: pytest.MonkeyPatch) -> None:
    assert _where(monkeypatch, "", "127.0.0.1") == ("127.0.0.1", "http")


def _where(monkeypatch: pytest.MonkeyPatch, proxies: str, peer: str) -> tuple[str, str]:
    monkeypatch.setenv("DEPOT_TRUSTED_PROXIES", proxies)
    get_settings.cache_clear()
    try:
        from service.app import create_app

        app = create_app()

        @app.get("/_where")
        def where(request: Request) -> dict[str, str]:
            assert request.client is not None
            return {"client": request.client.host, "scheme": request.url.scheme}

        with TestClient(app, client=(peer, 40000)) as client:
            body = client.get("/_where", headers=FORWARDED).json()
        return body["client"], body["scheme"]
    finally:
        get_settings.cache_clear()


@pytest.mark.parametrize("bad", ["localhost", "10.0.0.0/33", "127.0.0.1;rm"])
def test_a_wrong_proxy_address_is_refused_at_start(bad: str) -> None:
    with pytest.raises(ValidationError, match="DEPOT_TRUSTED_PROXIES"):
        Settings(trusted_proxies=bad)
