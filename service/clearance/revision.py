"""A run's revision: what a dispatcher saw, so that a decision taken on an old look is refused.

An independent trial (F2): a run under review, the dispatcher typing a reason, a late axle
count proving a loss turned the section to ALARM — and the ``clear`` sent from the page that
had not yet refreshed freed the section. The decision said nothing of what it was based on.

The revision is computed from what is already stored (no column of its own): the run's verdict,
reasons, gathered evidence, status and arrival, the section's state and current run, and the
latest action on the run. Any new evidence that changes what the run shows, any re-decision or
state change, and any action changes it. It reads ``<verdict>.<section state>.<digest>`` so that
a refusal can say in words what changed since (the words need the old verdict and state; the
digest alone would only say "something").

The GET of a run answers it as its ``ETag`` and every run carries it as ``revision``; a decision
may send it back (``If-Match`` or ``seen``), and is refused (409, nothing recorded) when the run
has changed. :func:`service.clearance.actions.act` checks it under the section lock, and only
when given: a replayed decision (``depot replay``) carries none and re-applies as recorded.
"""

from __future__ import annotations

import hashlib
import json
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

from sqlalchemy import func, select
from sqlalchemy.orm import Session

from core.errors import Conflict
from core.models import Section
from core.schemas import format_optional_instant
from service.clearance.models import AuditRecord, Run


@dataclass(frozen=True)
class RevisionRules:
    """How a revision is written."""

    # Hex digits of the SHA-256 kept: 64 bits, so two looks of one run never collide by chance.
    digest_chars: int = 16
    # At most this many of the run's current reasons are quoted in a refusal.
    reasons_quoted: int = 3


RULES = RevisionRules()
SEPARATOR = "."
# "section now ALARM": the state a dispatcher must not miss, written as the screen writes it.
STATE_WORDS = {"alarm": "ALARM", "review": "under review", "awaiting_sweep": "awaiting a sweep"}


def revision(run: Run, section: Section | None, last_action: int | None) -> str:
    """The run's revision as the dispatcher sees it now (``last_action``: the id of the latest
    audit record of the run, None while nobody has acted)."""
    seen: dict[str, Any] = {
        "status": run.status,
        "verdict": run.verdict,
        "reasons": run.reasons,
        "evidence": run.evidence,
        "arrived_at": format_optional_instant(run.arrived_at),
        "conflict": run.conflict,
        "cleared_by": run.cleared_by,
        "section_state": section.state if section else None,
        "current_run": section.current_run_id if section else None,
        "last_action": last_action,
    }
    text = json.dumps(seen, sort_keys=True, default=str, separators=(",", ":"))
    digest = hashlib.sha256(text.encode()).hexdigest()[: RULES.digest_chars]
    state = section.state if section else "none"
    return SEPARATOR.join((run.verdict or "none", state, digest))


def last_action_id(session: Session, run_id: int) -> int | None:
    return session.scalar(select(func.max(AuditRecord.id)).where(AuditRecord.run_id == run_id))


def if_match(header: str | None) -> list[str]:
    """The revisions of an ``If-Match`` header (``"a", W/"b"``); ``*`` is any (an empty list)."""
    if header is None:
        return []
    tags = [t.strip().removeprefix("W/").strip('"') for t in header.split(",")]
    return [] if "*" in tags else [t for t in tags if t]


def check_seen(session: Session, run: Run, section: Section, seen: Sequence[Sequence[str]]) -> None:
    """Refuse (409) a decision taken on a look at the run that is no longer current: every
    look in ``seen`` (the revisions it may be) must hold the run's revision now.

    ``run`` and ``section`` must be read under the section lock (the caller refreshes them), so
    that evidence committed while the lock was awaited is part of "now"."""
    if not seen:
        return
    now = revision(run, section, last_action_id(session, run.id))
    for look in seen:
        if now not in look:
            raise Conflict(changed_words(look[0], run, section.state))


def changed_words(seen: str, run: Run, state: str) -> str:
    """ "the run changed since you looked: verdict now incomplete (was undetermined), section now
    ALARM (was under review); …; look again": what a dispatcher must know before deciding."""
    parts = seen.split(SEPARATOR)
    was_verdict, was_state = (parts[0], parts[1]) if len(parts) == 3 else (None, None)
    verdict = run.verdict or "none"
    changes = [
        _change("verdict", verdict, was_verdict, verdict),
        _change("section", STATE_WORDS.get(state, state), was_state, state),
    ]
    said = [c for c in changes if c] or [
        f"new evidence or another decision (verdict still {verdict}, section still"
        f" {STATE_WORDS.get(state, state)})"
    ]
    reasons = "; ".join((run.reasons or [])[: RULES.reasons_quoted])
    because = f"; reasons now: {reasons}" if reasons else ""
    return (
        f"the run changed since you looked: {', '.join(said)}{because}; look again."
        " Nothing was recorded"
    )


def _change(what: str, words: str, was: str | None, now: str) -> str | None:
    if was is None:
        return f"{what} now {words}"
    if was == now:
        return None
    return f"{what} now {words} (was {STATE_WORDS.get(was, was)})"
