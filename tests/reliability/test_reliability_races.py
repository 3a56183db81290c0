"""Races a device's retry can cause: the same upload handled twice at once in one worker."""

from __future__ import annotations

import threading
from pathlib import Path

from ingest.snapshots import check_image, store_image
from tests.reliability.hostile import small_image


def test_same_image_stored_by_eight_threads_at_once(tmp_path: Path) -> None:
    errors: list[BaseException] = []
    for attempt in range(10):
        data = small_image("JPEG", (1600, 1200)) + bytes(attempt)
        checked = check_image(data, max_bytes=10 << 20, max_pixels=40_000_000)
        start = threading.Barrier(8, timeout=30)

        def store(
            data: bytes = data, checked: object = checked, start: threading.Barrier = start
        ) -> None:
            start.wait()
            try:
                store_image(tmp_path, checked, data)  # type: ignore[arg-type]
            except BaseException as exc:
                errors.append(exc)

        threads = [threading.Thread(target=store) for _ in range(8)]
        for thread in threads:
            thread.start()
        for thread in threads:
            thread.join(timeout=30)
    assert not errors, f"{len(errors)} of 80 concurrent stores failed: {errors[0]!r}"
    assert not list(tmp_path.rglob("*.tmp")), "temporary files left behind"
