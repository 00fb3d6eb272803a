"""The thread count of a run that does not give one (issue 15).

Numba's default is every core.  On a machine where other programs run,
a parallel region waits at its barrier for a thread the OS has parked:
tens of thousands of steps, several regions each.  So the default counts
only the cores that are idle: the cores this process may run on
(os.sched_getaffinity) less the other processes' runnable tasks (sampled
over 0.2 s from /proc/stat; the one-minute load average where there is no
/proc), rounded, at least one; and one thread for a model too small for threads to pay
(SERIAL_SPRINGS, benchmarks/README.md "Waiting policy").  One thread is
never slower than one thread; two on a busy two-core machine were 0.5-0.9x
of it.  While a dynamic run steps, Governor looks again every 30 s, so a
program started beside a run gets its core back (and returns it when it
stops).  A build's threaded passes take Numba's count (build_threads:
long independent ranges, which a busy core does not hold up).
`--threads` and `solver.threads` override.
"""
import math
import os
import time

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


def _cores():
    try:
        return len(os.sched_getaffinity(0))
    except (AttributeError, OSError):
        return os.cpu_count() or 1


def _loadavg():
    try:
        return os.getloadavg()[0]
    except (AttributeError, OSError):
        return 0.0


#: samples of the runnable tasks, and the seconds between two
SAMPLES, SAMPLE_GAP = 10, 0.02


def _procs_running():
    """Tasks runnable on the machine right now (/proc/stat), or None."""
    try:
        with open("/proc/stat") as f:
            for line in f:
                if line.startswith("procs_running"):
                    return int(line.split()[1])
    except (OSError, ValueError, IndexError):
        pass
    return None


def _own_running():
    """This process's threads that are runnable right now (the caller's
    among them)."""
    n = 0
    try:
        for t in os.listdir("/proc/self/task"):
            try:
                with open(f"/proc/self/task/{t}/stat") as f:
                    n += f.read().rsplit(")", 1)[1].split()[0] == "R"
            except (OSError, IndexError):
                pass
    except OSError:
        return 1
    return max(n, 1)


def running_others(samples=None, gap=None):
    """Other processes' runnable tasks now: the mean over SAMPLES looks,
    SAMPLE_GAP apart, of the machine's runnable count less this process's
    own (0.2 s at start-up).  Unlike the load average it forgets a program
    that has just ended (runs started one after another in a script saw
    their predecessor's minute of load and took one thread).  None where
    there is no /proc."""
    samples = SAMPLES if samples is None else samples
    gap = SAMPLE_GAP if gap is None else gap
    total = 0.0
    for k in range(samples):
        n = _procs_running()
        if n is None:
            return None
        total += max(0, n - _own_running())
        if k + 1 < samples:
            time.sleep(gap)
    return total / samples


def idle_cores(own=None, samples=None):
    """Cores this process may use that other processes leave idle (at least
    1): its cores less the others' runnable tasks now (running_others), or
    where that cannot be seen, less the last minute's load average with
    this process's share `own` taken off (default own_load())."""
    cores = _cores()
    load = running_others(samples)
    if load is None:
        load = max(0.0, _loadavg() - (own_load() if own is None else own))
    return max(1, min(cores, int(cores - load + 0.5)))


def build_threads():
    """Threads for one threaded pass of a build (mesh/voronoi_cell.py cells,
    the k-d tree's queries, spring points and arms, the schedule's gathers,
    model/stable_step.py row sums): Numba's count, the load not looked at.
    These passes hand each thread a long range of independent work, with
    no barrier inside it, so a busy core slows one range and not every
    step: beside `yes > /dev/null` on two cores, 200 000 cells built in
    11.9-12.7 s on two threads and 12.8-13.7 s on one, and their stable-step
    bound took 6.5-6.9 s against 8.6-10.0 s.  The model does not depend on
    the count."""
    import numba
    return numba.get_num_threads()


def default_threads(n_springs, available):
    """Threads for a model of n_springs spring points when the user gave no
    count; `available` the most Numba has (NUMBA_NUM_THREADS)."""
    if n_springs < SERIAL_SPRINGS:
        return 1
    return max(1, min(int(available), idle_cores()))


#: seconds between two looks at the load while a run with the default count
#: steps (a program started beside it takes its core back within a minute:
#: the load average's time constant)
RECHECK_SECONDS = 30.0


class Governor:
    """The default thread count kept right during a run: every
    RECHECK_SECONDS, `check()` takes the cores the load of other processes
    leaves idle, this process's own share being its CPU time over the last
    interval (all threads) per wall second, and sets Numba's count to it.
    Results do not depend on the count (partition.py), so it may change
    between steps.  Made by the command line only when no count was given."""

    def __init__(self, n_springs, available, clock=time.monotonic, cpu=time.process_time):
        self.n_springs, self.available = n_springs, int(available)
        self.clock, self.cpu = clock, cpu
        self.t, self.c = clock(), cpu()
        self.changes = 0

    def pick(self, own):
        """The count for this process's recent CPU use `own` [cores]."""
        if self.n_springs < SERIAL_SPRINGS:
            return 1
        # (5 looks 20 ms apart: 0.1 s in 30 s of stepping)
        return max(1, min(self.available, idle_cores(own, samples=5)))

    def check(self):
        """Re-pick the count when RECHECK_SECONDS have passed; returns the
        new count when it changed, else None."""
        now = self.clock()
        if now - self.t < RECHECK_SECONDS:
            return None
        c = self.cpu()
        own = (c - self.c) / (now - self.t)
        self.t, self.c = now, c
        import numba
        n = self.pick(own)
        if n == numba.get_num_threads():
            return None
        numba.set_num_threads(n)
        self.changes += 1
        return n


def on_threads(fn, n, nt, args):
    """fn(*args(i0, i1)) over [0, n) cut into nt contiguous ranges [i0, i1),
    one per Python thread (fn a compiled function that releases the GIL:
    Numba's nogil; the build's serial kernels, whose parallel versions cost
    seconds more to compile); the ranges' results do not depend on nt.
    Returns the calls' results in range order."""
    if nt <= 1 or n < 2 * nt:
        return [fn(*args(0, n))]
    from concurrent.futures import ThreadPoolExecutor
    with ThreadPoolExecutor(nt) as ex:
        return list(ex.map(lambda t: fn(*args(t * n // nt, (t + 1) * n // nt)), range(nt)))
