"""Numba's cache of compiled kernels never serves stale code (issue 15,
item 5): its folder is named by the version and a hash of every file that
holds a kernel, and every kernel of the package is cached there."""
import os
import shutil
import subprocess
import sys
from pathlib import Path

import rbsm_dyn
from rbsm_dyn._kernel_cache import kernel_cache_dir

PKG = Path(rbsm_dyn.__file__).resolve().parent


def test_an_edit_of_a_callee_in_another_file_changes_the_cache_folder(tmp_path):
    """Numba alone keys a kernel on its own file: an edit of the rupture law
    (called from physics/inelastic.py's loop) would leave the caller's
    machine code in place.  The folder is new after such an edit, and
    unchanged by an edit of a file without kernels."""
    copy = tmp_path / "rbsm_dyn"
    shutil.copytree(PKG, copy, ignore=shutil.ignore_patterns("__pycache__"))
    before = kernel_cache_dir(copy)
    assert before.name.startswith(f"numba-{rbsm_dyn.__version__}-")
    case = copy / "case" / "__init__.py"
    case.write_text(case.read_text() + "\n# an edit without kernels\n")
    assert kernel_cache_dir(copy) == before
    law = copy / "physics" / "laws" / "rupture.py"
    law.write_text(law.read_text() + "\n# a changed callee\n")
    assert kernel_cache_dir(copy) != before


def test_every_kernel_caches_in_the_keyed_folder():
    """Also kernels of modules imported before physics (mesh/interface.py:
    a kernel's cache folder is fixed when it is defined)."""
    code = ("import rbsm_dyn.mesh.interface as I, rbsm_dyn.physics.springs as S, os, sys\n"
            "print(os.environ['NUMBA_CACHE_DIR'])\n"
            "print(I._overlap_kernel._cache._cache_path)\n"
            "print(S.elastic_spring_pass._cache._cache_path)\n")
    env = {k: v for k, v in os.environ.items() if k != "NUMBA_CACHE_DIR"}
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True,
                         check=True).stdout.split()
    folder = str(kernel_cache_dir())
    assert out[0] == folder
    assert all(p.startswith(folder + os.sep) for p in out[1:]), out
