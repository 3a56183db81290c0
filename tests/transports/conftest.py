"""One line on one PostgreSQL database, shared by the package's tests (in file order): two
``depot serve``, one ``depot mqtt``, two ``depot consume``, the 50 simulated devices, and
device clients of both brokers."""

from __future__ import annotations

import os
import threading
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import pytest
from sqlalchemy import Engine
from sqlalchemy.orm import Session, sessionmaker

from core.auth import device_cache
from tests.reliability.conftest import ADMIN_HEADERS
from tests.reliability.loadgen import Device, Payloads, build_line
from tests.reliability.relkit import Server, depot_env, scratch_database
from tests.transports.tkit import (
    Answers,
    MqttDevices,
    NatsDevices,
    Process,
    RunNames,
    bridge,
    brokers,
    consumer,
)

MAX_BODY_BYTES = 256 * 1024  # small, so the oversize case is cheap to send
ACK_WAIT_S = 2.0  # a killed consumer's messages come again to the other after this


@dataclass
class Line:
    database_url: str
    env: dict[str, str]
    names: RunNames
    servers: list[Server]
    bridge: Process
    consumers: list[Process]
    devices: list[Device]
    answers: Answers
    mqtt: MqttDevices
    nats: NatsDevices


@pytest.fixture(scope="package")
def line(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Line]:
    names = RunNames()
    data_dir: Path = tmp_path_factory.mktemp("transports")
    with (
        brokers(names) as (answers, mqtt_devices, nats_devices),
        scratch_database(f"depot_test_transports_{os.getpid()}") as url,
    ):
        env = {
            **depot_env(url, data_dir),
            **names.env(),
            "DEPOT_MAX_BODY_BYTES": str(MAX_BODY_BYTES),
            "DEPOT_NATS_ACK_WAIT_S": str(ACK_WAIT_S),
        }
        servers = [Server(url, data_dir, workers=1) for _ in range(2)]
        for n, server in enumerate(servers):
            server.env = env
            server.log_path = data_dir / f"server-{n}.log"
        servers[0].migrate()
        the_bridge = bridge(env, data_dir)
        consumers = [consumer(env, data_dir, n) for n in range(2)]
        try:
            for process in (the_bridge, *consumers):
                process.launch()  # they import while the servers start
            for server in servers:
                server.start()
            for process in (the_bridge, *consumers):
                process.wait_ready()
            devices = build_line(servers[0].url, ADMIN_HEADERS)
            yield Line(
                url, env, names, servers, the_bridge, consumers, devices,
                answers, mqtt_devices, nats_devices,
            )  # fmt: skip
        finally:
            stops = [p.stop for p in (*consumers, the_bridge)] + [s.stop for s in servers]
            threads = [threading.Thread(target=stop) for stop in stops]
            for thread in threads:
                thread.start()
            for thread in threads:
                thread.join()


@pytest.fixture(scope="package")
def payloads() -> Payloads:
    return Payloads()


@pytest.fixture
def committed(engine: Engine) -> Iterator[sessionmaker[Session]]:
    """Committing sessions on the suite's shared database, emptied afterwards as
    ``committed_app`` does: every other test there finds it empty at rest (each rolls back),
    and one counts every raw event it sees."""
    from service.models import metadata

    yield sessionmaker(engine, expire_on_commit=False)
    with engine.begin() as connection:
        for table in reversed(metadata.sorted_tables):
            connection.execute(table.delete())
    device_cache().invalidate()  # the keys looked up here name devices that are gone
