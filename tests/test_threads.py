"""The default thread count (issue 15; rbsm_dyn/threads.py): the idle
cores by the load average, one for a small model; and the OpenMP waiting
policy rbsm_dyn sets (Numba's threads sleep at a barrier unless the user
chose otherwise)."""
import os
import subprocess
import sys

from rbsm_dyn import threads


def test_one_thread_below_the_serial_size(monkeypatch):
    monkeypatch.setattr(os, "getloadavg", lambda: (0.0, 0.0, 0.0))
    assert threads.default_threads(threads.SERIAL_SPRINGS - 1, 8) == 1


def test_busy_cores_are_not_counted(monkeypatch):
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
