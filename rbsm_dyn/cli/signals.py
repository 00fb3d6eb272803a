"""Ctrl-C anywhere outside a run's checkpointed loop: exit 130 and one line,
no traceback (cli.main installs the handler)."""
import os
import sys

#: set by the SIGINT handler below: a KeyboardInterrupt raised inside a
#: library (an import that catches everything, a callback) may be swallowed
#: there, so the flag is checked again after the imports and the build
_INTERRUPTED = False


def _on_sigint(signum, frame):
    global _INTERRUPTED
    _INTERRUPTED = True
    raise KeyboardInterrupt


def interrupted_flag():
    """Whether SIGINT has been received (by the handler above)."""
    return _INTERRUPTED


def stop_if_interrupted():
    if _INTERRUPTED:
        raise KeyboardInterrupt


def interrupted(argv):
    """One line and 130 for Ctrl-C (see cli.main)."""
    try:
        print("rbsm_dyn: interrupted", file=sys.stderr)
        sys.stderr.flush()
        sys.stdout.flush()
    except Exception:
        pass
    if argv is None:
        # as a program: CPython marks a KeyboardInterrupt that went through
        # code run by PyRun_* (inside some imports) as unhandled and, even
        # though it was caught here, ends the process by SIGINT (-2) at
        # exit; the files are closed and the lock released: leave now
        os._exit(130)
    return 130
