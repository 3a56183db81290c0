"""``depot mqtt --workers N``: N bridge processes on the one shared subscription.

One bridge process is bound by one interpreter (its network thread and its storing thread take
turns); N processes, each its own MQTT connection, persistent session and database
connection, split the broker's messages between them (``$share/depot/...``). Worker ``k``
connects as ``{client id}-{k}`` (with one worker: the client id itself), a stable id, so that a
worker restarted after a crash resumes its own session and gets back what it had not
acknowledged. Keep N stable: what the broker queued in the session of a worker that no longer
runs waits there until a bridge with that id connects again.
"""

from __future__ import annotations

import logging
import multiprocessing
import signal
import time
from collections.abc import Callable
from dataclasses import replace
from multiprocessing.process import BaseProcess

from transports.mqtt import MqttConfig

log = logging.getLogger("depot.mqtt")
RESTART_AFTER_S = 1.0  # a worker that died is started again after this long


def worker_configs(config: MqttConfig, workers: int) -> list[MqttConfig]:
    """One configuration per worker, each with its own stable client id."""
    if workers < 1:
        raise ValueError(f"--workers must be at least 1, not {workers}")
    if workers == 1:
        return [config]
    return [replace(config, client_id=f"{config.client_id}-{k}") for k in range(1, workers + 1)]


def serve_workers(run: Callable[[MqttConfig], None], config: MqttConfig, workers: int) -> None:
    """Run ``run(config)`` in one process per worker until SIGTERM or SIGINT (passed on to
    every worker, which finishes and acknowledges its batch in hand); a worker that dies is
    started again."""
    context = multiprocessing.get_context("fork")  # the handler table installed is inherited
    configs = worker_configs(config, workers)
    # A plain flag, not an Event: a signal handler must take no lock the main thread may hold
    # (Event.wait holds its condition's lock while it wakes up).
    stopping: list[bool] = []

    def start(one: MqttConfig) -> BaseProcess:
        process = context.Process(target=run, args=(one,), name=one.client_id)
        process.start()
        return process

    processes = [start(one) for one in configs]
    for sig in (signal.SIGTERM, signal.SIGINT):
        signal.signal(sig, lambda *_: stopping.append(True))
    while not stopping:
        time.sleep(RESTART_AFTER_S)
        for k, process in enumerate(processes):
            if not stopping and not process.is_alive():
                log.error(
                    "worker %s exited (%s); starting it again", process.name, process.exitcode
                )
                processes[k] = start(configs[k])
    for process in processes:
        if process.pid is not None and process.is_alive():
            process.terminate()  # SIGTERM: the worker's batch in hand is finished first
    for process in processes:
        process.join()
