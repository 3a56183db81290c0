"""The one rule for the names of stations, sections, cars, people and devices.

The API's request models (``schemas.py``) and the services that the CLI calls
(``credentials.py``, ``service.py``) both use it, so a name the API refuses is refused
everywhere, with the same words.
"""

from __future__ import annotations

import re
from dataclasses import dataclass

from core.errors import Unprocessable

# ASCII letters and digits first, then letters, digits, '_', '.' or '-': safe in URLs, MQTT
# topics and NATS subjects (the device id is a topic / subject level in transports.md).
NAME_PATTERN = r"^[A-Za-z0-9][A-Za-z0-9_.-]*$"


@dataclass(frozen=True)
class NameRule:
    """What a name of one kind of thing may be."""

    what: str
    max_length: int

    def check(self, value: str) -> str:
        """``value`` unchanged when it obeys the rule, else :class:`Unprocessable` naming it."""
        if not 1 <= len(value) <= self.max_length or not re.fullmatch(NAME_PATTERN, value):
            raise Unprocessable(
                f"{self.what} {value!r} is not a valid name: 1 to {self.max_length} characters,"
                " ASCII letters, digits, '_', '.' or '-', starting with a letter or digit"
            )
        return value


IDENTIFIER = NameRule("name", 32)  # stations, sections, cars, people
DEVICE_ID = NameRule("device id", 64)
USER_NAME = NameRule("user name", IDENTIFIER.max_length)
