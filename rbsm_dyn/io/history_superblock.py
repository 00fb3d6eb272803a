"""The HDF5 superblock of a history file, read and patched without the
HDF5 library: the file signature and where HDF5 looks for it, the lookup3
checksum of HDF5 metadata, and clearing the status flags that a killed
SWMR writer leaves (HistoryWriter.reopen).  Shared by the writer
(io/history_writer.py) and the reader (io/history_reader.py); re-exported
by io/history.py."""
from __future__ import annotations

import os


def _lookup3(data: bytes, initval: int = 0) -> int:
    """Bob Jenkins' lookup3 hashlittle, the checksum of HDF5 metadata
    (H5_checksum_lookup3)."""
    M = 0xFFFFFFFF

    def rot(x, k):
        return ((x << k) | (x >> (32 - k))) & M

    n = len(data)
    a = b = c = (0xDEADBEEF + n + initval) & M
    i = 0
    while n > 12:
        a = (a + int.from_bytes(data[i:i + 4], "little")) & M
        b = (b + int.from_bytes(data[i + 4:i + 8], "little")) & M
        c = (c + int.from_bytes(data[i + 8:i + 12], "little")) & M
        a = (a - c) & M; a ^= rot(c, 4); c = (c + b) & M      # noqa: E702
        b = (b - a) & M; b ^= rot(a, 6); a = (a + c) & M      # noqa: E702
        c = (c - b) & M; c ^= rot(b, 8); b = (b + a) & M      # noqa: E702
        a = (a - c) & M; a ^= rot(c, 16); c = (c + b) & M     # noqa: E702
        b = (b - a) & M; b ^= rot(a, 19); a = (a + c) & M     # noqa: E702
        c = (c - b) & M; c ^= rot(b, 4); b = (b + a) & M      # noqa: E702
        n -= 12
        i += 12
    if n == 0:
        return c
    tail = bytes(data[i:i + n]) + bytes(12 - n)
    a = (a + int.from_bytes(tail[0:4], "little")) & M
    b = (b + int.from_bytes(tail[4:8], "little")) & M
    c = (c + int.from_bytes(tail[8:12], "little")) & M
    c ^= b; c = (c - rot(b, 14)) & M      # noqa: E702
    a ^= c; a = (a - rot(c, 11)) & M      # noqa: E702
    b ^= a; b = (b - rot(a, 25)) & M      # noqa: E702
    c ^= b; c = (c - rot(b, 16)) & M      # noqa: E702
    a ^= c; a = (a - rot(c, 4)) & M       # noqa: E702
    b ^= a; b = (b - rot(a, 14)) & M      # noqa: E702
    c ^= b; c = (c - rot(b, 24)) & M      # noqa: E702
    return c


_SIGNATURE = b"\x89HDF\r\n\x1a\n"


def clear_status_flags(path) -> None:
    """Clear the "file is open for write / SWMR write" flags that a killed
    writer leaves in the superblock (version 2 or 3, at offset 0: what this
    writer makes), as ``h5clear -s`` does, so the file can be opened for
    writing again.  Raises OSError for another superblock."""
    with open(path, "r+b") as fh:
        head = bytearray(fh.read(12))
        if head[:8] != bytes(_SIGNATURE) or head[8] not in (2, 3):
            raise OSError(f"{path}: not an HDF5 file with a version 2/3 superblock at offset 0")
        size = 12 + 4 * head[9]               # signature .. root object header address
        fh.seek(0)
        block = bytearray(fh.read(size + 4))
        if int.from_bytes(block[size:size + 4], "little") != _lookup3(bytes(block[:size])):
            raise OSError(f"{path}: superblock checksum mismatch")
        block[11] = 0
        block[size:size + 4] = _lookup3(bytes(block[:size])).to_bytes(4, "little")
        fh.seek(0)
        fh.write(block)
        fh.flush()


def _hdf5_signature_at(path: str) -> bool:
    """Does the file carry the HDF5 signature where HDF5 looks for it
    (offset 0, 512, 1024, 2048, ...: after a user block)?"""
    size = os.path.getsize(path)
    with open(path, "rb") as fh:
        off = 0
        while off + 8 <= size:
            fh.seek(off)
            if fh.read(8) == _SIGNATURE:
                return True
            off = 512 if off == 0 else 2 * off
    return False
