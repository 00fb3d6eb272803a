"""Command line: python -m rbsm_dyn [run|check|info] CASE.yaml [options],
python -m rbsm_dyn export|render|plot RUN.h5 [options] (post-processing of a
history: rbsm_dyn/io/export.py, rbsm_dyn/io/render.py), and
python -m rbsm_dyn bench [--bodies N --steps K --threads T --physics P] (bench.py),
python -m rbsm_dyn spectrum RECORD|RUN.h5 [options] (response spectra: io/spectrum.py),
python -m rbsm_dyn sweep CASE.yaml --seeds 1..8 [--set KEY=V1,V2] (an ensemble: sweep.py).

Exit status: 0 success, 2 bad case or option (one message naming file,
line and key, or the option and its value; also: the output is locked by a
live run), 1 failed run (divergence or no convergence, with step and time;
the history file stays readable up to the failure), 130/143 stopped by
SIGINT/SIGTERM (dynamic runs after writing a checkpoint;
``CASE.yaml --restart RUN.h5`` continues it: solvers/checkpoint.py; Ctrl-C
before the run, during imports or the build, exits 130 too).

One module a command: run.py, check.py, info.py, export.py, render.py
(render and plot), bench.py, spectrum.py, sweep.py; args.py the parser, prepare.py what run,
check and info share (the case, its model, the preflight), notice.py the
compile notice, progress.py the progress of a run, signals.py Ctrl-C.
The modules import only the standard library when imported (the rest when
called), so that Ctrl-C during the imports is handled by main.
"""
import os
import sys

from . import bench, check, export, info, render, run, signals, spectrum, sweep
from .args import option_problem, parser

#: post-processing commands: the module of each (render: render and plot)
POST_COMMANDS = {"export": "export", "render": "render", "plot": "render"}


def main(argv=None):
    """The command line; returns the exit status.  Ctrl-C at any moment
    outside a run's checkpointed loop ends it with 130 and one line, no
    traceback."""
    import signal
    try:
        if signal.getsignal(signal.SIGINT) is signal.default_int_handler:
            signal.signal(signal.SIGINT, signals._on_sigint)   # (an ignored SIGINT stays ignored)
    except ValueError:                  # not the main thread
        pass
    try:
        return _main(argv)
    except BrokenPipeError:
        # the reader of stdout has gone (`info case.yaml | head`): quiet, as
        # other Unix tools; stdout pointed at /dev/null so that the final
        # flush does not raise again (Python docs, "Note on SIGPIPE")
        try:
            os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        except (OSError, ValueError):
            pass
        return 141
    except KeyboardInterrupt:
        return signals.interrupted(argv)
    except Exception:
        if signals.interrupted_flag():
            # a KeyboardInterrupt that a library wrapped in an error of its
            # own (Ctrl-C inside `import numba`: class creation turns it into
            # RuntimeError "Error calling __set_name__"): still Ctrl-C
            return signals.interrupted(argv)
        raise


def _main(argv=None):
    argv = sys.argv[1:] if argv is None else list(argv)
    for stream in (sys.stdout, sys.stderr):   # a file name that is not UTF-8 prints escaped
        if getattr(stream, "errors", None) == "strict" and hasattr(stream, "reconfigure"):
            stream.reconfigure(errors="backslashreplace")
    if argv[:1] == ["bench"]:
        return bench.main(argv[1:])
    if argv[:1] == ["spectrum"]:
        return spectrum.main(argv[1:])
    if argv[:1] == ["sweep"]:
        return sweep.main(argv[1:])
    if argv and argv[0] in POST_COMMANDS:
        if POST_COMMANDS[argv[0]] == "export":
            return export.main(argv[1:])
        return render.main(argv[1:], argv[0])
    args = parser().parse_args(argv)
    if args.command_or_case in ("run", "check", "info"):
        command, path = args.command_or_case, args.case
        if path is None:
            print(f"rbsm_dyn: {command} needs a case file", file=sys.stderr)
            return 2
    else:
        command, path = "run", args.command_or_case
    problem = option_problem(args)
    if problem:
        print(f"rbsm_dyn: {problem}", file=sys.stderr)
        return 2
    if command == "run":
        from .. import mpi_env
        if mpi_env.env_size() > 1:
            return _run_ranks(args, path)
    return {"run": run, "check": check, "info": info}[command].main(args, path)


def _run_ranks(args, path):
    """A run launched on several MPI processes (solvers/distributed.py):
    rank 0 runs the command as one process does and leads the stepping,
    the other ranks step their shares until it says stop; every rank exits
    with rank 0's status."""
    import signal
    from .. import mpi_env
    # the node's cores shared by its ranks, or --threads (before Numba is
    # imported: its pool's size); rank 0 picks the count as one process
    # does and the other ranks take rank 0's (solvers/distributed.py)
    have = os.environ.get("NUMBA_NUM_THREADS", "")
    want = max(args.threads or 0, int(have) if have.isdigit() else 0)
    os.environ["NUMBA_NUM_THREADS"] = str(want or mpi_env.rank_threads())
    try:
        comm = mpi_env.world()
    except ImportError as exc:
        print(f"rbsm_dyn: {exc}", file=sys.stderr)
        return 2
    if comm is None:
        return run.main(args, path)
    if comm.rank > 0:
        # rank 0 alone answers Ctrl-C and SIGTERM (a checkpoint, then stop)
        signal.signal(signal.SIGINT, signal.SIG_IGN)
        signal.signal(signal.SIGTERM, signal.SIG_IGN)
        from ..solvers.distributed import worker
        try:
            return worker(comm)
        except BaseException:
            # rank 0 would wait for this rank for ever: end the job
            import traceback
            traceback.print_exc()
            comm.Abort(1)
    args.mpi = comm
    code = 1
    try:
        code = run.main(args, path)
        return code
    finally:
        from ..solvers.distributed import stop_workers
        stop_workers(comm, code)
