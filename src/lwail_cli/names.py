"""What an artifact may be called, and how a ref to one is spelt: ``name``, ``name@vN`` or ``kind/name@vN``.

Names become folder names of the store and of its run area, so a name is checked before any path is built from it.
"""

from __future__ import annotations

import difflib
import re

from .errors import LwailError

MAX_NAME = 100
SHOWN = 10  # names an "unknown name" message lists at most
_NAME = re.compile(r"[A-Za-z0-9][A-Za-z0-9._-]*")  # used with fullmatch: a trailing newline is no name
_REF = re.compile(r"^(?:(?P<kind>[a-z]+)/)?(?P<name>[A-Za-z0-9][A-Za-z0-9._-]*?)(?:@v(?P<version>\d+))?$")


def check_name(name: str) -> None:
    if not _NAME.fullmatch(name) or len(name) > MAX_NAME:
        raise LwailError(f"artifact name {name!r} must be 1-{MAX_NAME} letters, digits, '.', '_' or '-', starting with a letter or digit")


def parse_ref(ref: str) -> tuple[str | None, str, int | None] | None:
    """(kind or None, name, version or None) of a ref; None if ``ref`` is not spelt as one."""
    match = _REF.fullmatch(ref)  # fullmatch: '$' alone lets "name\n" through as "name"
    if match is None:
        return None
    return match["kind"], match["name"], None if match["version"] is None else int(match["version"])


def closest(name: str, known: list[str], what: str) -> str:
    """The end of an "unknown name" message: the known names closest to ``name`` (difflib), else all of them (at
    most ``SHOWN``), else that there are none."""
    if not known:
        return f"there are no {what} yet"
    close = difflib.get_close_matches(name, known, n=3)
    if close:
        return f"did you mean {' or '.join(close)}?"
    listed = ", ".join(sorted(known)[:SHOWN]) + (f" and {len(known) - SHOWN} more" if len(known) > SHOWN else "")
    return f"{what}: {listed}"
