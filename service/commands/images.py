"""``depot images prune``: remove image files no event references.

An upload's image is written before its event commits (``ingest/router.py``): the image of
an upload refused with 409 (two uploads of one event_id with different images), or of a
process killed between the write and the commit, stays behind, referenced by nothing, as do
the temporary files of writes cut short. Registered into ``depot`` by ``service.cli``.
"""

from __future__ import annotations

import argparse
import os
import re
import stat
import time
from collections.abc import Collection, Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from sqlalchemy import select
from sqlalchemy.orm import Session

from core.database import get_sessionmaker
from core.settings import get_settings
from ingest.models import RawEvent, Snapshot
from ingest.snapshots import SUFFIXES, image_store_lock
from service.commands._common import FINITE, fail

__all__ = ["MIN_OLDER_THAN_S", "register"]

# An upload's image is on disk before its event commits: the body has arrived in full (the
# body deadline runs before the write), then detection runs and the commit waits its turn
# behind the section's lock; that takes seconds. A file younger than this may belong to an
# upload still on its way; ten minutes is ample margin.
MIN_OLDER_THAN_S = 600.0
DEFAULT_OLDER_THAN_S = 3600

_SHARD = re.compile(r"[0-9a-f]{2}")  # image_dir/<sha[:2]>/, as ingest.snapshots.image_path
_IMAGE = re.compile(r"([0-9a-f]{64})(\.[a-z]+)")
_SUFFIXES = frozenset(SUFFIXES.values())
_TEMPORARY = ".tmp"  # tempfile.mkstemp's suffix in ingest.snapshots.store_image
_STREAM_ROWS = 2000  # rows fetched at a time: a long history is never held in memory


@dataclass
class _Found:
    """What the image folder holds, by what prune may do with it."""

    images: dict[str, list[Path]] = field(default_factory=dict)  # sha256 -> files
    temporary: list[Path] = field(default_factory=list)
    foreign: int = 0


@dataclass
class _Tally:
    removed: int = 0
    removed_temporary: int = 0
    removed_bytes: int = 0
    referenced: int = 0
    recent: int = 0


def _entries(folder: str) -> Iterator[os.DirEntry[str]]:
    with os.scandir(folder) as entries:
        yield from entries


def _scan(image_dir: Path) -> _Found:
    """Every file depot's store writes (``<sha[:2]>/<sha256><suffix>`` and its temporary
    files); anything else, files or folders, is only counted. Symbolic links are never
    followed: a link named like an image is not an image of the store."""
    found = _Found()
    if not image_dir.is_dir():
        return found
    for top in _entries(str(image_dir)):
        if not (top.is_dir(follow_symlinks=False) and _SHARD.fullmatch(top.name)):
            found.foreign += 1
            continue
        for entry in _entries(top.path):
            path = Path(entry.path)
            image = _IMAGE.fullmatch(entry.name)
            if not entry.is_file(follow_symlinks=False):
                found.foreign += 1
            elif image and image[1].startswith(top.name) and image[2] in _SUFFIXES:
                found.images.setdefault(image[1], []).append(path)
            elif entry.name.endswith(_TEMPORARY):
                found.temporary.append(path)
            else:
                found.foreign += 1
    return found


def _referenced(session: Session, present: Collection[str]) -> set[str]:
    """The hashes among ``present`` that a snapshot or a ``tail_snapshot`` raw event names.

    The raw events count on their own: they are the source of truth (``depot replay``
    rebuilds the snapshots from them). Only the hash is selected (``->>`` on PostgreSQL,
    ``json_extract`` on SQLite), a few thousand rows at a time.
    """
    queries = (
        select(Snapshot.sha256),
        select(RawEvent.body["image_sha256"].as_string()).where(RawEvent.kind == "tail_snapshot"),
    )
    found: set[str] = set()
    for query in queries:
        rows = session.scalars(query.execution_options(yield_per=_STREAM_ROWS))
        found.update(sha for sha in rows if sha in present)
    return found


def _remove_if_old(image_dir: Path, path: Path, cutoff: float, dry_run: bool) -> int | None:
    """Remove ``path`` if it is still a file last changed before ``cutoff``: its size, or
    None when it is kept (changed since the scan: an upload touched it). The last look and
    the removal happen under the store's exclusive lock (``ingest.snapshots.image_store_lock``
    says why no accepted image is lost)."""
    if dry_run:
        return _old_size(path, cutoff)
    with image_store_lock(image_dir, exclusive=True):
        size = _old_size(path, cutoff)
        if size is not None:
            path.unlink(missing_ok=True)
    return size


