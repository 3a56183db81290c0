"""Service settings: one pydantic-settings class, environment prefix ``DEPOT_``."""

from __future__ import annotations

import ipaddress
from functools import lru_cache
from pathlib import Path
from typing import Literal
from zoneinfo import ZoneInfo, ZoneInfoNotFoundError

from pydantic import Field, field_validator, model_validator
from pydantic_settings import BaseSettings, SettingsConfigDict

from core.settings_secrets import GENERATE, secret_problem

DEVELOPMENT_ADMIN_TOKEN = "dev-admin-token"


class Settings(BaseSettings):
    """Everything the service reads from its environment.

    Defaults give a working local service on an embedded SQLite database; in
    ``production`` the unsafe defaults (the well-known admin token, SQLite) are refused.
    """

    model_config = SettingsConfigDict(env_prefix="DEPOT_", env_file=".env", extra="ignore")

    environment: Literal["development", "test", "production"] = "development"
    data_dir: Path = Path("./var")
    database_url: str | None = None
    admin_token: str = DEVELOPMENT_ADMIN_TOKEN
    # At least 20 s: a device's last_seen_at is written once per 5 s step (ingest/liveness.py),
    # so its displayed staleness may come up to one step early; with a 5 s period a device
    # heard every second looked stale every 5 s (an independent trial).
    heartbeat_s: float = Field(default=60.0, ge=20)
    # Events dated further ahead of the server's clock are refused (422): protocol.md.
    max_clock_skew_s: float = Field(default=300.0, ge=0)
    max_image_bytes: int = Field(default=10 * 1024 * 1024, gt=0)
    max_image_pixels: int = Field(default=40_000_000, gt=0)
    max_body_bytes: int = Field(default=8 * 1024 * 1024, gt=0)
    # A request's whole body must arrive within this many seconds of the request's start
    # (408 otherwise): uvicorn waits for a body for ever, so a client that trickles one
    # (slowloris) or a device whose link died mid-upload held a worker's request open.
    # 120 s carries a 10 MB photo at 0.7 Mbit/s; raise it for slower station links.
    body_timeout_s: float = Field(default=120.0, gt=0)
    # A connection must complete a request's headers within this many seconds of opening
    # or of its previous answer, else it is closed (service/header_deadline.py): uvicorn
    # held a connection that never finished its headers for ever.
    header_timeout_s: float = Field(default=20.0, gt=0)
    max_batch: int = Field(default=1000, gt=0, le=1000)
    forecast_every: float | None = Field(
        default=None, gt=0, description="seconds between scheduled forecasts"
    )
    review_refresh_s: int = Field(default=10, ge=2)
    # The dispatcher's time zone (IANA name): every time shown to people (core/timefmt.py).
    time_zone: str = "UTC"
    # How long a worker trusts a device key it has looked up: the revocation bound (≤ 5 s).
    device_key_ttl_s: float = Field(default=2.0, ge=0, le=5)
    # Group commit of single events: how long the first event waits for neighbours (0: off),
    # and how many events share one transaction at most.
    group_commit_ms: float = Field(default=2.0, ge=0, le=50)
    group_commit_max: int = Field(default=64, ge=1, le=1000)
    host: str = "127.0.0.1"
    port: int = 8000
    # One log line per HTTP request (uvicorn's access log). A station fleet sends thousands of
    # events a second, each stored with its receive time; the line costs a worker about 2 % of
    # its CPU per event, so a deployment may turn it off and read /metrics instead.
    access_log: bool = True
    # Reverse proxies whose X-Forwarded-For / X-Forwarded-Proto are believed (comma-separated
    # addresses or CIDR networks, "*" any, "" none): behind them the client address in the
    # logs is the real one and a request that came in over TLS is https (Secure cookies).
    trusted_proxies: str = "127.0.0.1"
    # /metrics (Prometheus text): answered to the admin token, or to this token when set.
    metrics_token: str | None = Field(default=None, min_length=24)
    # Transports (docs/DEPLOYMENT.md): the MQTT bridge and the JetStream consumer.
    mqtt_url: str = "mqtt://127.0.0.1:1883"
    mqtt_prefix: str = Field(default="depot/v1", pattern=r"^[^#+$/]([^#+]*[^#+/])?$")
    mqtt_client_id: str | None = Field(default=None, description="default: depot- + host name")
    mqtt_inflight: int = Field(default=500, ge=1, le=65535, description="MQTT 5 receive maximum")
    nats_url: str = "nats://127.0.0.1:4222"
    nats_prefix: str = Field(default="depot", pattern=r"^[A-Za-z0-9_-]+$")
    nats_replicas: int = Field(default=1, ge=1, le=5)
    nats_ack_wait_s: float = Field(default=30.0, gt=0)
    nats_max_deliver: int = Field(default=10, ge=1)
    transport_batch: int = Field(
        default=200, ge=1, le=1000, description="messages committed together, at most"
    )

    @field_validator("time_zone")
    @classmethod
    def _known_zone(cls, name: str) -> str:
        try:
            ZoneInfo(name)
        except (ZoneInfoNotFoundError, ValueError):
            raise ValueError(
                f"DEPOT_TIME_ZONE {name!r} is not an IANA time zone; use e.g. UTC or Europe/Kyiv"
            ) from None
        return name

    @field_validator("trusted_proxies")
    @classmethod
    def _proxy_addresses(cls, value: str) -> str:
        for item in (part.strip() for part in value.split(",")):
            if item and item != "*":
                try:
                    ipaddress.ip_network(item, strict=False)
                except ValueError:
                    raise ValueError(
                        f"DEPOT_TRUSTED_PROXIES: {item!r} is not an address or network"
                        " (e.g. 127.0.0.1,172.16.0.0/12)"
                    ) from None
        return value

    @property
    def trusted_proxy_list(self) -> list[str]:
        return [part.strip() for part in self.trusted_proxies.split(",") if part.strip()]

    @model_validator(mode="after")
    def _refuse_unsafe_production(self) -> Settings:
        if self.environment != "production":
            return self
        if self.admin_token == DEVELOPMENT_ADMIN_TOKEN:
            raise ValueError(f"DEPOT_ADMIN_TOKEN must be set to a secret in production; {GENERATE}")
        for setting, secret in (
            ("DEPOT_ADMIN_TOKEN", self.admin_token),
            ("DEPOT_METRICS_TOKEN", self.metrics_token),
        ):
            problem = None if secret is None else secret_problem(setting, secret)
            if problem is not None:
                raise ValueError(problem)
        if not (self.database_url or "").startswith("postgresql"):
            # SQLite is for one station's trial; any other engine is not supported at all.
            raise ValueError(
                "DEPOT_DATABASE_URL must point to PostgreSQL in production"
                " (postgresql+psycopg://USER@HOST/DB)"
            )
        return self

    @property
    def resolved_database_url(self) -> str:
        if self.database_url:
            return self.database_url
        return f"sqlite:///{(self.data_dir / 'depot.sqlite3').resolve()}"

    @property
    def image_dir(self) -> Path:
        return self.data_dir / "images"


@lru_cache
def get_settings() -> Settings:
    return Settings()
