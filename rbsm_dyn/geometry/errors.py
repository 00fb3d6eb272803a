"""GeometryError: a bad geometry description, with the key path into it."""
from __future__ import annotations

__all__ = ["GeometryError", "format_path"]


def format_path(path) -> str:
    """("difference", 1, "box") -> "difference[1].box" (the style of case/errors.py)."""
    out = ""
    for part in path:
        if isinstance(part, int) and not isinstance(part, bool):
            out += f"[{part}]"
        else:
            out += ("." if out else "") + str(part)
    return out


class GeometryError(ValueError):
    """A bad geometry description.

    ``path``: tuple of keys and list indices from the top of the spec given
    to :func:`build_solid` to the offending key, e.g.
    ``("difference", 1, "cylinder", "radius")``; ``message``: what is wrong.
    ``str(e) == "difference[1].cylinder.radius: must be > 0 (got -0.1)"``.
    A caller that embeds the spec in a larger document (a case file)
    prefixes its own path to ``path``.
    """

    def __init__(self, path, message: str):
        self.path = tuple(path)
        self.message = message
        super().__init__(str(self))

    def __str__(self) -> str:
        where = format_path(self.path)
        return f"{where}: {self.message}" if where else self.message

    def __reduce__(self):
        return (type(self), (self.path, self.message))
