"""A car's forecast as a PNG: index history, forecast with its interval, and the index band."""

from __future__ import annotations

import io
from datetime import UTC, datetime
from typing import Any

import matplotlib
import numpy as np
from numpy.typing import NDArray

matplotlib.use("Agg")  # no display on a server; must precede any pyplot import anywhere

from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.dates import AutoDateLocator, ConciseDateFormatter
from matplotlib.figure import Figure

from service.fleet.vectorised import HISTORY


def _utc(at: str) -> np.datetime64:
    return np.datetime64(datetime.fromisoformat(at).astimezone(UTC).replace(tzinfo=None), "s")


def _times(points: list[dict[str, Any]]) -> NDArray[np.datetime64]:
    """Times on the UTC axis (numpy datetimes: matplotlib's date axis, no tz warnings)."""
    return np.array([_utc(p["at"]) for p in points], dtype="datetime64[s]")


def decimated(n: int, values: NDArray[np.float64], most: int) -> list[int]:
    """Indices (increasing) of at most ``most`` of ``n`` points: each of ``most // 2`` buckets
    gives its lowest and highest value, and the last point is always kept."""
    if n <= most:
        return list(range(n))
    buckets = max(1, (most - 1) // 2)
    edges = np.linspace(0, n, buckets + 1).astype(np.int64)
    keep = {n - 1}
    for a, b in zip(edges[:-1], edges[1:], strict=True):
        if b > a:
            chunk = values[a:b]
            keep.update((a + int(np.nanargmin(chunk)), a + int(np.nanargmax(chunk))))
    return sorted(keep)


def render_chart(view: dict[str, Any], *, width_px: int = 760, height_px: int = 300) -> bytes:
    """PNG bytes of one car's forecast view (:func:`service.fleet.views.forecast_out`)."""
    # A Figure without pyplot keeps no global state, so requests can draw in parallel threads.
    fig = Figure(figsize=(width_px / 100, height_px / 100), dpi=100)
    FigureCanvasAgg(fig)
    ax = fig.add_subplot()
    history = [p for p in view.get("index_history", []) if p["at"] is not None]
    if len(history) > HISTORY.chart:
        y = np.array([np.nan if p["index"] is None else p["index"] for p in history], float)
        history = [history[i] for i in decimated(len(history), y, HISTORY.chart)]
    steps = (view.get("forecast") or {}).get("steps", [])
    if history:
        ax.plot(_times(history), [p["index"] for p in history], color="#1565c0", lw=1.2,
                label="quality index")  # fmt: skip
    if steps:
        when = _times(steps)
        if history:  # join the forecast to the last measured index
            when = np.concatenate([_times(history[-1:]), when])
        lead = [history[-1]["index"]] if history else []
        lower, upper = lead + [s["lower"] for s in steps], lead + [s["upper"] for s in steps]
        ax.fill_between(when, lower, upper, color="#ef6c00", alpha=0.18, lw=0,
                        label="prediction interval")  # fmt: skip
        ax.plot(when, lead + [s["value"] for s in steps], color="#ef6c00", lw=1.5, ls="--",
                label="forecast")  # fmt: skip
    band = view.get("index_band")
    if band and (history or steps):
        for edge in band:
            ax.axhline(edge, color="#c62828", lw=1.0, ls=":")
        ax.axhspan(band[0], band[1], color="#2e7d32", alpha=0.06, label="index band")
    exit_at = (view.get("first_exit") or {}).get("at")
    if exit_at:
        ax.axvline(_utc(exit_at), color="#c62828", lw=1.0, label="leaves band")  # type: ignore[arg-type]
    risk = view.get("risk")
    risk_text = "risk unknown" if risk is None else f"risk {risk:.0%}"
    ax.set_title(f"Car {view.get('car')} — {risk_text}", fontsize=10, loc="left")
    if not history:
        ax.text(0.5, 0.5, "not enough history", ha="center", va="center", transform=ax.transAxes)
    else:
        locator = AutoDateLocator()  # type: ignore[no-untyped-call]
        ax.xaxis.set_major_locator(locator)
        ax.xaxis.set_major_formatter(ConciseDateFormatter(locator))  # type: ignore[no-untyped-call]
        ax.legend(loc="upper left", fontsize=7, ncol=3, frameon=False)
    ax.set_ylabel("index", fontsize=8)
    ax.tick_params(labelsize=7)
    ax.grid(alpha=0.25)
    fig.tight_layout()
    out = io.BytesIO()
    fig.savefig(out, format="png")
    return out.getvalue()


_CACHE: dict[tuple[int, str, str], bytes] = {}
_CACHE_SIZE = 256


def cached_chart(key: tuple[int, str, str], view: dict[str, Any]) -> bytes:
    """The chart of a stored forecast; forecasts never change, so one drawing serves all views."""
    png = _CACHE.get(key)
    if png is None:
        png = render_chart(view)
        if len(_CACHE) >= _CACHE_SIZE:
            _CACHE.pop(next(iter(_CACHE)))  # oldest first: dicts keep insertion order
        _CACHE[key] = png
    return png
