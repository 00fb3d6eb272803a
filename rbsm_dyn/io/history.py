"""HDF5 run history in the H5MD 1.1 layout (DESIGN.md section 4).

The code is in the modules below; this one re-exports their names, so that
``from rbsm_dyn.io.history import HistoryWriter, open_history, ...`` works
as before:

* io/history_layout.py: the H5MD version, the groups reserved to rbsm_dyn
  (/h5md, /parameters, /checkpoint), which paths a dataset may take, the
  chunk shapes of the series;
* io/history_superblock.py: the HDF5 superblock (signature, lookup3
  checksum, clearing the flags a killed SWMR writer leaves);
* io/history_writer.py: :class:`HistoryWriter` (create, append frames,
  buffering, flush, the ``frames`` counter, status, reopen for a restart);
* io/history_reader.py: :func:`open_history`, :class:`History` and
  :meth:`History.to_xarray`, opening a file read-only and failing fast.

The writer and the reader import the layout and the superblock, never each
other.
"""
from .history_layout import H5MD_VERSION
from .history_superblock import _lookup3, clear_status_flags  # noqa: F401
from .history_writer import HistoryWriter
from .history_reader import (History, HistoryFileError, MissingData, _open_h5,  # noqa: F401
                             _read_dataset,
                             frame_indices, history_to_xarray, input_problem, open_history,
                             require_rbsm_history)

__all__ = ["HistoryWriter", "History", "open_history", "frame_indices", "history_to_xarray",
           "H5MD_VERSION", "HistoryFileError"]
