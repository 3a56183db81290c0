"""Starlette's in-process client, for the demo and the simulator that post through the API.

Imported here once so that its note on the client's transport (a deprecation in favour of
``httpx2``, nothing a person running ``depot demo`` or ``depot simulate`` can act on) is not
printed to them.
"""

from __future__ import annotations

import warnings

with warnings.catch_warnings():
    warnings.filterwarnings("ignore", message="Using `httpx` with `starlette.testclient`")
    from fastapi.testclient import TestClient

__all__ = ["TestClient"]
