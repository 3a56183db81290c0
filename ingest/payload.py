"""The JSON of a device payload, read the same way on HTTP, MQTT and NATS."""

from __future__ import annotations

import json
from typing import Any

from core.errors import Unprocessable


class _DuplicateKey(ValueError):
    pass


def _refuse_duplicates(pairs: list[tuple[str, Any]]) -> dict[str, Any]:
    # json.loads keeps the last of two equal keys; a device that sends "axles" twice has a
    # bug, and which value it meant is unknown, so the payload is refused.
    result = dict(pairs)  # built in C; the loop below only runs when a key was repeated
    if len(result) != len(pairs):
        seen: set[str] = set()
        for key, _ in pairs:
            if key in seen:
                raise _DuplicateKey(key)
            seen.add(key)
    return result


def read_json(data: bytes, *, what: str = "body") -> Any:
    """The parsed JSON of ``data`` (UTF-8); 422 naming the problem when it is not JSON, is
    nested too deeply, or repeats a key in one object."""
    try:
        return json.loads(data.decode("utf-8"), object_pairs_hook=_refuse_duplicates)
    except RecursionError:
        raise Unprocessable("the JSON is nested too deeply") from None
    except _DuplicateKey as exc:
        raise Unprocessable(
            f"the {what} repeats the key {exc.args[0]!r} in one object; send each field once",
            errors=[{"loc": ["body"], "msg": "duplicate key"}],
        ) from None
    except UnicodeDecodeError:
        raise Unprocessable(
            f"the {what} is not UTF-8 text; send JSON encoded as UTF-8",
            errors=[{"loc": ["body"], "msg": "invalid JSON"}],
        ) from None
    except json.JSONDecodeError as exc:
        raise Unprocessable(
            f"the {what} is not valid JSON ({exc})",
            errors=[{"loc": ["body"], "msg": "invalid JSON"}],
        ) from None
