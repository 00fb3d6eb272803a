"""Is this process one of several MPI ranks?  (Standard library only: the
command line asks before it imports NumPy or Numba.)

A launcher (Open MPI's mpirun, MPICH/Hydra, Intel MPI, Slurm's srun)
tells each process the world's size in its environment; mpi4py is imported
only when that size is above one (solvers/distributed.py)."""
import os

#: environment variables that give the world size of an MPI launch
SIZE_ENV = ("OMPI_COMM_WORLD_SIZE", "PMI_SIZE", "PMIX_SIZE", "SLURM_STEP_NUM_TASKS")
#: ... and the number of ranks on this node (threads per rank: cores / that)
LOCAL_SIZE_ENV = ("OMPI_COMM_WORLD_LOCAL_SIZE", "MPI_LOCALNRANKS", "SLURM_STEP_TASKS_PER_NODE")

INSTALL = ("pip install -e '.[mpi]' (mpi4py; it needs an MPI library, e.g. Debian's "
           "openmpi-bin and libopenmpi-dev)")


def _first_int(names):
    for k in names:
        v = os.environ.get(k, "").split("(")[0].split(",")[0].strip()
        if v.isdigit():
            return int(v)
    return None


def env_size():
    """The world size an MPI launcher gives this process (1 without one)."""
    return _first_int(SIZE_ENV) or 1


def local_size():
    """Ranks on this node (the world size when the launcher does not say)."""
    return _first_int(LOCAL_SIZE_ENV) or env_size()


def rank_threads():
    """Numba threads for one rank: this node's cores shared by its ranks."""
    return max(1, (os.cpu_count() or 1) // local_size())


def world():
    """mpi4py's COMM_WORLD when this process is one of several ranks, else
    None.  ImportError (its message the install line) when launched on
    several processes without mpi4py."""
    if env_size() <= 1:
        return None
    try:
        from mpi4py import MPI
    except ImportError as exc:
        raise ImportError(f"launched on {env_size()} MPI processes, but mpi4py is not "
                          f"installed: {INSTALL}") from exc
    comm = MPI.COMM_WORLD
    return comm if comm.size > 1 else None
