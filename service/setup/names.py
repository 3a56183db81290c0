"""The one rule for the names of stations, sections, cars, people and devices.

The API's request models (``schemas.py``) and the services that the CLI calls
(``credentials.py``, ``service.py``) both use it, so a name the API refuses is refused
everywhere, with the same words.

Things (stations, sections, cars, devices) have ASCII identifiers: they are URL path parts,
MQTT topic levels and NATS subject tokens. People are named as they are called: Ukrainian,
Russian or any other alphabet (:data:`PERSON_NAME`).
"""

from __future__ import annotations

import re
import unicodedata
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


IDENTIFIER = NameRule("name", 32)  # stations, sections, cars
DEVICE_ID = NameRule("device id", 64)

# Between the words of a person's name: one space, '-', '.', '_' or an apostrophe (Мар'яна,
# with the ASCII one, the typographic ’ or the Ukrainian letter apostrophe ʼ); ". " after an
# initial.
_JOINERS = frozenset(" -._'\u2019\u02bc")
_WORD_SPLIT = re.compile(r"[ \-._'\u2019\u02bc]+")


@dataclass(frozen=True)
class PersonNameRule:
    """A person's name (``depot user add``, ``POST /users``): what staff are called.

    Stored in Unicode NFC, so one name has one spelling whatever keyboard typed it. Letters
    of any alphabet with their combining marks, decimal digits, and single joiners between
    them (:data:`_JOINERS`); it starts with a letter or digit and holds at least one letter.
    No control, format or invisible characters (a right-to-left override, a zero-width
    space), and within one word the letters are of one script, so a Cyrillic word with a
    Latin look-alike letter in it ('Олeна') is refused rather than stored beside 'Олена'.
    """

    what: str = "user name"
    max_length: int = 64  # the users.name column (String(64)); also the audit's actor

    def problem(self, value: str) -> str | None:
        """What is wrong with ``value`` (already NFC), in words, or None."""
        if not 1 <= len(value) <= self.max_length:
            return f"1 to {self.max_length} characters"
        if not value[0].isalnum() or value[-1] in _JOINERS:
            return "starting with a letter or digit, and not ending with a space or mark"
        previous = ""
        for char in value:
            category = unicodedata.category(char)
            if char in _JOINERS:
                if previous in _JOINERS and previous + char != ". ":  # "О. Шевченко"
                    return "one space, '-', '.', '_' or apostrophe between words, not two"
            elif category[0] == "M":
                if not previous or previous in _JOINERS:
                    return "combining marks only on a letter"
            elif category[0] != "L" and category != "Nd":
                return "letters, digits, single spaces, '-', '.', '_' or apostrophes only"
            previous = char
        if not any(unicodedata.category(char)[0] == "L" for char in value):
            return "at least one letter"
        for word in _WORD_SPLIT.split(value):
            scripts = {_script(char) for char in word if unicodedata.category(char)[0] == "L"}
            if len(scripts) > 1:
                return (
                    f"one alphabet within a word ({word!r} mixes {' and '.join(sorted(scripts))})"
                )
        return None

    def normalise(self, value: str) -> str:
        """``value`` in NFC when it obeys the rule, else :class:`Unprocessable` naming it."""
        name = unicodedata.normalize("NFC", value)
        problem = self.problem(name)
        if problem is not None:
            raise Unprocessable(self.message(name, problem))
        return name

    def message(self, value: str, problem: str) -> str:
        return (  # repr shows an invisible character escaped, never raw
            f"{self.what} {value!r} is not a valid name: {problem}"
            " (letters of any alphabet, digits, single spaces, '-', '.', '_' or apostrophes)"
        )


def _script(char: str) -> str:
    """The script of a letter as its Unicode name starts: LATIN, CYRILLIC, GREEK, ..."""
    return unicodedata.name(char, "UNKNOWN").split(" ")[0]


PERSON_NAME = PersonNameRule()


def person_name(value: str) -> str:
    """Pydantic's validator for a person's name: NFC, or a ValueError naming the rule."""
    try:
        return PERSON_NAME.normalise(value)
    except Unprocessable as exc:
        raise ValueError(exc.detail) from None
