"""PostgreSQL bulk read of the fleet's tests: one row per car and layout, arrays as numpy.

Row-per-test fetching costs microseconds a row in Python (2 million rows for 10,000 cars of 200
tests); aggregated per car — times and ids as int8 arrays read in the binary protocol straight
into numpy, readings as one concatenated bytea — a car costs a few microseconds to fetch.
"""

from __future__ import annotations

import itertools
import struct
from collections.abc import Generator
from typing import Any

import numpy as np
from numpy.typing import NDArray
from psycopg.adapt import Buffer, Loader
from psycopg.pq import Format
from sqlalchemy.orm import Session

from service.fleet.blocks import Block
from service.fleet.models import READINGS_DTYPE

INT4_ARRAY_OID = 1007
INT8_ARRAY_OID = 1016
_ROWS_PER_FETCH = 200
_CURSORS = itertools.count()

TIMESTAMPTZ_ARRAY_OID = 1185
PG_EPOCH_US = 946_684_800_000_000  # 2000-01-01 UTC: binary timestamps count µs from there

# Aggregated per car from a subquery in (car, time) order, which the index on (car_id,
# taken_at) delivers without a sort: the server streams the first car at once, and does about
# half the work of grouping by (car, layout) in (car, layout, time, id) order. The aggregates
# keep their input order; ties in time and mixed layouts are sorted out here (rare).
_PER_CAR = """
    SELECT car_id, array_agg(layout_id), array_agg(taken_at), array_agg(id),
           string_agg(readings, ''::bytea)
    FROM (SELECT car_id, layout_id, taken_at, id, readings
          FROM measurements
          WHERE layout_id = ANY(%(layouts)s)
          ORDER BY car_id, taken_at) AS tests
    GROUP BY car_id
    ORDER BY car_id
"""


def _load_array(data: Buffer, item: np.dtype[Any], out: type) -> NDArray[Any]:
    """A binary-format PostgreSQL array without NULLs: header, then (length, value) pairs."""
    ndim = struct.unpack_from("!i", data, 0)[0]
    if ndim == 0:
        return np.zeros(0, dtype=out)
    dims = struct.unpack_from(f"!{2 * ndim}i", data, 12)[::2]
    items = np.frombuffer(data, dtype=item, offset=12 + 8 * ndim)
    return items["value"].astype(out).reshape(dims)


_INT8 = np.dtype([("length", ">i4"), ("value", ">i8")])


_INT4 = np.dtype([("length", ">i4"), ("value", ">i4")])


class Int8ArrayLoader(Loader):
    format = Format.BINARY

    def load(self, data: Buffer) -> NDArray[np.int64]:
        return _load_array(data, _INT8, np.int64)


class Int4ArrayLoader(Loader):
    format = Format.BINARY

    def load(self, data: Buffer) -> NDArray[np.int64]:
        return _load_array(data, _INT4, np.int64)


def car_blocks(
    layouts: NDArray[np.int64],
    epoch_s: NDArray[np.float64],
    ids: NDArray[np.int64],
    readings: bytes,
    widths: dict[int, int],
) -> list[Block]:
    """A car's tests (time order) as one block per layout; ``widths``: values per layout."""
    first = int(layouts[0])
    if np.all(layouts == first):  # the common case: one bench, one layout
        values = np.frombuffer(readings, dtype=READINGS_DTYPE).reshape(epoch_s.shape[0], -1)
        return [Block(first, epoch_s, ids, values)]
    flat = np.frombuffer(readings, dtype=READINGS_DTYPE)
    ends = np.cumsum([widths[int(layout)] for layout in layouts])
    rows = np.split(flat, ends[:-1])
    blocks = []
    for layout in np.unique(layouts):
        where = np.flatnonzero(layouts == layout)
        values = np.stack([rows[i] for i in where])
        blocks.append(Block(int(layout), epoch_s[where], ids[where], values))
    return blocks


def stream_postgresql(
    session: Session, widths: dict[int, int]
) -> Generator[tuple[str, list[Block]], None, None]:
    """Each car's blocks of tests (one per layout), cars in id order, via a server-side cursor.

    ``widths``: the layouts to read, each with its number of values per test.
    """
    driver = session.connection().connection.driver_connection
    name = f"depot_fleet_histories_{next(_CURSORS)}"  # unique: two readers may overlap
    cursor = driver.cursor(name=name, binary=True)  # type: ignore[union-attr]
    cursor.adapters.register_loader(INT4_ARRAY_OID, Int4ArrayLoader)
    cursor.adapters.register_loader(INT8_ARRAY_OID, Int8ArrayLoader)
    cursor.adapters.register_loader(TIMESTAMPTZ_ARRAY_OID, Int8ArrayLoader)  # µs since 2000
    cursor.itersize = _ROWS_PER_FETCH
    try:
        cursor.execute(_PER_CAR, {"layouts": sorted(widths)})
        for car_id, layouts, micros, ids, readings in cursor:
            epoch_s = (micros + PG_EPOCH_US) / 1e6
            yield car_id, car_blocks(layouts, epoch_s, ids, readings, widths)
    finally:
        cursor.close()  # a reader that stops early must not leave the cursor open
