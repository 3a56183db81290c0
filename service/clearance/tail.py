"""Tail-car snapshots: detect the red tail disc on the stored image and attach the verdict."""

from __future__ import annotations

import threading
from collections import OrderedDict
from pathlib import Path
from typing import Any

from sqlalchemy import select

import tail_check
from core.settings import get_settings
from ingest.handlers import Derivation, install_preparer
from ingest.models import Snapshot
from ingest.snapshots import load_bgr, stored_image
from service.clearance.attribution import run_at, side_of
from service.clearance.handlers import attach_evidence, evidence_row
from tail_check.profile import CameraProfile


def snapshot_file(snapshot: Snapshot) -> Path:
    return stored_image(get_settings().image_dir, snapshot.sha256, snapshot.content_type)


def camera_profile(device_id: str) -> Any:
    """The camera's calibrated profile (``DATA_DIR/profiles/<device>.json``), else the default."""
    path = get_settings().data_dir / "profiles" / f"{device_id}.json"
    return tail_check.load_profile(path) if path.exists() else None


def _departure_reference(d: Derivation, run_id: int | None) -> Snapshot | None:
    if run_id is None:
        return None
    return d.session.scalar(
        select(Snapshot)
        .where(
            Snapshot.run_id == run_id, Snapshot.side == "departure", Snapshot.verdict == "present"
        )
        .order_by(Snapshot.occurred_at.desc())
    )


# Detections prepared before the event is stored, by (device, image hash): at most this many
# (an upload's detection is used by its own derivation a moment later; a few in flight per
# camera at most).
PREPARED_MAX = 64
_prepared: OrderedDict[tuple[str, str], tuple[Any, dict[str, Any]]] = OrderedDict()
_prepared_lock = threading.Lock()


def prepare_snapshot(device: Any, event: Any) -> None:
    """Detect the disc on an uploaded (already stored) image before its event is stored: in
    a worker thread, outside the transaction and the section lock (see ``ingest.handlers``)."""
    profile = camera_profile(device.id)
    path = stored_image(get_settings().image_dir, event.image_sha256, event.content_type)
    detection = detect_stored(path, event.content_type, profile)
    with _prepared_lock:
        _prepared[(device.id, event.image_sha256)] = (profile, detection)
        while len(_prepared) > PREPARED_MAX:
            _prepared.popitem(last=False)


def detect_stored(path: Path, content_type: str, profile: Any) -> dict[str, Any]:
    """The single-camera detection of a stored image. A JPEG is decoded at reduced size in the
    DCT domain (``tail_check.detect_snapshot``: the detector works at a fixed scale of about
    400 pixels, so most of a 1080p decode was thrown away); any other image in full. A
    ``present`` must be confirmed by the learned verifier (``tail_check.detect_confirmed``)."""
    if content_type == "image/jpeg":
        return tail_check.detect_snapshot(path.read_bytes(), profile).to_dict()
    return tail_check.detect_confirmed(load_bgr(path), profile).to_dict()


def _detection(
    device_id: str, sha256: str, path: Path, content_type: str, profile: Any
) -> dict[str, Any]:
    """The single-camera detection: the prepared one when it was made with the same profile
    (the same image and profile give the same detection, so replay, which computes it, agrees),
    else computed now."""
    with _prepared_lock:
        prepared = _prepared.pop((device_id, sha256), None)
    if prepared is not None and prepared[0] == profile:
        return dict(prepared[1])
    return detect_stored(path, content_type, profile)


install_preparer("tail_snapshot", prepare_snapshot)


def tail_snapshot(d: Derivation) -> dict[str, Any]:
    event = d.event
    row = evidence_row(
        Snapshot,
        d,
        sha256=event.image_sha256,
        content_type=event.content_type,
        width=event.width,
        height=event.height,
        size_bytes=event.size_bytes,
    )
    profile = camera_profile(d.device.id)
    detection = _detection(
        d.device.id, event.image_sha256, snapshot_file(row), event.content_type, profile
    )
    # On an arrival image, the same run's departure image (if any) is the reference.
    run = run_at(d.session, event.section, event.occurred_at, d.device.station)
    arriving = run is not None and side_of(run, d.device.station) == "arrival"
    reference = _departure_reference(d, run.id) if run is not None and arriving else None
    if reference is not None:
        image = load_bgr(snapshot_file(row))
        compared = tail_check.compare(load_bgr(snapshot_file(reference)), image, profile=profile)
        detection = {
            **compared.to_dict(),
            "single_camera": detection,
            "reference_snapshot": reference.id,
        }
    detection["absent_confidence"] = (profile or CameraProfile()).absent_confidence
    row.verdict, row.score, row.detection = (
        detection["verdict"],
        float(detection["score"]),
        detection,
    )
    attached = attach_evidence(d, row)
    return {"snapshot": row.id, "verdict": row.verdict, "score": row.score, **attached}
