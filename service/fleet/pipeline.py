"""Overlapping the fleet job's reading, computing and writing with bounded queues.

The database does its part of reading and writing in its own server process, so a
reader thread (on its own connection) and a writer thread (on the job's session)
keep it busy while the job's thread computes. Queues are bounded, so at most
``depth`` items wait at each hand-over and memory stays flat however large the
fleet. An exception in either thread is raised again in the job's thread.
"""

from __future__ import annotations

import queue
import threading
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from types import TracebackType
from typing import Generic, TypeVar

T = TypeVar("T")
_POLL_S = 0.1  # how often a blocked thread checks whether the other side has stopped


@dataclass(frozen=True)
class _Failed:
    error: BaseException


_END = object()


def read_ahead(produce: Callable[[], Iterator[T]], *, depth: int) -> Iterator[T]:
    """Yield ``produce()``'s items, produced in a thread at most ``depth`` items ahead.

    Stopping early (``close()`` or garbage collection of the generator) stops the thread.
    """
    items: queue.Queue[object] = queue.Queue(maxsize=depth)
    stop = threading.Event()

    def put(item: object) -> bool:
        while not stop.is_set():
            try:
                items.put(item, timeout=_POLL_S)
                return True
            except queue.Full:
                continue
        return False

    def run() -> None:
        try:
            for item in produce():
                if not put(item):
                    return
            put(_END)
        except BaseException as exc:  # handed to the consumer, raised there
            put(_Failed(exc))

    thread = threading.Thread(target=run, name="fleet-reader", daemon=True)
    thread.start()
    try:
        while True:
            item = items.get()
            if item is _END:
                return
            if isinstance(item, _Failed):
                raise item.error
            yield item  # type: ignore[misc]
    finally:
        stop.set()
        thread.join()


class Writer(Generic[T]):
    """Run ``write(batch)`` in a thread for every submitted batch, in order.

    Use as a context manager: leaving it waits for every batch to be written and
    raises the first write error (a failed write stops the writer; later
    ``submit`` calls raise it at once).
    """

    def __init__(self, write: Callable[[T], None], *, depth: int) -> None:
        self._write = write
        self._batches: queue.Queue[object] = queue.Queue(maxsize=depth)
        self._error: BaseException | None = None
        self._thread = threading.Thread(target=self._run, name="fleet-writer", daemon=True)

    def __enter__(self) -> Writer[T]:
        self._thread.start()
        return self

    def _run(self) -> None:
        while (batch := self._batches.get()) is not _END:
            if self._error is None:
                try:
                    self._write(batch)  # type: ignore[arg-type]
                except BaseException as exc:  # raised in the job's thread
                    self._error = exc

    def submit(self, batch: T) -> None:
        """Queue ``batch`` (blocks while ``depth`` batches wait)."""
        if self._error is not None:
            raise self._error
        self._batches.put(batch)

    def __exit__(
        self,
        kind: type[BaseException] | None,
        error: BaseException | None,
        trace: TracebackType | None,
    ) -> None:
        self._batches.put(_END)
        self._thread.join()
        if self._error is not None and error is None:
            raise self._error
