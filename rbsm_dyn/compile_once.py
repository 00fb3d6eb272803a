"""One compilation of a kernel for all the processes that need it at once.

Several rbsm_dyn processes started together on a cold kernel cache (the
ranks of ``mpirun -n N``, a sweep's runs, a test suite's workers) would
each compile the same kernels side by side: N times the CPU for the same
machine code (the threaded inelastic spring pass alone is about 90 s of
one core).  Here every compilation of one of the package's cached kernels
(a Numba dispatcher with ``cache=True``, called from Python or typed inside
another kernel) takes a file lock named by the kernel and its argument
types, in Numba's cache folder: the first process compiles and writes the
cache, the others wait on the lock (asleep, no CPU) and then load the
machine code from the cache (Numba reads its index again on each compile).

Deadlock-free: a process holds Numba's compiler lock (one compiling thread
per process) before it takes a file lock, and takes them in call order
(a kernel before the kernels it calls), which has no cycles; a process
never waits on a lock it holds itself; a lock dies with its process.
Where a lock cannot be taken (no fcntl, a folder that refuses it) the
process compiles as before.  No MPI message is involved.

Installed once by the package's import (rbsm_dyn/__init__.py, install()): on
Numba's dispatcher when it is already imported, else when it is imported
(a finder on sys.meta_path that patches it after it loads), so that
``import rbsm_dyn`` alone does not import Numba.
"""
import hashlib
import importlib.abc
import importlib.util
import os
import sys
import tempfile

try:
    import fcntl
except ImportError:          # (Windows: no lock, each process compiles)
    fcntl = None

#: the package whose kernels are locked (rbsm_dyn)
_PACKAGE = __package__
_DISPATCHER = "numba.core.dispatcher"
#: the lock files this process holds
_held = set()


def _lock_path(kernel, args):
    from numba.core import config
    name = f"{kernel.py_func.__module__}.{kernel.py_func.__qualname__}"
    key = hashlib.sha1(f"{name}{args}".encode()).hexdigest()[:20]
    folder = os.path.join(config.CACHE_DIR or tempfile.gettempdir(), "rbsm_dyn-compile-locks")
    os.makedirs(folder, exist_ok=True)
    return os.path.join(folder, f"{name}-{key}.lock")


def _locking(compile_):
    """Dispatcher.compile under the (kernel, types) file lock for the
    package's cached kernels; anything else as Numba has it."""
    from numba.core import sigutils
    from numba.core.compiler_lock import global_compiler_lock

    def compile(self, sig):
        py = getattr(self, "py_func", None)
        if (py is None or not getattr(py, "__module__", "").startswith(_PACKAGE + ".")
                or type(getattr(self, "_cache", None)).__name__ != "FunctionCache"):
            return compile_(self, sig)
        with global_compiler_lock:
            args = tuple(sigutils.normalize_signature(sig)[0])
            if args in self.overloads:
                return compile_(self, sig)
            try:
                path = _lock_path(self, args)
            except (OSError, AttributeError):
                return compile_(self, sig)
            if path in _held:
                return compile_(self, sig)
            try:
                fd = os.open(path, os.O_CREAT | os.O_RDWR, 0o666)
            except OSError:
                return compile_(self, sig)
            try:
                try:
                    fcntl.flock(fd, fcntl.LOCK_EX)
                except OSError:
                    pass     # (a folder that refuses locks: compile unlocked)
                _held.add(path)
                # from the cache when the process before this one wrote it
                return compile_(self, sig)
            finally:
                _held.discard(path)
                os.close(fd)  # (releases the lock)

    compile.__wrapped__ = compile_
    return compile


def _patch(module):
    d = getattr(module, "Dispatcher", None)
    if d is not None and not hasattr(d.compile, "__wrapped__"):
        d.compile = _locking(d.compile)


class _Finder(importlib.abc.MetaPathFinder):
    """Patches numba.core.dispatcher once it has loaded."""

    def find_spec(self, fullname, path, target=None):
        if fullname != _DISPATCHER:
            return None
        sys.meta_path.remove(self)
        spec = importlib.util.find_spec(fullname)
        if spec is None or spec.loader is None:
            return spec
        exec_module = spec.loader.exec_module

        def patched(module):
            exec_module(module)
            _patch(module)
        spec.loader.exec_module = patched
        return spec


def install():
    """Lock the package's kernel compilations (once per process)."""
    if fcntl is None:
        return
    if _DISPATCHER in sys.modules:
        _patch(sys.modules[_DISPATCHER])
    elif not any(isinstance(f, _Finder) for f in sys.meta_path):
        sys.meta_path.insert(0, _Finder())
