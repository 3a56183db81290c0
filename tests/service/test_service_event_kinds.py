"""One source of truth per event kind: the schema union, its senders and the handler table."""

from __future__ import annotations

import pytest

from core.models import DEVICE_KINDS
from ingest import handlers
from ingest.schemas import ALL_EVENT_MODELS, ALLOWED_KINDS, EVENT_KINDS, Heartbeat, kind_of
from service import features
from tests.reliability.test_reliability_access import PROTOCOL_EVENTS


def test_every_kind_has_senders_and_an_entry_in_the_handler_table() -> None:
    for model in ALL_EVENT_MODELS:
        assert model.senders, f"{kind_of(model)} has no device kind that may send it"
        assert model.senders <= set(DEVICE_KINDS), f"{kind_of(model)}: unknown sender kinds"
        assert model in features.HANDLER_TABLE, f"{kind_of(model)} has no handler-table entry"
    derived = {kind_of(m) for m, h in features.HANDLER_TABLE.items() if h}
    assert derived == {kind_of(m) for m in ALL_EVENT_MODELS} - {"heartbeat"}


def test_kinds_and_allowed_senders_are_derived_from_the_models() -> None:
    assert set(EVENT_KINDS) | {"tail_snapshot"} == {kind_of(m) for m in ALL_EVENT_MODELS}
    assert set(ALLOWED_KINDS) == set(DEVICE_KINDS)
    for device_kind, kinds in ALLOWED_KINDS.items():
        assert "heartbeat" in kinds, f"{device_kind} cannot prove it is alive"
    # The access test's oracle, written from protocol.md, lists exactly the same kinds.
    assert set(PROTOCOL_EVENTS) == set(EVENT_KINDS)


def test_a_table_without_a_kind_is_refused_at_start() -> None:
    incomplete = {m: h for m, h in features.HANDLER_TABLE.items() if m is not Heartbeat}
    with pytest.raises(ValueError, match="heartbeat"):
        handlers.install(incomplete)
    features.install()  # the complete table is installed again for the other tests
    assert handlers.has_handlers("train_arrived") and not handlers.has_handlers("heartbeat")
