"""One writer per history file: the lock file ``RUN.h5.lock`` (docs/history.md,
"One writer at a time").

A run (or a restart) takes the lock before it writes anything: it opens
``RUN.h5.lock`` next to the history (created if missing), takes an exclusive
``flock`` on it without waiting and writes its pid into it.  A second run
with the same output, or a ``--restart`` of a run that is still going, finds
the lock held and is refused (:class:`HistoryLocked`, naming the holder's
pid).  The kernel drops a ``flock`` when its process ends, however it ends
(SIGKILL too): a lock file left by a dead run is not held and the next
writer takes it over.  The lock file is removed when the lock is released.

Readers never take the lock: :func:`writer_alive` only asks whether a live
process holds it (a shared ``flock`` attempt that is given back at once), so
that :func:`rbsm_dyn.io.history.open_history` knows whether to wait for a
writer (SWMR retries) or to fail fast on a damaged file.

The lock is advisory and local: it works between processes on one machine
(and on file systems where ``flock`` does, e.g. NFSv4 emulates it).
"""
from __future__ import annotations

import errno
import glob
import os
import time

try:
    import fcntl
except ImportError:             # not POSIX: no locking (nothing else depends on it)
    fcntl = None

__all__ = ["HistoryLock", "HistoryLocked", "lock_path", "writer_alive", "writer_pid",
           "temporary_path"]

#: flock errors of file systems that do not support it (then the pid decides)
_NO_FLOCK = {errno.ENOLCK, errno.EOPNOTSUPP, errno.ENOSYS, errno.EINVAL}

#: a writer that finds the lock held tries again this long before it gives up
#: (a reader's probe holds a shared lock for microseconds)
_RETRY_SECONDS = 0.25


class HistoryLocked(OSError):
    """The history is being written by another live process."""

    def __init__(self, path, pid, lockfile):
        self.path = str(path)
        self.pid = pid
        self.lockfile = str(lockfile)
        who = f"process {pid}" if pid else "another process"
        super().__init__(errno.EBUSY, f"{path}: is being written by {who} (lock file "
                                      f"{lockfile}); wait for it to end or stop it first")

    def __str__(self):
        return self.strerror


def lock_path(path) -> str:
    """The lock file of history ``path``: ``path + ".lock"``."""
    return os.fspath(path) + ".lock"


def temporary_path(path, pid=None) -> str:
    """Where a run writes history ``path`` until its first frame: the hidden
    ``.NAME.tmp-<pid>`` in the same directory (then renamed to ``path``)."""
    path = os.fspath(path)
    folder, name = os.path.split(path)
    return os.path.join(folder, f".{name}.tmp-{os.getpid() if pid is None else pid}")


def _read_pid(fd_or_path):
    try:
        if isinstance(fd_or_path, int):
            os.lseek(fd_or_path, 0, os.SEEK_SET)
            text = os.read(fd_or_path, 64)
        else:
            with open(fd_or_path, "rb") as fh:
                text = fh.read(64)
        return int(text.split()[0])
    except (OSError, ValueError, IndexError):
        return None


def _pid_alive(pid) -> bool:
    if not pid or pid <= 0:
        return False
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:         # alive, another user's
        return True
    except OSError:
        return False
    return True


def writer_pid(path):
    """The pid of the live process holding the lock of history ``path``, or
    None when no live process holds it (no lock file, or a stale one).  Never
    blocks; takes nothing (a shared lock attempt given back at once)."""
    lp = lock_path(path)
    if fcntl is None:
        pid = _read_pid(lp)
        return pid if _pid_alive(pid) else None
    try:
        fd = os.open(lp, os.O_RDONLY)
    except OSError:
        return None
    try:
        try:
            fcntl.flock(fd, fcntl.LOCK_SH | fcntl.LOCK_NB)
        except OSError as exc:
            if exc.errno in (errno.EAGAIN, errno.EWOULDBLOCK, errno.EACCES):
                return _read_pid(fd) or -1          # held: by a live process
            if exc.errno in _NO_FLOCK:
                pid = _read_pid(fd)
                return pid if _pid_alive(pid) else None
            return None
        fcntl.flock(fd, fcntl.LOCK_UN)
        return None
    finally:
        os.close(fd)


def writer_alive(path) -> bool:
    """Does a live process hold the write lock of history ``path``?"""
    return writer_pid(path) is not None


class HistoryLock:
    """The write lock of one history file (module docstring).

    ``HistoryLock(path).acquire()`` (or ``with HistoryLock(path):``) raises
    :class:`HistoryLocked` when a live process holds it, OSError when the lock
    file cannot be made (directory not writable ...).  ``release()`` is
    idempotent.  Acquiring removes temporary histories ``.NAME.tmp-<pid>``
    left by dead runs (:func:`temporary_path`)."""

    def __init__(self, path):
        self.path = os.fspath(path)
        self.lockfile = lock_path(self.path)
        self._fd = None

    @property
    def held(self) -> bool:
        return self._fd is not None

    def acquire(self) -> "HistoryLock":
        if self._fd is not None:
            return self
        deadline = time.monotonic() + _RETRY_SECONDS
        while True:
            fd = os.open(self.lockfile, os.O_RDWR | os.O_CREAT, 0o644)
            try:
                try:
                    if fcntl is None:
                        raise OSError(errno.ENOSYS, "no fcntl")
                    fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
                except OSError as exc:
                    if exc.errno not in _NO_FLOCK:
                        raise
                    # a file system without flock: the pid in the file decides
                    pid = _read_pid(fd)
                    if _pid_alive(pid) and pid != os.getpid():
                        raise BlockingIOError(errno.EAGAIN, "held") from None
            except OSError as exc:
                if exc.errno not in (errno.EAGAIN, errno.EWOULDBLOCK, errno.EACCES):
                    os.close(fd)
                    raise
                pid = _read_pid(fd)
                os.close(fd)
                if time.monotonic() < deadline:
                    time.sleep(0.01)
                    continue
                raise HistoryLocked(self.path, pid, self.lockfile) from None
            # the file may have been removed (released) between open and
            # flock: then this lock is on a dead inode; start again
            try:
                same = os.path.samestat(os.fstat(fd), os.stat(self.lockfile))
            except FileNotFoundError:
                same = False
            if not same:
                os.close(fd)
                continue
            os.ftruncate(fd, 0)
            os.lseek(fd, 0, os.SEEK_SET)
            os.write(fd, f"{os.getpid()}\n".encode())
            self._fd = fd
            break
        self._remove_stale_temporaries()
        return self

    def _remove_stale_temporaries(self):
        folder, name = os.path.split(self.path)
        for p in glob.glob(os.path.join(glob.escape(folder or "."), f".{glob.escape(name)}.tmp-*")):
            try:
                pid = int(p.rsplit("-", 1)[1])
            except ValueError:
                continue
            if pid != os.getpid() and not _pid_alive(pid):
                try:
                    os.unlink(p)
                except OSError:
                    pass

    def release(self) -> None:
        if self._fd is None:
            return
        fd, self._fd = self._fd, None
        try:
            os.unlink(self.lockfile)      # before the unlock: see acquire()
        except OSError:
            pass
        os.close(fd)

    def __enter__(self) -> "HistoryLock":
        return self.acquire()

    def __exit__(self, *exc) -> None:
        self.release()

    def __del__(self):
        try:
            self.release()
        except Exception:
            pass
