"""Reading the stored measurements: parameter bands and each car's test matrix, in bulk.

A test is one row whose readings (float64 bytes) follow its layout's names. On PostgreSQL one
streamed query returns, per car and layout, the times and the concatenated readings, loaded
straight into numpy; a car measured with a single layout needs no pivot at all.
"""

from __future__ import annotations

import itertools
from collections.abc import Generator, Iterable, Sequence
from dataclasses import dataclass, field
from datetime import UTC, datetime
from typing import Any, NamedTuple

import numpy as np
from numpy.typing import NDArray
from sqlalchemy import DateTime, select, type_coerce
from sqlalchemy.orm import Session

from maintenance.bands import bands_from_nominal
from service.fleet.blocks import Block
from service.fleet.models import READINGS_DTYPE, Measurement, MeasurementLayout, Parameter
from service.fleet.pg_arrays import stream_postgresql

# A parameter measured at fewer than this share of a car's tests is left out of its index:
# carrying one old value forward over most of the history would fake a perfectly stable parameter.
MIN_COVERAGE = 0.5
_READ_CHUNK = 20_000


@dataclass(frozen=True)
class CarHistory:
    """One car's tests: ``values[i, j]`` is parameter ``names[j]`` at ``epoch_s[i]``."""

    car_id: str
    epoch_s: NDArray[np.float64]  # test times, Unix seconds, increasing
    names: tuple[str, ...]
    values: NDArray[np.float64]

    @property
    def taken_at(self) -> list[datetime]:
        return [datetime.fromtimestamp(float(t), UTC) for t in self.epoch_s]

    @property
    def start(self) -> datetime:
        return datetime.fromtimestamp(float(self.epoch_s[0]), UTC)

    @property
    def days(self) -> NDArray[np.float64]:
        """Test times in days since the first test."""
        return np.asarray((self.epoch_s - self.epoch_s[0]) / 86400.0, dtype=np.float64)

    def __len__(self) -> int:
        return int(self.epoch_s.shape[0])


def empty_history(car_id: str) -> CarHistory:
    return CarHistory(car_id, np.zeros(0), (), np.zeros((0, 0)))


@dataclass(frozen=True)
class Bands:
    """The tolerance bands of every registered parameter."""

    names: tuple[str, ...]
    limits: NDArray[np.float64]  # (n_params, 2): lower, upper
    units: dict[str, str]

    _described: dict[tuple[str, ...], dict[str, Any]] = field(
        default_factory=dict, compare=False, repr=False
    )

    def of(self, names: Sequence[str]) -> NDArray[np.float64]:
        where = {name: i for i, name in enumerate(self.names)}
        return self.limits[[where[n] for n in names]]

    def described(self, names: Sequence[str]) -> dict[str, Any]:
        """``{"bands": {name: [lower, upper]}, "units": {name: unit}}`` of ``names`` (cached:
        every car of a fleet has the same; treat the result as read-only)."""
        key = tuple(names)
        if key not in self._described:
            limits = self.of(key).tolist() if key else []
            self._described[key] = {
                "bands": dict(zip(key, limits, strict=True)),
                "units": {n: self.units.get(n, "") for n in key},
            }
        return self._described[key]


def load_bands(session: Session) -> Bands:
    params = list(session.scalars(select(Parameter).order_by(Parameter.name)))
    if not params:
        return Bands((), np.zeros((0, 2)), {})
    limits = bands_from_nominal([p.nominal for p in params], [p.tolerance for p in params])
    return Bands(tuple(p.name for p in params), limits, {p.name: p.unit for p in params})


class Columns(NamedTuple):
    """Where a layout's banded readings go: ``readings[:, source]`` → ``names[target]``."""

    source: list[int]
    target: list[int]


def layout_columns(session: Session, names: Sequence[str]) -> dict[int, Columns]:
    """Per layout holding at least one of ``names``, its columns in ``names`` order."""
    where = {name: i for i, name in enumerate(names)}
    out = {}
    for ident, stored in session.execute(select(MeasurementLayout.id, MeasurementLayout.names)):
        pairs = sorted((where[n], j) for j, n in enumerate(stored) if n in where)
        if pairs:
            out[ident] = Columns([j for _, j in pairs], [i for i, _ in pairs])
    return out


def car_history(
    car_id: str, blocks: Sequence[Block], columns: dict[int, Columns], names: Sequence[str]
) -> CarHistory | None:
    """The car's test matrix over the banded ``names`` it was measured on (None: no tests).

    A parameter skipped at one test keeps its last measured value (a bench may skip a
    parameter on a visit); parameters measured too rarely are dropped; tests at the same time
    merge (a repeated parameter keeps the last stored value).
    """
    blocks = [b for b in blocks if b.layout_id in columns and b.epoch_s.shape[0]]
    if not blocks:
        return None
    if len(blocks) == 1 and np.all(np.diff(blocks[0].epoch_s) > 0.0):
        block = blocks[0]
        cols = columns[block.layout_id]
        kept = tuple(names[i] for i in cols.target)
        return CarHistory(car_id, block.epoch_s, kept, block.readings[:, cols.source])
    return _merged(car_id, blocks, columns, names)


