"""HDF5 run history in the H5MD 1.1 layout (DESIGN.md section 4): the reader
(the layout: io/history_layout.py; the writer: io/history_writer.py).

Reader
------
:func:`open_history` reads the file (all frames, or a selection) into NumPy
arrays truncated to ``frames`` rows; see :class:`History` and
docs/history.md.  :meth:`History.to_xarray` (or ``open_history(path,
xarray=True)``) gives an xarray Dataset with dims ``frame``, ``body``,
``spring`` when xarray is installed (``pip install 'rbsm_dyn[xarray]'``).
"""
from __future__ import annotations

import errno
import json
import os
from typing import Any

import h5py
import numpy as np

from .history_layout import _RESERVED, MissingData  # noqa: F401
from .history_superblock import _hdf5_signature_at

__all__ = ["History", "open_history", "frame_indices", "history_to_xarray", "HistoryFileError",
           "input_problem", "require_rbsm_history"]


def _read_dataset(ds: h5py.Dataset) -> Any:
    if h5py.check_string_dtype(ds.dtype) is not None:
        out = ds.asstr()[()]
        return out if isinstance(out, str) else np.asarray(out, dtype=object)
    return ds[()]


def _attr_str(obj, name: str, default=None):
    if name not in obj.attrs:
        return default
    v = obj.attrs[name]
    if isinstance(v, np.ndarray) and v.shape == ():
        v = v[()]
    if isinstance(v, bytes):
        return v.decode("utf-8")
    return str(v)


def _read_step_time(g: h5py.Group, name: str, n: int):
    """H5MD step/time: a dataset (one entry per frame) or a scalar (fixed
    interval, optional attribute ``offset``)."""
    if name not in g:
        return None
    ds = g[name]
    if ds.shape == ():
        inc = ds[()]
        off = ds.attrs.get("offset", 0)
        return off + inc * np.arange(n)
    return ds[:n]


