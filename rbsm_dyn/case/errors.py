"""Errors of the case file: :class:`CaseError` (``file:line: key.path:
message``), key paths and how values are shown in messages."""
from __future__ import annotations

from typing import Any, Optional

from pydantic_core import PydanticCustomError

KeyPath = tuple  # a key path: str keys and int list indices
DOCUMENT = "<document>"  # key path shown for errors about the whole file


def format_path(path: KeyPath) -> str:
    """``("boundary", 0, "fix")`` -> ``"boundary[0].fix"``."""
    out = ""
    for part in path:
        if isinstance(part, int) and not isinstance(part, bool):
            out += f"[{part}]"
        else:
            text = _show(part) if part is None or isinstance(part, bool) else str(part)
            if not text or not text.isprintable():   # '', tabs, line breaks...
                text = repr(text)
            out += ("." if out else "") + text
    return out or DOCUMENT


class CaseError(Exception):
    """A bad case file.  ``str(e) == "file:line: key.path: message"``.

    Attributes: ``file``, ``line`` (int, or None when unknown: shown as
    ``?``), ``path`` (dotted key path string), ``key_path`` (the tuple) and
    ``message``.
    """

    def __init__(self, file: str, line: Optional[int], path: KeyPath | str,
                 message: str):
        self.file = file
        self.line = line
        self.key_path = tuple(path) if not isinstance(path, str) else (path,)
        self.path = path if isinstance(path, str) else format_path(path)
        self.message = message
        self.others: list[CaseError] = []   # all schema errors, when several
        super().__init__(str(self))

    def __str__(self) -> str:
        line = "?" if self.line is None else self.line
        return f"{self.file}:{line}: {self.path}: {self.message}"


def _fail(message: str) -> PydanticCustomError:
    """A validation error whose message is shown to the user unchanged."""
    return PydanticCustomError("case", "{message}", {"message": message})


def _show(value: Any) -> str:
    """A value as the user would write it in YAML, for messages."""
    if value is None:
        return "null"
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, float):
        text = f"{value:g}"
        return text + ".0" if text.lstrip("-").isdigit() else text
    if isinstance(value, int):
        return str(value)
    if isinstance(value, str):
        return repr(value)
    if isinstance(value, dict):
        return "a mapping"
    if isinstance(value, list):
        return "a list"
    return repr(value)


def _nearest_line(lines: dict, path: KeyPath) -> Optional[int]:
    path = tuple(path)
    while path not in lines and path:
        path = path[:-1]
    return lines.get(path)
