"""The OpenMP waiting policy rbsm_dyn sets (issue 15): Numba's OpenMP
threads sleep at a barrier unless the user chose otherwise."""
import os
import subprocess
import sys


def _policy(env):
    code = "import os, rbsm_dyn; print(os.environ['OMP_WAIT_POLICY'])"
    return subprocess.run([sys.executable, "-c", code], env=env, capture_output=True,
                          text=True, check=True).stdout.strip()


def test_passive_unless_the_user_set_a_policy():
    env = {k: v for k, v in os.environ.items() if k != "OMP_WAIT_POLICY"}
    assert _policy(env) == "PASSIVE"
    assert _policy(dict(env, OMP_WAIT_POLICY="ACTIVE")) == "ACTIVE"
