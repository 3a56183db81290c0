"""How strong a secret setting must be (the admin and metrics tokens in production).

Length alone let ``aaaa…`` (40 × 'a') through. A token people type or copy from a note is
refused when it has few distinct characters, is a short pattern repeated, or is mostly a run
of neighbouring characters (``abcdef…``, ``0123…``). What ``openssl rand -base64 32``,
``openssl rand -hex 16`` and ``secrets.token_urlsafe(32)`` print passes every time (tested).
"""

from __future__ import annotations

from dataclasses import dataclass

GENERATE = (
    "generate one with `openssl rand -base64 32`"
    " (or python3 -c 'import secrets; print(secrets.token_urlsafe(32))')"
)


@dataclass(frozen=True)
class SecretRule:
    """The thresholds; a random hex token of 24 characters clears each by a wide margin."""

    min_length: int = 24
    # 24 random hex digits show about 13 distinct ones. At most 7 happens to 2.3e-5 of
    # them (the test drawing a thousand failed once in about 40 runs), at most 5 to
    # 3.2e-9 (exact count); 'aaaa…ab' has 2, 'password' repeated 7 but repeats a pattern.
    min_distinct: int = 6
    # Share of neighbouring pairs that are equal or one code point apart (a random hex token:
    # about 0.19; 'abcdef…': 1.0).
    max_run_share: float = 0.75

    def weakness(self, secret: str) -> str | None:
        """Why ``secret`` is weak, in words that never quote it, or None."""
        if len(secret) < self.min_length:
            return f"it is shorter than {self.min_length} characters"
        distinct = len(set(secret))
        if distinct < self.min_distinct:
            return f"it has only {distinct} distinct characters"
        for period in range(1, len(secret) // 2 + 1):
            if secret[period:] == secret[:-period]:
                return f"it repeats a pattern of {period} characters"
        pairs = list(zip(secret, secret[1:], strict=False))
        runs = sum(1 for a, b in pairs if abs(ord(a) - ord(b)) <= 1)
        if runs / len(pairs) > self.max_run_share:
            return "it is mostly a run of neighbouring characters"
        return None


SECRETS = SecretRule()


def secret_problem(setting: str, secret: str) -> str | None:
    """One line naming ``setting`` and the fix when ``secret`` is weak, else None."""
    why = SECRETS.weakness(secret)
    if why is None:
        return None
    return f"{setting} is too weak for production ({why}); {GENERATE}"
