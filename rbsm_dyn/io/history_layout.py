"""The layout of an rbsm_dyn history file (H5MD 1.1, docs/history.md):
the H5MD and units-module versions, the groups reserved to rbsm_dyn
(/h5md, /parameters, /checkpoint), which paths a dataset may take, and the
chunk shapes of the time series.  Shared by the writer
(io/history_writer.py) and the reader (io/history_reader.py); re-exported
by io/history.py."""
from __future__ import annotations

import math

H5MD_VERSION = (1, 1)
_UNITS_MODULE_VERSION = (1, 0)
_RESERVED = ("h5md", "parameters", "checkpoint")   # /checkpoint: solvers/checkpoint.py
_CHUNK_TARGET_BYTES = 1 << 20      # about 1 MiB of value data per chunk ...
_CHUNK_MAX_FRAMES = 1024           # ... but no more than this many frames
_STEP_TIME_CHUNK = 1024            # frames per chunk of step/time (8 KiB)
_MAX_CHUNK_BYTES = 1 << 30         # HDF5 refuses chunks of 4 GiB or more


def _norm_path(path: str) -> str:
    if not isinstance(path, str):
        raise TypeError(f"path in file must be a str, got {type(path).__name__}")
    p = path.strip("/")
    parts = p.split("/")
    if not p or any(part in ("", ".", "..") for part in parts):
        raise ValueError(f"invalid path in file: {path!r}")
    if parts[0] in _RESERVED:
        raise ValueError(f"path {path!r} is reserved (/{parts[0]} is written by HistoryWriter)")
    return p


def _chunks(tail_shape: tuple[int, ...], itemsize: int) -> tuple[int, ...]:
    """Chunk shape for a (None, *tail_shape) dataset.

    About 1 MiB per chunk (at most _CHUNK_MAX_FRAMES frames, at least one
    frame): whole frames per chunk, so appending a frame touches one chunk.
    Only if a single frame exceeds 1 GiB is the frame split (along its first
    axes) -- HDF5 chunks must stay below 4 GiB.
    """
    tail = [max(1, int(d)) for d in tail_shape]
    frame_bytes = itemsize * math.prod(tail)
    rows = max(1, min(_CHUNK_MAX_FRAMES, _CHUNK_TARGET_BYTES // max(1, frame_bytes)))
    for i in range(len(tail)):
        if itemsize * math.prod(tail) <= _MAX_CHUNK_BYTES:
            break
        rest = itemsize * math.prod(tail[i + 1:])
        tail[i] = max(1, min(tail[i], _MAX_CHUNK_BYTES // max(1, rest)))
    return (rows, *tail)


class MissingData(KeyError):
    """What a command needs is not in the history (a field not written):
    a KeyError whose text is the message itself (a plain KeyError prints
    its message in quotes)."""

    def __str__(self):
        return str(self.args[0]) if self.args else ""
