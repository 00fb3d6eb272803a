"""Numba kernels (DESIGN.md §3): nothing here imports case, mesh or io.

Compiled kernels are cached on disk (`cache=True`).  Numba keys a cached
function on its own source file only, so a kernel whose callee in another
file changed (say laws/rupture.py under physics/integrate.py's time loop)
would load stale machine code.  The cache therefore lives in a directory
named by a hash of the package's files that hold compiled code,
`~/.cache/rbsm_dyn/numba-<hash>` (or under $XDG_CACHE_HOME): any edit of
them, or an upgrade, starts a fresh cache (old ones may be deleted).  A
NUMBA_CACHE_DIR set by the user is left alone.
"""
import hashlib
import os
from pathlib import Path


def _kernel_cache_dir():
    root = Path(__file__).resolve().parent.parent
    h = hashlib.sha1()
    for p in sorted(root.rglob("*.py")):
        text = p.read_bytes()
        if b"njit" in text:              # the files that hold compiled code
            h.update(str(p.relative_to(root)).encode())
            h.update(text)
    base = Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache")
    return base / "rbsm_dyn" / f"numba-{h.hexdigest()[:16]}"


if "NUMBA_CACHE_DIR" not in os.environ:
    try:
        _dir = _kernel_cache_dir()
        _dir.mkdir(parents=True, exist_ok=True)
    except OSError:          # no writable home: Numba's default, beside the sources
        pass
    else:
        import numba
        numba.config.CACHE_DIR = str(_dir)