class History:
    """An rbsm_dyn history read into memory (see :func:`open_history`).

    Attributes
    ----------
    frames : number of complete frames T (root attribute ``frames``).
    step (T,) int64, time (T,) float64 [s] : of the frames.
    series : {path: value (T, ...)} for every time-dependent element.
    series_step, series_time : {path: (T,)} step and time of each series.
    static : {path: array} for every time-independent dataset.
    units : {path: unit string} for series values and static datasets.
    parameters : {name: str} the ``/parameters`` strings (JSON left as text;
        see :meth:`parameter_json`).
    observables : {name: (T,)} the series under ``observables/``;
        observable_time : {name: time} only for observables whose time
        differs from ``time``.
    status : "running" (run going or killed), "completed" or "failed: ...".
    h5md_version, creator, creator_version, author.
    frames_in_file : complete frames in the file; frame_index (T,) : which
        of them were read (``open_history(path, frames=...)``; all by default,
        then ``frames == frames_in_file``).
    position0, orientation0 : (N, 3), (N, 4) positions and orientations at
        file frame 0 (read even when frame 0 is not selected), or None;
        observables0 : {name: value at file frame 0}.
    """

    BODIES = "particles/bodies"

    def __init__(self, path: str):
        self.path = str(path)
        self.frames = 0
        self.step = np.zeros(0, dtype=np.int64)
        self.time = np.zeros(0, dtype=np.float64)
        self.series: dict[str, np.ndarray] = {}
        self.series_step: dict[str, np.ndarray] = {}
        self.series_time: dict[str, np.ndarray] = {}
        self.static: dict[str, Any] = {}
        self.units: dict[str, str] = {}
        self.parameters: dict[str, str] = {}
        self.status: str | None = None
        self.dimension = 3          # 2: a plane model (root attribute dimension)
        self.plane = ""             # "strain" | "stress" for a plane model
        self.h5md_version: tuple[int, ...] | None = None
        self.creator = self.creator_version = self.author = None
        self.observables: dict[str, np.ndarray] = {}
        self.observable_time: dict[str, np.ndarray] = {}
        self.frames_in_file = 0
        self.frame_index = np.zeros(0, dtype=np.int64)
        self.position0: np.ndarray | None = None
        self.orientation0: np.ndarray | None = None
        self.observables0: dict[str, float] = {}

    # convenience -------------------------------------------------------
    def _body(self, name: str):
        return self.series.get(f"{self.BODIES}/{name}")

    @property
    def position(self):
        """(T, N, 3) [m] body centroids, or None."""
        return self._body("position")

    @property
    def orientation(self):
        """(T, N, 4) unit quaternions, scalar first (w, x, y, z), or None."""
        return self._body("orientation")

    @property
    def velocity(self):
        return self._body("velocity")

    @property
    def angular_velocity(self):
        return self._body("angular_velocity")

    @property
    def displacement(self):
        """position - position at frame 0, (T, N, 3); None without positions."""
        x = self.position
        if x is None:
            return None
        if len(x) == 0 or self.position0 is None:
            return np.zeros_like(x)
        return x - self.position0

    @property
    def spring_state(self):
        """(T, S) int8 spring states (0 elastic, 1 yielded, 2 broken,
        3 contact), or None when not written."""
        return self.series.get("springs/state")

    @property
    def spring_force(self):
        """(T, S, 3) [N] spring forces, or None when not written."""
        return self.series.get("springs/force")

    @property
    def cell_stress(self):
        """(T, N, 3, 3) [Pa] cell stress tensors (symmetric Love–Weber
        averages, solvers/output.py), or None when not written."""
        return self._body("stress")

    @property
    def n_bodies(self) -> int | None:
        """Number of bodies N (from the static masses or the positions)."""
        m = self.static.get(f"{self.BODIES}/mass")
        if m is not None:
            return int(np.shape(m)[0])
        x = self.position
        return None if x is None else int(x.shape[1])

    @property
    def n_springs(self) -> int | None:
        """Number of spring points S (from /connectivity/springs)."""
        c = self.static.get("connectivity/springs")
        return None if c is None else int(np.shape(c)[0])

    def _ground(self, name: str):
        """(T, 3) the observable `name` (along the ground's direction) times
        that direction, or None without a ground motion."""
        along = self.observables.get(name)
        if along is None:
            return None
        e = np.asarray((self.case().get("ground_motion") or {}).get("direction",
                                                                    [1.0, 0.0, 0.0]), float)
        return np.asarray(along, float)[:, None] * (e / np.linalg.norm(e))[None, :]

    @property
    def ground_displacement(self):
        """(T, 3) [m] the ground's displacement (a case with a
        ``ground_motion``: its record integrated and baseline corrected,
        the same as probes ``relative_to: ground`` take), or None."""
        return self._ground("ground_displacement")

    @property
    def ground_velocity(self):
        """(T, 3) [m/s] the ground's velocity, or None (ground_displacement)."""
        return self._ground("ground_velocity")

    @property
    def displacement_relative_to_ground(self):
        """(T, N, 3) [m] each body's displacement less the ground's, or None
        (no positions written, or no ground motion)."""
        u, g = self.displacement, self.ground_displacement
        return None if u is None or g is None else u - g[:, None, :]

    @property
    def velocity_relative_to_ground(self):
        """(T, N, 3) [m/s] each body's velocity less the ground's, or None
        (field ``velocity`` not written, or no ground motion)."""
        v, g = self.velocity, self.ground_velocity
        return None if v is None or g is None else v - g[:, None, :]

    def case(self) -> dict:
        """The resolved case (``/parameters/case`` as a dict), {} if absent."""
        return self.parameter_json("case") if "case" in self.parameters else {}

    def energy_balance(self) -> dict:
        """Energy balance of the run (solvers/output.py), each (T,) [J]:
        ``stored`` = kinetic + strain, ``dissipated`` = damping + plastic +
        fracture (+ contact_friction, + viscous), ``supplied`` = kinetic(0) +
        strain(0) + external_work, and
        ``error`` = stored + dissipated - supplied (0 for an exact balance).
        Missing observables count as 0."""
        o = self.observables
        zero = np.zeros(self.frames)

        def get(name):
            return np.asarray(o.get(name, zero), np.float64)

        stored = get("kinetic") + get("strain")
        dissipated = (get("damping") + get("plastic") + get("fracture")
                      + get("contact_friction") + get("viscous"))
        o0 = self.observables0
        e0 = float(o0.get("kinetic", 0.0)) + float(o0.get("strain", 0.0))
        supplied = e0 + get("external_work")
        return {"stored": stored, "dissipated": dissipated, "supplied": supplied,
                "error": stored + dissipated - supplied}

    def geometry(self):
        """The cells and faces (reference configuration) and their rigid
        motion: :class:`rbsm_dyn.io.geometry.CellGeometry`."""
        from .geometry import CellGeometry
        return CellGeometry.from_history(self)

    def to_xarray(self):
        """The history as an ``xarray.Dataset`` (dims ``frame``, ``body``,
        ``spring``, ``xyz``, ``wxyz``); needs xarray
        (``pip install 'rbsm_dyn[xarray]'``).  See :func:`history_to_xarray`."""
        return history_to_xarray(self)

    def parameter_json(self, name: str) -> Any:
        """``/parameters/<name>`` parsed as JSON."""
        return json.loads(self.parameters[name])

    def __getitem__(self, path: str):
        p = path.strip("/")
        if p in self.series:
            return self.series[p]
        if p in self.static:
            return self.static[p]
        raise KeyError(path)

    def __contains__(self, path: str) -> bool:
        p = path.strip("/")
        return p in self.series or p in self.static

    def close(self) -> None:
        """Nothing to release (everything is in memory); for symmetry."""

    def __enter__(self) -> "History":
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def __repr__(self) -> str:
        return (f"History({self.path!r}, frames={self.frames}, status={self.status!r}, "
                f"series={sorted(self.series)}, static={sorted(self.static)})")


