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
import math
import os

#: spring points below which a run uses one thread by default (idle, 2 cores,
#: 2 threads against 1: 0.47x at 1 497, 0.88x at 19 634, 1.30x at 51 634,
#: 1.57x at 106 838, 1.77x at 372 038 spring points; benchmarks/README.md)
SERIAL_SPRINGS = 30000


def own_load():
    """This process's share of the one-minute load average: its mean CPU
    use (all threads) times 1 − exp(−t/60 s), the exponential average's
    response after t seconds of it (the kernel's loadavg is an exponential
    moving average of the runnable count with a 60 s time constant).  A
    long-lived process (a notebook, a test suite) is not its own "other
    load"; a fresh command line is hardly any."""
    try:
        import resource
        with open("/proc/self/stat") as f:
            start = int(f.read().rsplit(")", 1)[1].split()[19])   # field 22, clock ticks
        with open("/proc/uptime") as f:
            now = float(f.read().split()[0])
        age = now - start / os.sysconf("SC_CLK_TCK")
        ru = resource.getrusage(resource.RUSAGE_SELF)
        cpu = ru.ru_utime + ru.ru_stime
    except (ImportError, OSError, ValueError, IndexError):
        return 0.0
    if age <= 0.0:
        return 0.0
    return cpu / age * (1.0 - math.exp(-age / 60.0))


def idle_cores():
    """Cores this process may use that the last minute's load of other
    processes left idle (at least 1)."""
    try:
        cores = len(os.sched_getaffinity(0))
    except (AttributeError, OSError):
        cores = os.cpu_count() or 1
    try:
        load = os.getloadavg()[0]
    except (AttributeError, OSError):
        load = 0.0
    load = max(0.0, load - own_load())
    return max(1, min(cores, int(cores - load + 0.5)))


def default_threads(n_springs, available):
    """Threads for a model of n_springs spring points when the user gave no
    count; `available` the most Numba has (NUMBA_NUM_THREADS)."""
    if n_springs < SERIAL_SPRINGS:
        return 1
    return max(1, min(int(available), idle_cores()))
