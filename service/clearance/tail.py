"""Tail-car snapshots: detect the red tail disc on the stored image and attach the verdict."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from sqlalchemy import select

import tail_check
from core.settings import get_settings
from ingest.handlers import Derivation
from ingest.models import Snapshot
from ingest.snapshots import load_bgr, stored_image
from service.clearance.evidence import run_at, side_of
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
    image = load_bgr(snapshot_file(row))
    profile = camera_profile(d.device.id)
    result = tail_check.detect(image, profile)
    # On an arrival image, the same run's departure image (if any) is the reference.
    run = run_at(d.session, event.section, event.occurred_at, d.device.station)
    arriving = run is not None and side_of(run, d.device.station) == "arrival"
    reference = _departure_reference(d, run.id) if run is not None and arriving else None
    detection: dict[str, Any] = result.to_dict()
    if reference is not None:
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