class HistoryFileError(OSError):
    """A history file that cannot be read: not there, a directory, not
    HDF5, truncated or damaged.  The message names the file."""

    def __str__(self):
        return str(self.strerror if self.strerror is not None else super().__str__())


_read_attempts_fn = None


def _metadata_read_attempts(fapl, n: int) -> bool:
    """H5Pset_metadata_read_attempts on an h5py file access list (h5py does
    not wrap it): the HDF5 library h5py loaded, through ctypes.  False when
    it cannot be found (then the library's default stays)."""
    global _read_attempts_fn
    if _read_attempts_fn is None:
        import ctypes
        import ctypes.util
        import glob
        _read_attempts_fn = False
        candidates = []
        try:                       # the copy this process has loaded (Linux)
            with open("/proc/self/maps") as fh:
                candidates += sorted({ln.split()[-1] for ln in fh
                                      if "libhdf5" in ln and "hl" not in ln.rsplit("/", 1)[-1]
                                      and ln.split()[-1].startswith("/")})
        except OSError:
            pass
        here = os.path.dirname(h5py.__file__)
        candidates += glob.glob(os.path.join(here, os.pardir, "h5py.libs", "libhdf5-*"))
        candidates += glob.glob(os.path.join(here, ".dylibs", "libhdf5.*"))
        found = ctypes.util.find_library("hdf5")
        if found:
            candidates.append(found)
        for c in candidates:
            try:
                fn = ctypes.CDLL(c).H5Pset_metadata_read_attempts
            except (OSError, AttributeError):
                continue
            fn.argtypes = [ctypes.c_int64, ctypes.c_uint]
            fn.restype = ctypes.c_int
            _read_attempts_fn = fn
            break
    if not _read_attempts_fn:
        return False
    return _read_attempts_fn(fapl.id, int(n)) >= 0


