"""rbsm_dyn: Kawai rigid-body-spring model, explicit dynamics."""
import os as _os

# Numba's OpenMP threads wait at the end of a parallel region by sleeping,
# not spinning (issue 15): beside one busy process on 2 cores, a 600-body
# bench ran at 0.49x of one thread on two spinning threads and 0.87x with
# PASSIVE (benchmarks/README.md).  Read when the OpenMP runtime loads (the
# first parallel kernel), so set on import; a value the user set is kept.
_os.environ.setdefault("OMP_WAIT_POLICY", "PASSIVE")
from ._version import __version__   # noqa: E402

from . import _kernel_cache as _kc   # noqa: E402  (before any module defines a kernel)

_kc.configure()
from . import compile_once as _co   # noqa: E402  (one process compiles a kernel, others load it)

_co.install()
__all__ = ["open_history", "load_case", "__version__"]


def open_history(path, *, frames=None, xarray=False):
    """Read an rbsm_dyn history (HDF5, H5MD) into NumPy arrays
    (see rbsm_dyn.io.history.History), also while the run is still writing
    it.  ``frames``: which frames to read (int, slice or list; all by
    default); ``xarray=True``: return an xarray Dataset (dims frame, body,
    spring; needs the optional extra ``rbsm_dyn[xarray]``)."""
    from .io.history import open_history as _open
    return _open(path, frames=frames, xarray=xarray)


def load_case(path):
    """Read and validate a case file (raises rbsm_dyn.case.CaseError)."""
    from .case import load_case as _load
    return _load(path)
