"""HDF5 run history in the H5MD 1.1 layout (DESIGN.md section 4): the writer
(the layout: io/history_layout.py; the reader: io/history_reader.py).

Writer
------
::

    with HistoryWriter("run.h5", creator_version="0.1.0",
                       parameters={"case_yaml": text, "case": resolved_dict}) as w:
        w.write_static("particles/bodies/mass", mass, "kg")          # (N,)
        w.write_static("connectivity/springs", pairs, "1")           # (S, 2)
        w.add_series("particles/bodies/position", (N, 3), "f8", "m")
        w.add_series("observables/kinetic", (), "f8", "J")
        w.start()                      # optional: SWMR starts; no new datasets after it
        for ...:
            w.append_frame(step, t, {"particles/bodies/position": x,
                                     "observables/kinetic": ek})
    # leaving the block closes the file: status "completed", or
    # "failed: <exception>" when the block raised

The file is written in HDF5 SWMR mode (single writer, multiple readers), so
other processes (and the writing process itself) can open it while the run
is going.  SWMR forbids creating datasets once it has started: every
``write_static`` and ``add_series`` must come before :meth:`HistoryWriter.start`
(which the first :meth:`HistoryWriter.append_frame` calls if needed).

Each frame is written to every series, flushed, and only then counted in the
root attribute ``frames`` (flushed again).  A reader that keeps to ``frames``
rows -- :func:`open_history` does -- never sees a half-written frame, and a
run killed at any moment (even SIGKILL) leaves a readable file.
"""
from __future__ import annotations

import json
import os
from time import monotonic as _monotonic
from dataclasses import dataclass
from typing import Any, Mapping

import h5py
import numpy as np

from .history_layout import (H5MD_VERSION, _RESERVED, _STEP_TIME_CHUNK, _UNITS_MODULE_VERSION,
                             _chunks, _norm_path)
from .history_superblock import clear_status_flags

__all__ = ["HistoryWriter"]


def _param_text(value: Any) -> str:
    if isinstance(value, str):
        return value
    if isinstance(value, bytes):
        return value.decode("utf-8")
    return json.dumps(value, ensure_ascii=False, indent=1, default=str)


@dataclass
class _Series:
    path: str
    tail_shape: tuple[int, ...]
    dtype: np.dtype
    value: h5py.Dataset
    step: h5py.Dataset
    time: h5py.Dataset