def _open_swmr(path: str, attempts: int | None) -> h5py.File:
    """A SWMR read-only open; ``attempts``: metadata read attempts (HDF5
    retries a metadata block whose checksum fails, with growing sleeps, 100
    times by default in SWMR mode: right while a writer is running, for
    ever on a damaged file)."""
    if attempts is None:
        return h5py.File(path, "r", swmr=True)
    fapl = h5py.h5p.create(h5py.h5p.FILE_ACCESS)
    fapl.set_fclose_degree(h5py.h5f.CLOSE_STRONG)
    if not _metadata_read_attempts(fapl, attempts):
        return h5py.File(path, "r", swmr=True)
    fid = h5py.h5f.open(os.fsencode(path), h5py.h5f.ACC_RDONLY | h5py.h5f.ACC_SWMR_READ,
                        fapl=fapl)
    return h5py.File(fid)


def _h5_message(exc: BaseException) -> str:
    msg = str(exc.args[0]) if isinstance(exc, KeyError) and exc.args else str(exc)
    if msg.startswith("Unable to synchronously open file (") and msg.endswith(")"):
        msg = msg[len("Unable to synchronously open file ("):-1]
    return msg


def _open_h5(path: str, *, writer_alive: bool | None = None) -> h5py.File:
    """Open a history read-only, failing fast (HistoryFileError naming the
    file) when it is missing, a directory, not HDF5, truncated or damaged.

    A plain read-only open comes first: it checks the superblock and the
    file's length at once.  A file whose SWMR writer is running or was
    killed refuses it ("already open for write"); it is opened in SWMR mode
    then -- with HDF5's patient metadata retries only when a live writer
    holds the lock (io/lock.py; ``writer_alive`` overrides the check), and
    with a single read attempt for a killed run's file, so that a damaged
    file gives an error at once instead of retrying for ever."""
    path = os.fspath(path)
    if os.path.isdir(path):
        raise HistoryFileError(errno.EISDIR, f"{path}: is a directory, not a history file")
    if not os.path.exists(path):
        raise HistoryFileError(errno.ENOENT, f"{path}: no such file")
    try:
        if not _hdf5_signature_at(path):
            raise HistoryFileError(errno.EINVAL, f"not an HDF5 file: {path}")
    except PermissionError:
        raise HistoryFileError(errno.EACCES, f"{path}: permission denied") from None
    try:
        return h5py.File(path, "r")
    except OSError as exc:
        plain_err = exc
    msg = str(plain_err)
    if writer_alive is None:
        from .lock import writer_alive as _alive
        writer_alive = _alive(path)
    if not writer_alive and "already open for write" not in msg:
        raise HistoryFileError(errno.EIO, f"{path}: cannot read the history file "
                                          f"({_h5_message(plain_err)})") from None
    try:
        return _open_swmr(path, None if writer_alive else 1)
    except OSError as exc:
        raise HistoryFileError(errno.EIO, f"{path}: cannot read the history file "
                                          f"({_h5_message(exc)})") from None


def input_problem(path) -> str | None:
    """Why ``path`` cannot be a history to read (a directory, missing), or
    None; for the commands export, render, plot."""
    path = os.fspath(path)
    if os.path.isdir(path):
        return f"{path}: is a directory, not a history file"
    if not os.path.exists(path):
        return f"{path}: no such file"
    if not os.path.isfile(path):
        return f"{path}: not a regular file"
    return None


def require_rbsm_history(path) -> None:
    """HistoryFileError unless history ``path`` was written by rbsm_dyn
    (attribute name of /h5md/creator), for the commands that need its
    layout (export, render, plot); reads nothing else."""
    f = _open_h5(os.fspath(path))
    try:
        with f:
            creator = None
            # (not f.get or `in`: they take a damaged object for a missing one)
            if "h5md" in list(f) and "creator" in list(f["h5md"]):
                creator = _attr_str(f["h5md/creator"], "name")
    except (OSError, RuntimeError, KeyError) as exc:
        raise HistoryFileError(errno.EIO, f"{path}: cannot read the history file, it is "
                                          f"damaged ({_h5_message(exc)})") from None
    if creator != "rbsm_dyn":
        what = (f"its H5MD creator is {creator!r}" if creator is not None
                else "it has no /h5md/creator")
        raise HistoryFileError(errno.EINVAL, f"{path}: not an rbsm_dyn history ({what})")


