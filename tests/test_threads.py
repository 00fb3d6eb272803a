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
    big = 10 * threads.SERIAL_SPRINGS
    for load, expect in ((0.0, 2), (0.4, 2), (0.6, 1), (1.0, 1), (5.0, 1)):
        monkeypatch.setattr(os, "getloadavg", lambda load=load: (load, 0.0, 0.0))
        assert threads.default_threads(big, 2) == expect, load
    monkeypatch.setattr(os, "getloadavg", lambda: (0.0, 0.0, 0.0))
    assert threads.default_threads(big, 1) == 1               # NUMBA_NUM_THREADS=1



def _policy(env):
    code = "import os, rbsm_dyn; print(os.environ['OMP_WAIT_POLICY'])"
    return subprocess.run([sys.executable, "-c", code], env=env, capture_output=True,
                          text=True, check=True).stdout.strip()


def test_passive_unless_the_user_set_a_policy():
    env = {k: v for k, v in os.environ.items() if k != "OMP_WAIT_POLICY"}
    assert _policy(env) == "PASSIVE"
    assert _policy(dict(env, OMP_WAIT_POLICY="ACTIVE")) == "ACTIVE"