def _merged(
    car_id: str, blocks: Sequence[Block], columns: dict[int, Columns], names: Sequence[str]
) -> CarHistory:
    epoch = np.concatenate([b.epoch_s for b in blocks])
    ids = np.concatenate([b.ids for b in blocks])
    per_test = [columns[b.layout_id] for b in blocks for _ in range(b.epoch_s.shape[0])]
    rows = [r for b in blocks for r in b.readings]
    unique, test = np.unique(epoch, return_inverse=True)
    t_idx, p_idx, vals = [], [], []
    for k in np.lexsort((ids, epoch)):  # stored order: a later row overwrites an earlier one
        cols = per_test[k]
        t_idx.extend([int(test[k])] * len(cols.target))
        p_idx.extend(cols.target)
        vals.extend(np.asarray(rows[k])[cols.source].tolist())
    grid = np.full((unique.shape[0], len(names)), np.nan)
    grid[t_idx, p_idx] = vals
    return _filled(car_id, unique, grid, names)


def _filled(
    car_id: str, epoch: NDArray[np.float64], grid: NDArray[np.float64], names: Sequence[str]
) -> CarHistory:
    seen = ~np.isnan(grid)
    keep = seen.mean(axis=0) >= MIN_COVERAGE if len(epoch) else np.zeros(len(names), bool)
    grid, seen = grid[:, keep], seen[:, keep]
    last = np.maximum.accumulate(np.where(seen, np.arange(len(epoch))[:, None], 0), axis=0)
    grid = np.take_along_axis(grid, last, axis=0)
    first = np.argmax(seen, axis=0)  # leading gaps take the first measured value
    grid = np.where(np.isnan(grid), grid[first, np.arange(grid.shape[1])], grid)
    kept = tuple(n for n, k in zip(names, keep, strict=True) if k)
    return CarHistory(car_id, epoch, kept, grid)


def histories(session: Session, names: Sequence[str]) -> Generator[CarHistory, None, None]:
    """Every car's history of the banded parameters, read in one streamed query ordered by car.

    Cars without a test of a banded parameter are left out.
    """
    columns = layout_columns(session, names) if names else {}
    if not columns:
        return
    if session.get_bind().dialect.name == "postgresql":
        layouts = select(MeasurementLayout.id, MeasurementLayout.names)
        widths = {i: len(n) for i, n in session.execute(layouts) if i in columns}
        cars = stream_postgresql(session, widths)
    else:
        cars = _stream_rows(session, sorted(columns))
    for car_id, blocks in cars:
        history = car_history(car_id, blocks, columns, names)
        if history is not None:
            yield history


def _stream_rows(
    session: Session, layouts: list[int]
) -> Generator[tuple[str, list[Block]], None, None]:
    """One row per test (SQLite and other databases), grouped into blocks in Python."""
    table = Measurement.__table__.c
    query = (
        select(
            table.car_id,
            type_coerce(table.taken_at, DateTime()),
            table.id,
            table.layout_id,
            table.readings,
        )
        .where(table.layout_id.in_(layouts))
        .order_by(table.car_id, table.taken_at, table.id)
        .execution_options(stream_results=True, max_row_buffer=_READ_CHUNK)
    )
    result = session.connection().execute(query)
    try:
        for car_id, rows in itertools.groupby(result, key=lambda r: r[0]):
            yield car_id, _blocks(rows)
    finally:
        result.close()  # a reader that stops early must not leave the cursor open


def _blocks(rows: Iterable[Any]) -> list[Block]:
    by_layout: dict[int, list[Any]] = {}
    for row in rows:
        by_layout.setdefault(row[3], []).append(row)
    return [
        Block(
            layout,
            np.array([_utc(r[1]).timestamp() for r in group], dtype=np.float64),
            np.array([r[2] for r in group], dtype=np.int64),
            np.frombuffer(b"".join(r[4] for r in group), dtype=READINGS_DTYPE).reshape(
                len(group), -1
            ),
        )
        for layout, group in by_layout.items()
    ]


def _utc(at: datetime) -> datetime:
    # Times are read raw (UTCDateTime's per-row conversion would cost more than the test):
    # SQLite gives naive UTC values, other databases aware ones.
    return at.replace(tzinfo=UTC) if at.tzinfo is None else at.astimezone(UTC)