def frame_indices(frames, n: int) -> np.ndarray:
    """File frame indices (sorted, unique, int64) selected by ``frames`` out
    of ``n`` complete frames: None (all), an int (negative counts from the
    end), a slice, or a sequence of ints.  Raises IndexError for an int out
    of range (a slice is clipped, as in Python)."""
    if frames is None:
        return np.arange(n, dtype=np.int64)
    if isinstance(frames, slice):
        return np.arange(n, dtype=np.int64)[frames]
    if isinstance(frames, (int, np.integer)):
        k = int(frames)
        if not -n <= k < n:
            raise IndexError(f"frame {k} out of range: the file has {n} complete frames")
        return np.array([k % n], dtype=np.int64)
    idx = np.asarray(frames, dtype=np.int64).ravel()
    bad = idx[(idx < -n) | (idx >= n)]
    if len(bad):
        raise IndexError(f"frame {int(bad[0])} out of range: the file has {n} complete frames")
    return np.unique(idx % n) if n else idx


def _take(ds: h5py.Dataset, idx: np.ndarray) -> np.ndarray:
    """Rows ``idx`` (sorted, unique) of a dataset along axis 0, as one
    hyperslab when they are evenly spaced."""
    if len(idx) == 0:
        return ds[0:0]
    if len(idx) == 1:
        return ds[int(idx[0]):int(idx[0]) + 1]
    d = np.diff(idx)
    if np.all(d == d[0]):
        return ds[int(idx[0]):int(idx[-1]) + 1:int(d[0])]
    return ds[idx]


def open_history(path, *, frames=None, xarray: bool = False):
    """Open a history file read-only and read it into memory.

    Everything time-dependent is truncated to the root attribute ``frames``
    (the number of complete frames), so a file being written or left by a
    killed run gives consistent arrays.  Files without ``frames`` (other H5MD
    writers) use the shortest series.

    ``frames`` selects file frames (see :func:`frame_indices`: an int, a
    slice such as ``slice(None, None, 10)``, or a list); only those rows are
    read.  ``xarray=True`` returns :meth:`History.to_xarray` instead of the
    :class:`History`.
    """
    h = History(path)
    f = _open_h5(str(path))
    try:
        with f:
            _read_into(h, f, frames)
    except HistoryFileError:
        raise
    except (OSError, RuntimeError, KeyError, ValueError, TypeError) as exc:
        if isinstance(exc, KeyError) and not str(exc).strip("'\"").startswith("Unable to"):
            raise
        # h5py's errors on damaged metadata or data (a bit flipped ...)
        raise HistoryFileError(errno.EIO, f"{path}: cannot read the history file, it is "
                                          f"damaged ({_h5_message(exc)})") from None
    return h.to_xarray() if xarray else h


