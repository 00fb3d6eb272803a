"""Where Numba caches rbsm_dyn's compiled kernels (issue 15, item 5).

Compiled kernels are cached on disk (`cache=True`).  Numba keys a cached
function on its own source file only, so a kernel whose callee in another
file changed (say laws/rupture.py under physics/integrate.py's time loop)
would load stale machine code.  The cache therefore lives in a directory
named by the package version and a hash of the package's files that hold
compiled code, `~/.cache/rbsm_dyn/numba-<version>-<hash>` (or under
$XDG_CACHE_HOME): any edit of them, or an upgrade, starts a fresh cache.
Set on import of the package, before any module defines a kernel (a
kernel's cache folder is fixed when it is defined).  Cache folders of
other versions not used for PRUNE_DAYS are deleted, the newest KEEP kept.
A NUMBA_CACHE_DIR set by the user is left alone.
"""
import hashlib
import os
import shutil
import time
from pathlib import Path

PRUNE_DAYS = 14
KEEP = 4


def kernel_cache_dir(root=None):
    """The cache folder of the package at `root` (this one by default)."""
    root = Path(root or Path(__file__).resolve().parent)
    from ._version import __version__
    h = hashlib.sha1()
    for p in sorted(root.rglob("*.py")):
        text = p.read_bytes()
        if b"njit" in text:              # the files that hold compiled code
            h.update(str(p.relative_to(root)).encode())
            h.update(text)
    base = Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache")
    return base / "rbsm_dyn" / f"numba-{__version__}-{h.hexdigest()[:16]}"


def _prune(current):
    """Delete other cache folders unused for PRUNE_DAYS (the newest KEEP stay)."""
    old = sorted((p for p in current.parent.glob("numba-*") if p != current and p.is_dir()),
                 key=lambda p: p.stat().st_mtime, reverse=True)
    cutoff = time.time() - PRUNE_DAYS * 86400
    for p in old[KEEP:]:
        if p.stat().st_mtime < cutoff:
            shutil.rmtree(p, ignore_errors=True)


def configure():
    if "NUMBA_CACHE_DIR" in os.environ:
        return
    try:
        folder = kernel_cache_dir()
        new = not folder.exists()
        folder.mkdir(parents=True, exist_ok=True)
        if new:
            _prune(folder)
    except OSError:          # no writable home: Numba's default, beside the sources
        return
    # Numba reads NUMBA_CACHE_DIR into numba.config on its import: the
    # variable (children inherit it) and the config, if already imported
    os.environ["NUMBA_CACHE_DIR"] = str(folder)
    import sys
    if "numba" in sys.modules:
        sys.modules["numba"].config.CACHE_DIR = str(folder)
