"""``depot import-measurements FILE.csv`` and ``depot forecast``."""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path
from typing import Any, TextIO

from core.database import get_sessionmaker
from core.errors import DepotError
from service.commands._common import COUNT, fail
from service.fleet.schemas import WEIGHTS_METHODS


class ProgressBar:
    """A one-line text progress bar on a terminal stream (redrawn at most 10 times a second)."""

    def __init__(self, stream: TextIO, *, width: int = 30, label: str = "cars") -> None:
        self.stream, self.width, self.label = stream, width, label
        self._drawn = 0.0

    def __call__(self, done: int, total: int) -> None:
        now = time.monotonic()
        if done < total and now - self._drawn < 0.1:
            return
        self._drawn = now
        share = done / total if total else 1.0
        filled = int(round(share * self.width))
        bar = "#" * filled + "." * (self.width - filled)
        self.stream.write(f"\r[{bar}] {done}/{total} {self.label}")
        if done >= total:
            self.stream.write("\n")
        self.stream.flush()


def _import(args: argparse.Namespace) -> int:
    from service.fleet.importing import import_tests, read_tests
    from service.fleet.rules import registered

    path = Path(args.file)
    if not path.is_file():
        return fail(f"{path} does not exist or is not a file; give the path of a CSV file")
    try:
        with get_sessionmaker().begin() as session:
            with path.open(newline="", encoding="utf-8-sig") as stream:
                tests = read_tests(stream, registered(session))
            count, rows = import_tests(session, tests)
    except UnicodeDecodeError:
        return fail(f"{path} is not UTF-8 text; export the CSV as UTF-8")
    except DepotError as exc:
        return fail(f"{path}: {exc.detail}")
    skipped = len(tests) - count
    again = f"; {skipped} already stored, skipped" if skipped else ""
    print(f"imported {count} tests ({rows} measurements) from {path}{again}")
    return 0


def _forecast(args: argparse.Namespace) -> int:
    from service.fleet.forecasts import ForecastOptions, run_forecasts

    options = ForecastOptions(method=args.method, horizon=args.horizon, order=args.order)
    started = time.perf_counter()
    try:
        with get_sessionmaker().begin() as session:
            run = run_forecasts(session, options, progress=ProgressBar(sys.stderr))
    except DepotError as exc:
        return fail(exc.detail)
    elapsed = time.perf_counter() - started
    statuses = ", ".join(f"{n} {status}" for status, n in sorted(run.statuses.items()))
    print(f"forecast {run.cars} cars in {elapsed:.1f} s ({statuses or 'no cars registered'})")
    print(run.calibration)
    for car, risk in run.top:
        print(f"  car {car}: risk {risk:.0%}")
    return 0


def register(subparsers: Any) -> None:
    imp = subparsers.add_parser(
        "import-measurements",
        help="import bench measurements from CSV (car,taken_at,<parameter>,…)",
        description="Import test-bench measurements. Header: car,taken_at then one column per"
        " parameter (empty cell = not measured), or car,taken_at,parameter,value."
        " taken_at is ISO 8601 with an offset. All rows are imported or none.",
    )
    imp.add_argument("file", help="the CSV file")
    imp.set_defaults(func=_import)
    fc = subparsers.add_parser(
        "forecast", help="forecast every car from its stored measurements (progress on stderr)"
    )
    fc.add_argument(
        "--method", choices=WEIGHTS_METHODS, default="prediction", help="quality-index weights"
    )
    fc.add_argument("--horizon", type=COUNT, default=30, help="forecast steps (tests)")
    fc.add_argument("--order", type=COUNT, default=2, help="AR order of the index")
    fc.set_defaults(func=_forecast)