def _read_into(h: "History", f: h5py.File, frames) -> None:
    """open_history's reading of the open file ``f`` into ``h``."""
    frames_attr = f.attrs.get("frames")
    h.status = _attr_str(f, "status")
    # a plane model's history: dimension 2 (files before issue 27: 3)
    h.dimension = int(f.attrs.get("dimension", 3))
    h.plane = _attr_str(f, "plane") or ""
    if "h5md" in f:
        g = f["h5md"]
        if "version" in g.attrs:
            h.h5md_version = tuple(int(v) for v in np.ravel(g.attrs["version"]))
        if "creator" in g:
            h.creator = _attr_str(g["creator"], "name")
            h.creator_version = _attr_str(g["creator"], "version")
        if "author" in g:
            h.author = _attr_str(g["author"], "name")
    if "parameters" in f:
        for name, ds in f["parameters"].items():
            if isinstance(ds, h5py.Dataset):
                v = _read_dataset(ds)
                h.parameters[name] = v if isinstance(v, str) else json.dumps(
                    v.tolist() if isinstance(v, np.ndarray) else v)

    # discover elements ---------------------------------------------
    series_groups: dict[str, h5py.Group] = {}
    static_ds: dict[str, h5py.Dataset] = {}

    def visit(name: str, obj) -> None:
        top = name.split("/", 1)[0]
        if top in _RESERVED:
            return
        if isinstance(obj, h5py.Group):
            if isinstance(obj.get("value"), h5py.Dataset) and "step" in obj:
                series_groups[name] = obj
        elif isinstance(obj, h5py.Dataset):
            static_ds[name] = obj

    f.visititems(visit)
    for sp in series_groups:
        for k in [k for k in static_ds if k.startswith(sp + "/")]:
            del static_ds[k]

    lengths = {p: g["value"].shape[0] for p, g in series_groups.items()}
    if frames_attr is not None:
        T = int(frames_attr)
    else:
        T = min(lengths.values()) if lengths else 0
    h.frames_in_file = T
    idx = frame_indices(frames, T)
    h.frame_index = idx
    h.frames = len(idx)

    for p, g in sorted(series_groups.items()):
        n = min(T, lengths[p])
        ip = idx[idx < n]
        value = _take(g["value"], ip)
        h.series[p] = value
        h.units[p] = _attr_str(g["value"], "unit", "1")
        st = _read_step_time(g, "step", n)
        tm = _read_step_time(g, "time", n)
        h.series_step[p] = np.asarray(st[ip] if st is not None else ip, np.int64)
        h.series_time[p] = np.asarray(tm[ip] if tm is not None else np.full(len(ip), np.nan),
                                      np.float64)
        if n > 0:
            if p == f"{History.BODIES}/position":
                h.position0 = value[0] if len(ip) and ip[0] == 0 else g["value"][0]
            elif p == f"{History.BODIES}/orientation":
                h.orientation0 = value[0] if len(ip) and ip[0] == 0 else g["value"][0]
            elif p.startswith("observables/") and g["value"].ndim == 1:
                h.observables0[p[len("observables/"):]] = float(
                    value[0] if len(ip) and ip[0] == 0 else g["value"][0])
    for p, ds in sorted(static_ds.items()):
        h.static[p] = _read_dataset(ds)
        if "unit" in ds.attrs:
            h.units[p] = _attr_str(ds, "unit")

    # frame step/time: from the positions if any, else any full-length series
    if f"{History.BODIES}/position" in h.series and \
            len(h.series[f"{History.BODIES}/position"]) == h.frames:
        ref = f"{History.BODIES}/position"
    else:
        ref = next((p for p in h.series if len(h.series[p]) == h.frames), None)
    if ref is not None:
        h.step = h.series_step[ref]
        h.time = h.series_time[ref]
    for p, v in h.series.items():
        if p.startswith("observables/"):
            name = p[len("observables/"):]
            h.observables[name] = v
            t = h.series_time[p]
            if t.shape != h.time.shape or not np.array_equal(t, h.time):
                h.observable_time[name] = t


# ==================================================================== xarray
_XYZ = ("x", "y", "z")
_WXYZ = ("w", "x", "y", "z")


def _xr_dims(path: str, shape: tuple[int, ...], n_bodies, n_springs, lead=()):
    """Dimension names for an array of ``shape`` (after the ``lead`` dims)."""
    dims = list(lead)
    rest = list(shape[len(lead):])
    if rest and n_bodies is not None and rest[0] == n_bodies and not path.startswith("springs") \
            and not path.startswith("connectivity"):
        dims.append("body")
        rest = rest[1:]
    elif rest and n_springs is not None and rest[0] == n_springs and \
            (path.startswith("springs") or path.startswith("connectivity")):
        dims.append("spring")
        rest = rest[1:]
    else:
        return None
    for j, d in enumerate(rest):
        if d == 3:
            dims.append("xyz" if j == len(rest) - 1 else "xyz_row")
        elif d == 4 and j == len(rest) - 1:
            dims.append("wxyz")
        elif d == 2 and path == "connectivity/springs":
            dims.append("end")
        else:
            dims.append(f"{path.rsplit('/', 1)[-1]}_dim{j}")
    return dims


