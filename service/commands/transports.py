"""``depot mqtt`` (the MQTT 5 bridge) and ``depot consume`` (the JetStream consumer)."""

from __future__ import annotations

import argparse
import asyncio
import logging
import socket
from typing import Any

from core.database import get_sessionmaker
from core.settings import get_settings
from service.commands._common import fail, number

# Bridge processes on one shared subscription: each is one broker connection and one
# database connection; past a few per core they only contend.
BRIDGE_WORKERS = number(int, low=1, high=32)


def _logging() -> None:
    logging.basicConfig(
        level=logging.INFO, format="%(asctime)s %(levelname)s %(name)s: %(message)s"
    )


def _mqtt(args: argparse.Namespace) -> int:
    from service import features  # imported when used: every feature, paho
    from transports.mqtt import Bridge, MqttConfig, broker_address
    from transports.mqtt_workers import serve_workers

    settings = get_settings()
    url = args.broker or settings.mqtt_url
    try:
        broker_address(url)
    except ValueError as exc:
        return fail(f"{exc} (set --broker or DEPOT_MQTT_URL)")
    config = MqttConfig(
        broker_url=url,
        client_id=settings.mqtt_client_id or f"depot-{socket.gethostname()}",
        prefix=settings.mqtt_prefix,
        inflight=settings.mqtt_inflight,
        batch=settings.transport_batch,
        max_bytes=settings.max_body_bytes,
    )
    if args.workers < 1:
        return fail(f"--workers must be at least 1, not {args.workers}")
    features.install()  # the same handler table as the HTTP app
    _logging()
    if args.workers == 1:
        Bridge(get_sessionmaker(), config).serve()
    else:  # each worker process opens its own database connections
        serve_workers(lambda one: Bridge(get_sessionmaker(), one).serve(), config, args.workers)
    return 0


def _consume(args: argparse.Namespace) -> int:
    from service import features
    from transports.jetstream import ConsumeConfig, Consumer, StreamNames

    settings = get_settings()
    url = args.nats or settings.nats_url
    if not url.startswith(("nats://", "tls://")):
        return fail(f"not a NATS URL: {url!r}; write nats://HOST:PORT (--nats or DEPOT_NATS_URL)")
    config = ConsumeConfig(
        url=url,
        names=StreamNames(settings.nats_prefix),
        replicas=settings.nats_replicas,
        ack_wait_s=settings.nats_ack_wait_s,
        max_deliver=settings.nats_max_deliver,
        batch=settings.transport_batch,
        max_bytes=settings.max_body_bytes,
    )
    features.install()
    _logging()
    asyncio.run(Consumer(get_sessionmaker(), config).run())
    return 0


def register(sub: Any) -> None:
    mqtt = sub.add_parser(
        "mqtt", help="bridge device events from an MQTT 5 broker (ack after commit)"
    )
    mqtt.add_argument("--broker", help="mqtt://HOST:PORT (default: DEPOT_MQTT_URL)")
    mqtt.add_argument(
        "--workers",
        type=BRIDGE_WORKERS,
        default=1,
        help="bridge processes on the shared subscription, client ids ID-1..N, 1 to 32 (default 1)",
    )
    mqtt.set_defaults(func=_mqtt)
    consume = sub.add_parser(
        "consume", help="consume device events from NATS JetStream (ack after commit)"
    )
    consume.add_argument("--nats", help="nats://HOST:PORT (default: DEPOT_NATS_URL)")
    consume.set_defaults(func=_consume)
