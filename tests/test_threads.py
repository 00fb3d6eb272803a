"""The default thread count (issue 15; rbsm_dyn/threads.py): the idle
cores (other processes' runnable tasks now, or the load average), one for
a small model; and the OpenMP waiting policy rbsm_dyn sets (Numba's
threads sleep at a barrier unless the user chose otherwise)."""
import os
import subprocess
import sys

from rbsm_dyn import threads


def test_one_thread_below_the_serial_size(monkeypatch):
    monkeypatch.setattr(os, "getloadavg", lambda: (0.0, 0.0, 0.0))
    assert threads.default_threads(threads.SERIAL_SPRINGS - 1, 8) == 1


def test_busy_cores_are_not_counted(monkeypatch):
    # where /proc/stat cannot be read: the load average less this process's share
    monkeypatch.setattr(threads, "_procs_running", lambda: None)
    monkeypatch.setattr(os, "sched_getaffinity", lambda pid: {0, 1}, raising=False)
    monkeypatch.setattr(threads, "own_load", lambda: 0.0)
    big = 10 * threads.SERIAL_SPRINGS
    for load, expect in ((0.0, 2), (0.4, 2), (0.6, 1), (1.0, 1), (5.0, 1)):
        monkeypatch.setattr(os, "getloadavg", lambda load=load: (load, 0.0, 0.0))
        assert threads.default_threads(big, 2) == expect, load
    monkeypatch.setattr(os, "getloadavg", lambda: (0.0, 0.0, 0.0))
    assert threads.default_threads(big, 1) == 1               # NUMBA_NUM_THREADS=1
    # this process's own load is not "other load"
    monkeypatch.setattr(os, "getloadavg", lambda: (1.0, 0.0, 0.0))
    monkeypatch.setattr(threads, "own_load", lambda: 0.9)
    assert threads.default_threads(big, 2) == 2


def test_runnable_tasks_now_not_the_last_minutes_load(monkeypatch):
    """Two cores.  A program that has just ended left a load average of 1.0
    but no runnable task: both cores are idle.  A CPU-bound program now
    (runnable count 2 with this process's 1): one core."""
    monkeypatch.setattr(os, "sched_getaffinity", lambda pid: {0, 1}, raising=False)
    monkeypatch.setattr(os, "getloadavg", lambda: (1.0, 1.0, 1.0))
    monkeypatch.setattr(threads, "_own_running", lambda: 1)
    monkeypatch.setattr(threads, "SAMPLE_GAP", 0.0)
    big = 10 * threads.SERIAL_SPRINGS
    monkeypatch.setattr(threads, "_procs_running", lambda: 1)
    assert threads.default_threads(big, 2) == 2
    monkeypatch.setattr(threads, "_procs_running", lambda: 2)
    assert threads.default_threads(big, 2) == 1
    # on this machine, now: a count of at least this process's own thread
    assert threads._procs_running() >= 1 and threads.running_others() >= 0.0


def test_a_run_gives_a_core_back_to_a_program_started_beside_it(monkeypatch):
    """threads.Governor: two cores, a run on 2 threads.  A CPU-bound program
    starts: the load is 3 (theirs 1 + ours 2) while our threads, sharing two
    cores with it, used 1.3 cores over the last interval: 1.7 cores of other
    load, one left idle -> 1 thread.  It stops: load 1.2, ours 1.0 -> 2."""
    import numba
    monkeypatch.setattr(threads, "_procs_running", lambda: None)    # the load-average path
    monkeypatch.setattr(os, "sched_getaffinity", lambda pid: {0, 1}, raising=False)
    now, cpu, count = [0.0], [0.0], [2]
    monkeypatch.setattr(numba, "get_num_threads", lambda: count[0])
    monkeypatch.setattr(numba, "set_num_threads", lambda n: count.__setitem__(0, n))
    gov = threads.Governor(10 * threads.SERIAL_SPRINGS, 2, clock=lambda: now[0],
                           cpu=lambda: cpu[0])

    def interval(seconds, cores_used, load):
        monkeypatch.setattr(os, "getloadavg", lambda: (load, 0.0, 0.0))
        now[0] += seconds
        cpu[0] += seconds * cores_used
        return gov.check()

    assert interval(10.0, 2.0, 3.0) is None            # not yet RECHECK_SECONDS
    assert interval(threads.RECHECK_SECONDS, 1.3, 3.0) == 1 and count[0] == 1
    assert interval(threads.RECHECK_SECONDS, 1.0, 2.0) is None   # still busy: stays 1
    assert interval(threads.RECHECK_SECONDS, 1.0, 1.2) == 2 and count[0] == 2
    # a model below the serial size stays on one thread whatever the load
    small = threads.Governor(threads.SERIAL_SPRINGS - 1, 2)
    assert small.pick(0.0) == 1


def test_own_load_of_a_busy_process():
    """After ~2 s of pure CPU at the start of a fresh process its share of
    the load average is about (2 s of CPU / age) (1 − e^(−age/60 s)), i.e.
    below 0.05 (a fresh command line counts itself as almost no load), and
    above 0.01 (it sees its own work)."""
    code = ("import time, rbsm_dyn.threads as t\n"
            "t0 = time.process_time()\n"
            "while time.process_time() - t0 < 2.0: pass\n"
            "print(t.own_load())")
    out = float(subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                               check=True).stdout)
    assert 0.01 < out < 0.05



def _policy(env):
    code = "import os, rbsm_dyn; print(os.environ['OMP_WAIT_POLICY'])"
    return subprocess.run([sys.executable, "-c", code], env=env, capture_output=True,
                          text=True, check=True).stdout.strip()


def test_passive_unless_the_user_set_a_policy():
    env = {k: v for k, v in os.environ.items() if k != "OMP_WAIT_POLICY"}
    assert _policy(env) == "PASSIVE"
    assert _policy(dict(env, OMP_WAIT_POLICY="ACTIVE")) == "ACTIVE"