def history_to_xarray(h: "History"):
    """An ``xarray.Dataset`` of a :class:`History`.

    Dims: ``frame`` (the frames read; coordinates ``time`` [s], ``step``,
    ``frame`` = index in the file), ``body``, ``spring``, ``xyz``, ``wxyz``
    (quaternion components, scalar first), ``end`` (the two bodies of a
    spring).  Variables: the body series by their last path element
    (``position``, ``orientation``, ``velocity``, ``angular_velocity``) and
    ``displacement``; ``spring_state``, ``spring_force``, ...; every
    observable by its name (``kinetic``, probes, ...); per-body and
    per-spring static arrays (``mass``, ``volume``, ``reference_position``,
    ``spring_bodies``, ``spring_area``, ...).  Each variable has attrs
    ``units`` and ``path`` (its path in the HDF5 file).  Mesh geometry
    (ragged arrays) stays out: use :meth:`History.geometry`.
    """
    try:
        import xarray as xr
    except ImportError as exc:      # optional extra
        raise ImportError("History.to_xarray needs xarray: pip install 'rbsm_dyn[xarray]' "
                          "(or pip install xarray); the NumPy arrays need nothing more") from exc
    N, S = h.n_bodies, h.n_springs
    coords = {"frame": ("frame", h.frame_index), "time": ("frame", h.time),
              "step": ("frame", h.step), "xyz": list(_XYZ), "wxyz": list(_WXYZ)}
    if N is not None:
        coords["body"] = np.arange(N)
    if S is not None:
        coords["spring"] = np.arange(S)
    data = {}

    def add(name, path, arr, dims):
        unit = h.units.get(path, "1")
        if name in data:
            name = path.replace("/", "_")
        data[name] = xr.Variable(dims, arr, attrs={"units": unit, "path": path})

    for p, v in h.series.items():
        if len(v) != h.frames:
            continue                  # a series shorter than the frames: leave it out
        tail = p.rsplit("/", 1)[-1]
        if p.startswith("observables/"):
            name = p[len("observables/"):]
            if name in h.observable_time:
                continue
            if v.ndim == 1:
                add(name, p, v, ("frame",))
            continue
        dims = _xr_dims(p, v.shape, N, S, lead=("frame",))
        if dims is None:
            continue
        name = tail if p.startswith(History.BODIES) else "spring_" + tail
        add(name, p, v, dims)
    if h.position is not None and len(h.position) == h.frames:
        add("displacement", f"{History.BODIES}/position", h.displacement,
            ("frame", "body", "xyz"))
    for p, v in h.static.items():
        if not isinstance(v, np.ndarray) or v.ndim == 0 or v.dtype == object:
            continue
        if "/geometry/" in p or p.startswith("springs/faces") or \
                p.startswith("springs/boundary_faces") or p.startswith("modes") or \
                p.startswith("checkpoint"):
            continue
        dims = _xr_dims(p, v.shape, N, S)
        if dims is None:
            continue
        tail = p.rsplit("/", 1)[-1]
        if p == "connectivity/springs":
            name = "spring_bodies"
        elif p.startswith("springs/"):
            name = "spring_" + tail
        else:
            name = tail
        add(name, p, v, dims)
    attrs = {"path": h.path, "status": h.status or "", "frames_in_file": h.frames_in_file,
             "creator": h.creator or "", "creator_version": h.creator_version or ""}
    case = h.case()
    if case.get("name"):
        attrs["case_name"] = case["name"]
    return xr.Dataset(data, coords=coords, attrs=attrs)
