"""python -m rbsm_dyn: the command line, rbsm_dyn/cli/ (its docstring gives
the commands and exit statuses); the console script rbsm_dyn calls main.

The names below stay importable from here (tests, benchmarks, scripts):
``from rbsm_dyn.__main__ import main``."""
import os
import sys

from .cli import main
from .cli.notice import (COMPILE_SECONDS, RUN_KERNELS, CompileNotice, _run_kind,
                         cold_kernels, compile_seconds, kernel_is_cold,
                         record_compile_seconds)
from .cli.progress import Progress, progress_style

__all__ = ["main", "COMPILE_SECONDS", "RUN_KERNELS", "CompileNotice", "_run_kind",
           "cold_kernels", "compile_seconds", "kernel_is_cold", "record_compile_seconds",
           "Progress", "progress_style"]

if __name__ == "__main__":
    try:
        code = main()
    except KeyboardInterrupt:           # (between main's return and here)
        os._exit(130)
    sys.exit(code)
