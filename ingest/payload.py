"""The JSON of a device payload, read the same way on HTTP, MQTT and NATS."""

from __future__ import annotations

import json
import re
from typing import Any

from core.errors import Unprocessable


class _DuplicateKey(ValueError):
    pass


# A UTF-16 surrogate escape in the raw text; a valid pair decodes to one character, so the
# parsed value is searched for a lone one only when the text holds such an escape at all.
_SURROGATE_ESCAPE = re.compile(rb"\\u[dD][89a-fA-F]")


def _has_lone_surrogate(value: Any) -> bool:
    if isinstance(value, str):
        try:
            value.encode("utf-8")
        except UnicodeEncodeError:
            return True
        return False
    if isinstance(value, dict):
        return any(_has_lone_surrogate(k) or _has_lone_surrogate(v) for k, v in value.items())
    if isinstance(value, list):
        return any(_has_lone_surrogate(item) for item in value)
    return False


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
    nested too deeply, repeats a key in one object, or escapes half a character (a lone
    UTF-16 surrogate such as ``"\\ud800"``, which no text can store or hash)."""
    try:
        parsed = json.loads(data.decode("utf-8"), object_pairs_hook=_refuse_duplicates)
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
    except ValueError as exc:  # an integer of more than 4300 digits (Python's own bound)
        raise Unprocessable(
            f"the {what} holds a number that cannot be read ({exc}); send numbers of at most"
            " 4300 digits",
            errors=[{"loc": ["body"], "msg": "number too long"}],
        ) from None
    if _SURROGATE_ESCAPE.search(data) and _has_lone_surrogate(parsed):
        raise Unprocessable(
            f"the {what} escapes a lone UTF-16 surrogate (\\ud800–\\udfff without its pair),"
            " which is no character; send the text as UTF-8 or escape both halves of the pair",
            errors=[{"loc": ["body"], "msg": "lone surrogate"}],
        )
    return parsed
