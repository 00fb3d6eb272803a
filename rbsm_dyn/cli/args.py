"""The command line's parsers: the one of run, check and info (and of a bare
case file), the checks of its options, and the parser of a post-processing
command (export, render, plot)."""
import argparse


def parser():
    p = argparse.ArgumentParser(
        prog="python -m rbsm_dyn",
        description="Rigid-body-spring model (Kawai RBSM), explicit dynamics.",
        formatter_class=argparse.RawDescriptionHelpFormatter,
        epilog="progress (stderr): a bar on a terminal; without one (batch jobs, a pipe) a\n"
               "line every 30 s and 10 % of the run, whichever comes later; --quiet: none.\n"
               "The environment variable RBSM_PROGRESS overrides it: bar (or 1) a bar even\n"
               "without a terminal, log lines even on one, 0 or off no progress.  A run's\n"
               "cold start says \"compiling kernels (first run only, about N s)\" first.\n"
               "At the end a run prints the probes' last values (static runs: the reaction\n"
               "and the residual too); the history is in SI units whatever the case's units.")
    p.add_argument("command_or_case", help="run | check | info, or the case file to run "
                   "(export | render | plot RUN.h5: see python -m rbsm_dyn export --help; "
                   "bench: time the explicit loop, python -m rbsm_dyn bench --help; "
                   "spectrum RECORD|RUN.h5: response spectra, python -m rbsm_dyn spectrum --help)")
    p.add_argument("case", nargs="?", help="case file (after a command)")
    p.add_argument("--out", help="output HDF5 file (overrides output.file)")
    p.add_argument("--quiet", action="store_true",
                   help="no progress, no compile notice, no summary (RBSM_PROGRESS: below)")
    p.add_argument("--max-steps", type=int, default=None,
                   help="stop after this many steps (iterations in static mode)")
    p.add_argument("--threads", type=int, default=None,
                   help="Numba threads (default: 1 below 30 000 spring points, else the cores "
                        "other running processes leave idle, looked at again every 30 s)")
    p.add_argument("--restart", metavar="RUN.h5",
                   help="continue the run of this history file from its last checkpoint "
                   "(dynamic mode; frames are appended to RUN.h5)")
    p.add_argument("--no-model-cache", action="store_true",
                   help="build the model even when .rbsm_cache/ beside the case holds it, and "
                        "do not write it there (also RBSM_MODEL_CACHE=0)")
    p.add_argument("--force", action="store_true",
                   help="run (or pass check) even when the run is estimated to take more "
                        "than a day on this machine or to write a history larger than the "
                        "free disk of its folder")
    return p


def option_problem(args):
    """Why an option of a run/check/info cannot be used (None if fine)."""
    if args.threads is not None and args.threads < 1:
        return f"--threads must be at least 1 (got {args.threads})"
    if args.max_steps is not None and args.max_steps < 0:
        return f"--max-steps must be 0 or more (got {args.max_steps})"
    if args.out is not None and not args.out.strip():
        return f"--out needs a file name (got {args.out!r})"
    if args.restart is not None and not args.restart.strip():
        return f"--restart needs a history file (got {args.restart!r})"
    return None


def post_parser(command, module):
    """The parser of export | render | plot RUN.h5: described by the first
    line of the post-processing module's docstring (rbsm_dyn/io/)."""
    return argparse.ArgumentParser(prog=f"python -m rbsm_dyn {command}",
                                   description=(module.__doc__ or "").strip().splitlines()[0])