def _old_size(path: Path, cutoff: float) -> int | None:
    try:
        info = path.lstat()
    except FileNotFoundError:
        return 0  # removed meanwhile (another prune): nothing left to do
    if not stat.S_ISREG(info.st_mode) or info.st_mtime >= cutoff:
        return None
    return info.st_size


def _sweep(
    image_dir: Path, found: _Found, referenced: set[str], cutoff: float, dry: bool
) -> _Tally:
    tally = _Tally()
    candidates: list[tuple[Path, bool]] = [(path, False) for path in found.temporary]
    for sha, paths in found.images.items():
        if sha in referenced:
            tally.referenced += len(paths)
        else:
            candidates += [(path, True) for path in paths]
    for path, is_image in candidates:
        size = _remove_if_old(image_dir, path, cutoff, dry)
        if size is None:
            tally.recent += 1
            continue
        tally.removed_bytes += size
        if is_image:
            tally.removed += 1
        else:
            tally.removed_temporary += 1
    return tally


def _plural(count: int, noun: str, plural: str = "") -> str:
    return f"{count} {noun if count == 1 else plural or noun + 's'}"


def _report(image_dir: Path, tally: _Tally, found: _Found, older_than: float, dry: bool) -> None:
    verb = "would remove (dry run)" if dry else "removed"
    print(
        f"{verb} {_plural(tally.removed, 'unreferenced image')} and"
        f" {_plural(tally.removed_temporary, 'stale temporary file')},"
        f" {tally.removed_bytes} bytes, from {image_dir}"
    )
    print(
        f"kept {_plural(tally.referenced, 'referenced image')};"
        f" kept {tally.recent} too recent (changed within the last {older_than:g} s)"
    )
    others = _plural(found.foreign, "other entry", "other entries")
    print(f"left alone {others} (not a file depot's store writes)")


def _prune(args: argparse.Namespace) -> int:
    older_than = float(args.older_than)
    if older_than < MIN_OLDER_THAN_S:
        return fail(
            f"--older-than {older_than:g} is too short; give at least {MIN_OLDER_THAN_S:g}"
            " seconds: an upload's image is written before its event commits (detection and"
            " the commit come after the write), so a younger unreferenced file may belong to"
            " an upload still being accepted"
        )
    image_dir = get_settings().image_dir
    # Fixed before the references are read, and every removal re-checked against it: the
    # ordering argument of ingest.snapshots.image_store_lock rests on both.
    cutoff = time.time() - older_than
    found = _scan(image_dir)
    with get_sessionmaker()() as session, session.begin():
        referenced = _referenced(session, found.images.keys())
    try:
        tally = _sweep(image_dir, found, referenced, cutoff, args.dry_run)
    except OSError as exc:
        return fail(
            f"cannot prune {image_dir}: {exc.strerror or exc}; run it as the user depot"
            " runs as, on the image store's own host"
        )
    _report(image_dir, tally, found, older_than, args.dry_run)
    return 0


def register(subparsers: Any) -> None:
    """Add ``images`` (with its action ``prune``) to ``depot``'s sub-command parser."""
    images = subparsers.add_parser("images", help="the snapshot image store")
    images.set_defaults(action_group=images)
    actions = images.add_subparsers(dest="images_command", metavar="ACTION")
    prune = actions.add_parser(
        "prune",
        help="remove image files no event references",
        description="Remove image files under DEPOT_DATA_DIR/images that no snapshot or"
        " tail_snapshot raw event references and that have not changed for --older-than"
        " seconds, and temporary files of interrupted writes as old. Safe while depot runs.",
    )
    prune.add_argument(
        "--older-than",
        type=FINITE,
        default=DEFAULT_OLDER_THAN_S,
        metavar="SECONDS",
        help=f"only files unchanged this long, seconds (at least {MIN_OLDER_THAN_S:g})",
    )
    prune.add_argument(
        "--dry-run", action="store_true", help="say what would be removed, remove nothing"
    )
    prune.set_defaults(func=_prune)
