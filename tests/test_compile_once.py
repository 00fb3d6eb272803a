"""Processes started together on a cold kernel cache compile each kernel
once (rbsm_dyn/compile_once.py): the ranks of an MPI run, a sweep's runs and
the suite's workers would otherwise each compile the same machine code."""
import os
import subprocess
import sys
from pathlib import Path

#: both processes import the package, meet at a barrier (a folder holding
#: one file per arrived process), then call the same cold kernel at once;
#: each prints its Numba cache misses (compiled here) and hits (loaded)
CODE = """
import os, sys, time
import numpy as np
import rbsm_dyn.physics.rotation as R
ready, me = sys.argv[1], sys.argv[2]
open(os.path.join(ready, me), "w").close()
t = time.time()
while len(os.listdir(ready)) < 2 and time.time() - t < 60:
    time.sleep(0.005)
out = np.empty((2, 4))
R.frames_from_normals(np.array([[0.0, 0.0, 1.0], [1.0, 0.0, 0.0]]), out)
assert np.allclose(np.sum(out * out, axis=1), 1.0)
s = R.frames_from_normals.stats
print(sum(s.cache_misses.values()), sum(s.cache_hits.values()))
"""


def test_two_processes_on_a_cold_cache_compile_a_kernel_once(tmp_path):
    """Without the lock both compile (a miss each: the kernel takes longer
    to compile than the processes take to pass the barrier together);
    with it one compiles and the other loads its machine code."""
    ready = tmp_path / "ready"
    ready.mkdir()
    env = dict(os.environ, NUMBA_CACHE_DIR=str(tmp_path / "cache"))
    root = str(Path(__file__).resolve().parent.parent)
    env["PYTHONPATH"] = os.pathsep.join(filter(None, [root, env.get("PYTHONPATH")]))
    procs = [subprocess.Popen([sys.executable, "-c", CODE, str(ready), str(k)], env=env,
                              stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
             for k in range(2)]
    got = []
    for p in procs:
        out, err = p.communicate(timeout=600)
        assert p.returncode == 0, err
        got.append(tuple(map(int, out.split())))
    assert sorted(got) == [(0, 1), (1, 0)], got
