"""The fleet job's pipeline stages: order kept, bounded, errors raised in the job's thread."""

from __future__ import annotations

import threading
from collections.abc import Iterator

import pytest

from service.fleet.pipeline import Writer, read_ahead


def test_read_ahead_keeps_order_and_stays_bounded() -> None:
    produced: list[int] = []

    def produce() -> Iterator[int]:
        for i in range(50):
            produced.append(i)
            yield i

    seen: list[int] = []
    for item in read_ahead(produce, depth=3):
        # the reader may be at most depth (+1 in hand) items ahead of the consumer
        assert len(produced) - len(seen) <= 5
        seen.append(item)
    assert seen == list(range(50))


def test_read_ahead_raises_the_readers_error_here() -> None:
    def produce() -> Iterator[int]:
        yield 1
        raise RuntimeError("connection lost")

    stream = read_ahead(produce, depth=2)
    assert next(stream) == 1
    with pytest.raises(RuntimeError, match="connection lost"):
        next(stream)


def test_read_ahead_stopped_early_stops_the_thread() -> None:
    def produce() -> Iterator[int]:
        yield from range(10_000)

    stream = read_ahead(produce, depth=2)
    assert next(stream) == 0
    stream.close()  # type: ignore[attr-defined]
    assert not any(t.name == "fleet-reader" for t in threading.enumerate())


def test_writer_writes_every_batch_in_order() -> None:
    written: list[list[int]] = []
    with Writer(written.append, depth=1) as writer:
        for i in range(20):
            writer.submit([i, i])
    assert written == [[i, i] for i in range(20)]


def test_writer_error_is_raised_and_stops_later_writes() -> None:
    written: list[int] = []

    def write(batch: int) -> None:
        if batch == 3:
            raise ValueError("duplicate key")
        written.append(batch)

    with pytest.raises(ValueError, match="duplicate key"), Writer(write, depth=1) as writer:
        for i in range(10):
            writer.submit(i)
    assert written == [0, 1, 2]
