"""The device key cache: a changed key is refused within the stated bound, never later."""

from __future__ import annotations

from sqlalchemy.orm import Session

from core.auth import DeviceKeyCache, hash_secret, new_secret
from core.database import utcnow
from core.models import Device, Section, Station

BOUND_S = 5.0  # protocol: a rotated or removed device key stops working within this bound


class Clock:
    def __init__(self) -> None:
        self.now = 1000.0

    def __call__(self) -> float:
        return self.now


def _device(session: Session, key: str) -> Device:
    session.add_all([Station(id="KA", name="A"), Station(id="KB", name="B")])
    session.flush()
    session.add(Section(id="KAB", from_station="KA", to_station="KB", mode="primary"))
    session.flush()
    device = Device(id="KA-ac", station="KA", section="KAB", kind="axle_counter")
    device.key_hash = hash_secret(key)
    session.add(device)
    session.flush()
    return device


def test_rotated_key_refused_within_the_ttl_and_new_key_at_once(session: Session) -> None:
    key, clock = new_secret(), Clock()
    cache = DeviceKeyCache(2.0, clock=clock)
    device = _device(session, key)
    assert cache.ttl_s <= BOUND_S
    cached = cache.lookup(session, key)
    assert cached is not None and cached.id == "KA-ac" and cached.station == "KA"
    new = new_secret()
    device.key_hash = hash_secret(new)  # rotated by another worker: this cache is not told
    session.flush()
    clock.now += 1.0
    assert cache.lookup(session, key) is not None  # within the TTL the old key may still pass
    assert cache.lookup(session, new) is not None  # the new key works at once (not cached)
    clock.now += 1.0  # TTL reached
    assert cache.lookup(session, key) is None
    clock.now += 10.0
    assert cache.lookup(session, key) is None  # and stays refused


def test_invalidate_forgets_at_once_and_zero_ttl_never_caches(session: Session) -> None:
    key, clock = new_secret(), Clock()
    cache = DeviceKeyCache(2.0, clock=clock)
    device = _device(session, key)
    assert cache.lookup(session, key) is not None
    device.key_hash = hash_secret(new_secret())
    session.flush()
    cache.invalidate("KA-ac")
    assert cache.lookup(session, key) is None
    off = DeviceKeyCache(0.0, clock=clock)
    device.key_hash = hash_secret(key)
    session.flush()
    assert off.lookup(session, key) is not None
    device.key_hash = hash_secret(new_secret())
    session.flush()
    assert off.lookup(session, key) is None


def test_decommissioned_device_is_carried_by_the_cached_copy(session: Session) -> None:
    key, clock = new_secret(), Clock()
    cache = DeviceKeyCache(2.0, clock=clock)
    device = _device(session, key)
    device.decommissioned_at = utcnow()
    session.flush()
    cached = cache.lookup(session, key)
    assert cached is not None and cached.decommissioned_at is not None