class HistoryWriter:
    """Write an H5MD 1.1 history file (see the module docstring).

    Parameters
    ----------
    path : file to create (an existing file is overwritten).
    creator, creator_version : written to ``/h5md/creator`` (attributes
        ``name`` and ``version``); ``creator_version`` defaults to
        ``rbsm_dyn.__version__``.  ``version=`` is accepted as an alias.
    author : ``/h5md/author`` attribute ``name``.
    parameters : ``{name: str | dict | list | number}``; each becomes the
        string dataset ``/parameters/<name>`` (non-strings as JSON text).
    swmr : write in SWMR mode (default).  Only turn it off on file systems
        without POSIX write ordering (some network file systems); readers in
        other processes then cannot open the file until it is closed.
    lock : True (default): hold the lock file ``path + ".lock"``
        (io/lock.py) from here to :meth:`close`, so that no other writer
        touches the file meanwhile (:class:`rbsm_dyn.io.lock.HistoryLocked`
        if a live process holds it); a held
        :class:`rbsm_dyn.io.lock.HistoryLock` of ``path``: use it (the
        caller releases it); False: no lock.
    stage : write to the temporary ``.NAME.tmp-<pid>`` in the same directory
        and rename it to ``path`` at the first :meth:`append_frame` (an
        existing ``path`` is replaced only then); a writer closed or
        :meth:`discard`-ed before its first frame removes the temporary
        file and leaves ``path`` as it was.  Default False (``path`` is
        overwritten at once).
    """

    def __init__(self, path, *, creator: str = "rbsm_dyn",
                 creator_version: str | None = None,
                 author: str = "rbsm_dyn user",
                 parameters: Mapping[str, Any] | None = None,
                 swmr: bool = True, version: str | None = None, lock=True,
                 stage: bool = False):
        if creator_version is None:
            creator_version = version
        if creator_version is None:
            from .._version import __version__ as creator_version
        self.path = str(path)
        self._swmr = bool(swmr)
        self._series: dict[str, _Series] = {}
        self._frames = 0
        self._started = False
        self._status = "running"
        self._init_buffer()
        self._f = None
        self._take_lock(lock)
        from .lock import temporary_path
        self._staged = temporary_path(self.path) if stage else None
        # libver="latest" is required for SWMR; a larger chunk cache keeps a
        # ~1 MiB chunk in memory between appends.
        try:
            self._f = h5py.File(self._staged or self.path, "w", libver="latest",
                                rdcc_nbytes=4 << 20)
        except BaseException:
            self._drop_lock()
            raise
        try:
            f = self._f
            h5md = f.create_group("h5md")
            h5md.attrs["version"] = np.array(H5MD_VERSION, dtype=np.int32)
            f.create_group("h5md/author").attrs["name"] = str(author)
            cr = f.create_group("h5md/creator")
            cr.attrs["name"] = str(creator)
            cr.attrs["version"] = str(creator_version)
            units = f.create_group("h5md/modules/units")
            units.attrs["version"] = np.array(_UNITS_MODULE_VERSION, dtype=np.int32)
            units.attrs["system"] = "SI"
            pg = f.create_group("parameters")
            for name, value in (parameters or {}).items():
                if not isinstance(name, str) or not name or "/" in name:
                    raise ValueError(f"invalid parameter name {name!r}")
                pg.create_dataset(name, data=_param_text(value),
                                  dtype=h5py.string_dtype("utf-8"))
            f.attrs["frames"] = np.int64(0)
            f.attrs["status"] = self._status
            f.attrs["swmr"] = np.int8(self._swmr)
            f.flush()
        except BaseException:
            self.discard()
            raise

    def _take_lock(self, lock) -> None:
        from .lock import HistoryLock
        self._lock, self._own_lock = None, False
        if isinstance(lock, HistoryLock):
            if not lock.held or os.path.abspath(lock.path) != os.path.abspath(self.path):
                raise ValueError(f"{self.path}: the lock given is not held for this file")
            self._lock = lock
        elif lock:
            self._lock, self._own_lock = HistoryLock(self.path).acquire(), True

    def _drop_lock(self) -> None:
        if self._own_lock and self._lock is not None:
            self._lock.release()
        self._lock = None

    def discard(self) -> None:
        """Close without marking anything; a staged file that has had no
        frame yet is removed (``path`` stays as it was).  Idempotent."""
        try:
            if self._f is not None and self._f.id.valid:
                self._f.close()
        finally:
            if self._staged is not None:
                try:
                    os.unlink(self._staged)
                except OSError:
                    pass
                self._staged = None
            self._drop_lock()

    def _publish(self) -> None:
        """Move a staged file to its name (at the first frame)."""
        if self._staged is not None:
            os.replace(self._staged, self.path)
            self._staged = None

    @classmethod
    def reopen(cls, path, *, frames: int, swmr: bool = True, lock=True) -> "HistoryWriter":
        """Open an existing history to append to it (restart,
        solvers/checkpoint.py): every series is cut back to ``frames``
        complete frames (rows after them -- frames written after the
        checkpoint, or half-written by a kill -- are dropped), ``status``
        becomes "running" again and SWMR starts.  A file left by a killed
        SWMR writer has its superblock "open for write" flags cleared first
        (what ``h5clear -s`` does): the lock (``lock``, as in
        :class:`HistoryWriter`) is taken first, so a live writer's file is
        never touched."""
        self = cls.__new__(cls)
        self.path = str(path)
        self._swmr = bool(swmr)
        self._series = {}
        self._started = False
        self._status = "running"
        self._init_buffer()
        self._f = None
        self._staged = None
        self._take_lock(lock)
        try:
            try:
                self._f = h5py.File(self.path, "r+", libver="latest", rdcc_nbytes=4 << 20)
            except OSError as exc:
                if "already open" not in str(exc):
                    raise
                clear_status_flags(self.path)
                self._f = h5py.File(self.path, "r+", libver="latest", rdcc_nbytes=4 << 20)
        except BaseException:
            self._drop_lock()
            raise
        try:
            f = self._f
            n_file = int(f.attrs.get("frames", 0))
            if not 0 <= int(frames) <= n_file:
                raise ValueError(f"{self.path}: cannot keep {frames} frames, the file has {n_file}")
            found = {}

            def visit(name, obj):
                if name.split("/", 1)[0] in _RESERVED or not isinstance(obj, h5py.Group):
                    return
                if all(isinstance(obj.get(k), h5py.Dataset) for k in ("value", "step", "time")):
                    found[name] = obj

            f.visititems(visit)
            for p, g in found.items():
                v = g["value"]
                self._series[p] = _Series(p, tuple(v.shape[1:]), v.dtype, v, g["step"], g["time"])
                for ds in (g["step"], g["time"], v):
                    if ds.shape[0] != int(frames):
                        ds.resize(int(frames), axis=0)
            f.attrs.modify("frames", np.int64(frames))
            f.attrs.modify("status", self._status)
            f.flush()
            self._frames = int(frames)
        except BaseException:
            self.discard()
            raise
        self.start()
        return self

    @property
    def h5file(self) -> h5py.File:
        """The open h5py.File, for the groups reserved to rbsm_dyn itself
        (/checkpoint: solvers/checkpoint.py)."""
        return self._file()

    # ------------------------------------------------------------------ state
    @property
    def frames(self) -> int:
        """Number of complete frames written (and counted) so far; frames
        still pending under set_buffering are not included."""
        return self._frames

    @property
    def started(self) -> bool:
        return self._started

    @property
    def closed(self) -> bool:
        return self._f is None or not self._f.id.valid

    @property
    def file_path(self) -> str:
        """Where the file is now: ``path``, or its temporary name while a
        staged writer has no frame yet."""
        return self._staged or self.path

    @property
    def status(self) -> str:
        return self._status

    @property
    def series_paths(self) -> list[str]:
        return list(self._series)

    def _file(self) -> h5py.File:
        if self.closed:
            raise RuntimeError(f"history file {self.path} is closed")
        return self._f

    def _check_can_create(self, what: str) -> h5py.File:
        f = self._file()
        if self._started:
            raise RuntimeError(
                f"cannot {what} after start() / the first append_frame(): "
                "HDF5 SWMR mode forbids creating datasets; create every static "
                "dataset and series first")
        return f

    def _ensure_particle_box(self, path: str) -> None:
        # H5MD requires a `box` group in every particles group.
        parts = path.split("/")
        if parts[0] == "particles" and len(parts) >= 3:
            g = self._f.require_group("/".join(parts[:2]))
            if "box" not in g:
                box = g.create_group("box")
                box.attrs["dimension"] = np.int32(3)
                box.attrs["boundary"] = np.array(["none"] * 3, dtype=h5py.string_dtype())

    # --------------------------------------------------------------- creation
    def write_static(self, path_in_file: str, array, unit: str) -> h5py.Dataset:
        """Write a time-independent dataset with attribute ``unit`` ("1" if
        dimensionless).  Only before :meth:`start`."""
        f = self._check_can_create("write_static")
        p = _norm_path(path_in_file)
        if p in f:
            raise ValueError(f"/{p} already exists in {self.path}")
        arr = np.asarray(array)
        self._ensure_particle_box(p)
        if arr.dtype.kind in "UO":
            ds = f.create_dataset(p, data=arr.astype(str).astype(object),
                                  dtype=h5py.string_dtype("utf-8"))
        else:
            ds = f.create_dataset(p, data=arr)
        ds.attrs["unit"] = str(unit)
        return ds

    def add_series(self, path_in_file: str, tail_shape, dtype, unit: str) -> None:
        """Create an H5MD time-dependent element ``<path>/{step,time,value}``
        with ``value`` of shape (0, *tail_shape).  Only before :meth:`start`."""
        f = self._check_can_create("add_series")
        p = _norm_path(path_in_file)
        if p in f:
            raise ValueError(f"/{p} already exists in {self.path}")
        if isinstance(tail_shape, (int, np.integer)):
            tail_shape = (int(tail_shape),)
        tail = tuple(int(d) for d in tail_shape)
        if any(d < 0 for d in tail):
            raise ValueError(f"negative dimension in tail_shape {tail} for {p}")
        dt = np.dtype(dtype)
        if dt.kind in "UOSV":
            raise TypeError(f"series {p}: dtype {dt} not supported (numbers and bool only)")
        self._ensure_particle_box(p)
        g = f.create_group(p)
        step = g.create_dataset("step", shape=(0,), maxshape=(None,), dtype=np.int64,
                                chunks=(_STEP_TIME_CHUNK,))
        step.attrs["unit"] = "1"
        time = g.create_dataset("time", shape=(0,), maxshape=(None,), dtype=np.float64,
                                chunks=(_STEP_TIME_CHUNK,))
        time.attrs["unit"] = "s"
        # A zero-length axis cannot have a fixed maximum with a positive chunk
        # size; leave it unlimited (it stays 0).
        maxshape = (None, *(d if d > 0 else None for d in tail))
        value = g.create_dataset("value", shape=(0, *tail), maxshape=maxshape, dtype=dt,
                                 chunks=_chunks(tail, dt.itemsize))
        value.attrs["unit"] = str(unit)
        self._series[p] = _Series(p, tail, dt, value, step, time)

    def start(self) -> None:
        """End the set-up phase: switch to SWMR mode (readers may now open the
        file concurrently).  No dataset can be added afterwards.  Idempotent;
        called by the first :meth:`append_frame`."""
        f = self._file()
        if self._started:
            return
        f.flush()
        if self._swmr:
            f.swmr_mode = True
        self._started = True

    # ---------------------------------------------------------------- frames
    def _init_buffer(self) -> None:
        self._pending: list = []       # frames appended, not yet written
        self._pending_bytes = 0
        self._last_write = _monotonic()
        self.buffer_frames = 1         # set_buffering
        self.buffer_seconds = 0.0
        self.buffer_bytes = 64 << 20

    def set_root_attr(self, name: str, value) -> None:
        """A root attribute of the file (before :meth:`start`): e.g.
        ``dimension`` (docs/history.md)."""
        self._check_can_create(f"set the root attribute {name}")
        self._f.attrs[name] = value

    def set_buffering(self, frames: int = 1, seconds: float = 0.0,
                      nbytes: int = 64 << 20) -> None:
        """Hold appended frames in memory and write them together (one resize
        and one write per dataset instead of one per frame and dataset: a
        frame of a small model cost ~10 ms alone).  Pending frames are written
        when ``frames`` of them are held, when ``seconds`` have passed since
        the last write, when they reach ``nbytes``, and by :meth:`flush_frames`,
        :meth:`mark_failed` and :meth:`close`.  Default: every frame at once."""
        self.buffer_frames = max(1, int(frames))
        self.buffer_seconds = float(seconds)
        self.buffer_bytes = int(nbytes)

    def append_frame(self, step: int, time: float, values: Mapping[str, Any]) -> int:
        """Append one frame to every series; it is written, flushed and then
        counted (root attribute ``frames``) at once, or with the next ones
        under :meth:`set_buffering`.

        ``values`` maps each series path (as given to :meth:`add_series`) to
        an array of its tail shape.  Every series must be present and no other
        key; shapes are checked before anything is written (arrays are
        copied).  Returns the number of frames appended so far (written or
        pending).
        """
        f = self._file()
        if not self._started:
            self.start()
        given = {_norm_path(k): v for k, v in values.items()}
        missing = [p for p in self._series if p not in given]
        if missing:
            raise KeyError(f"append_frame: no value for series {missing}")
        unknown = [p for p in given if p not in self._series]
        if unknown:
            raise KeyError(f"append_frame: {unknown} not added with add_series "
                           f"(series: {list(self._series)})")
        arrays = {}
        for p, s in self._series.items():
            a = np.asarray(given[p])
            if a.shape != s.tail_shape:
                raise ValueError(f"append_frame: {p} has shape {a.shape}, "
                                 f"expected {s.tail_shape}")
            arrays[p] = np.array(a, dtype=s.dtype, copy=True)
            self._pending_bytes += arrays[p].nbytes
        self._pending.append((int(step), float(time), arrays))
        self._publish()            # a staged file takes its name at its first frame
        if (len(self._pending) >= self.buffer_frames
                or self._pending_bytes >= self.buffer_bytes
                or _monotonic() - self._last_write >= self.buffer_seconds):
            self.flush_frames()
        return self._frames + len(self._pending)

    def flush_frames(self) -> int:
        """Write the pending frames, flush, then count them; returns the
        number of frames on disk."""
        if not self._pending:
            return self._frames
        f = self._file()
        n = self._frames
        k = len(self._pending)
        steps = np.array([fr[0] for fr in self._pending], dtype=np.int64)
        times = np.array([fr[1] for fr in self._pending], dtype=np.float64)
        for p, s in self._series.items():
            for ds in (s.step, s.time, s.value):
                if ds.shape[0] != n + k:
                    ds.resize(n + k, axis=0)
            s.step[n:n + k] = steps
            s.time[n:n + k] = times
            s.value[n:n + k] = np.stack([fr[2][p] for fr in self._pending])
        f.flush()                          # the frames are on disk ...
        f.attrs.modify("frames", np.int64(n + k))
        f.flush()                          # ... and only then counted
        self._frames = n + k
        self._pending = []
        self._pending_bytes = 0
        self._last_write = _monotonic()
        return self._frames

    def truncate(self, frames: int) -> None:
        """Drop every frame after the first ``frames`` (pending ones too): a
        static run that goes back on its path (solvers/newton.py, the
        implicit update given up for IMPL-EX) replaces them.  The count
        (root attribute ``frames``) falls first, so a reader never counts a
        row that is about to go."""
        self.flush_frames()
        f = self._file()
        if not 0 <= int(frames) <= self._frames:
            raise ValueError(f"{self.path}: cannot keep {frames} frames, "
                             f"{self._frames} are written")
        f.attrs.modify("frames", np.int64(frames))
        f.flush()
        for s in self._series.values():
            for ds in (s.step, s.time, s.value):
                ds.resize(int(frames), axis=0)
        f.flush()
        self._frames = int(frames)

    # --------------------------------------------------------------- status
    def _set_status(self, status: str) -> None:
        f = self._file()
        f.attrs.modify("status", status)
        f.flush()
        self._status = status

    def mark_failed(self, message: str) -> None:
        """Write the pending frames, set the root attribute ``status`` to
        ``"failed: <message>"`` and flush.  The data written so far stays
        readable; close() keeps it."""
        self.flush_frames()
        self._set_status(f"failed: {message}")

    def close(self) -> None:
        """Set status "completed" (unless marked failed) and close; release
        the lock.  A staged file without frames is removed instead
        (:meth:`discard`).  Idempotent."""
        if self._staged is not None and not self._pending:
            self.discard()
            return
        if self.closed:
            self._drop_lock()
            return
        try:
            self.flush_frames()
            if self._status == "running":
                self._set_status("completed")
            else:
                self._f.flush()
        finally:
            try:
                self._f.close()
            finally:
                self._drop_lock()

    def __enter__(self) -> "HistoryWriter":
        return self

    def __exit__(self, exc_type, exc, tb) -> None:
        try:
            if exc_type is not None and not self.closed and self._status == "running":
                self.mark_failed(f"{exc_type.__name__}: {exc}")
        finally:
            self.close()
