"""The thread count of a run that does not give one (issue 15).

Numba's default is every core.  On a machine where other programs run,
a parallel region waits at its barrier for a thread the OS has parked:
tens of thousands of steps, several regions each.  So the default counts
only the cores that are idle: the cores this process may run on
(os.sched_getaffinity) less the one-minute load average, rounded, at least
one; and one thread for a model too small for threads to pay
(SERIAL_SPRINGS, benchmarks/README.md "Waiting policy").  One thread is
never slower than one thread; two on a busy two-core machine were 0.5-0.9x
of it.  `--threads` and `solver.threads` override.
"""
import os

#: spring points below which a run uses one thread by default (idle, 2 cores,
#: 2 threads against 1: 0.47x at 1 497, 0.88x at 19 634, 1.30x at 51 634,
#: 1.57x at 106 838, 1.77x at 372 038 spring points; benchmarks/README.md)
SERIAL_SPRINGS = 30000


def idle_cores():
    """Cores this process may use that the last minute's load left idle
    (at least 1)."""
    try:
        cores = len(os.sched_getaffinity(0))
    except (AttributeError, OSError):
        cores = os.cpu_count() or 1
    try:
        load = os.getloadavg()[0]
    except (AttributeError, OSError):
        load = 0.0
    return max(1, min(cores, int(cores - load + 0.5)))


def default_threads(n_springs, available):
    """Threads for a model of n_springs spring points when the user gave no
    count; `available` the most Numba has (NUMBA_NUM_THREADS)."""
    if n_springs < SERIAL_SPRINGS:
        return 1
    return max(1, min(int(available), idle_cores()))
