"""The force passes every solver shares: springs, then the auxiliary stress.

The explicit step (physics/integrate.py run_dynamic) and dynamic relaxation
(physics/relax.py run_relax) call this, then contact (explicit only) and
their own body pass; the output steps and Newton's residual call it alone
(solvers/passes.py).  A container that is None prunes its pass before
typing (physics/arrays.py): an elastic scene without the Poisson
correction compiles the elastic spring pass and nothing else here.
"""
import numba as nb
from numba.core import types
from numba.extending import overload

from .inelastic import finish_cell_stress, inelastic_spring_pass
from .poisson import poisson_pass
from .springs import elastic_spring_pass

JIT = dict(cache=True, nogil=True, error_model="numpy")


@nb.njit(**JIT)
def spring_forces(springs, bs, hist, aux, store, step, parallel):
    """Wrenches of all springs and of the auxiliary stress on the bodies
    (bs.body_wrench, bs.body_support), at the present positions.

    springs     arrays.Springs
    bs          arrays.BodyState (store: also bs.spring_force, output steps)
    hist        arrays.SpringHistory (inelastic pass, history updated) or
                None (elastic pass)
    aux         arrays.PoissonSlots or None (no Poisson correction)
    step        [s] an explicit step's size, 0 for a static pass
                (physics/inelastic.py)
    parallel    None: one thread (small models)"""
    spring_pass(springs, bs, hist, store, step, parallel)
    if aux is not None:
        poisson_pass(aux, bs, hist, parallel)


def spring_pass(springs, bs, hist, store, step, parallel):
    """The spring pass of `hist`'s type: elastic (None) or inelastic
    (compiled callers only, spring_forces)."""
    raise NotImplementedError("a compiled function only")


@overload(spring_pass, jit_options=dict(nogil=True, error_model="numpy"))
def _spring_pass_of(springs, bs, hist, store, step, parallel):
    # chosen by type when the caller is typed: an `if hist is None` branch
    # is pruned before typing only when hist is None, so an inelastic run
    # compiled the elastic pass as well (16 s of a cold start, unused)
    if isinstance(hist, types.NoneType):
        def elastic(springs, bs, hist, store, step, parallel):
            elastic_spring_pass(springs, bs, store, parallel)
        return elastic

    def inelastic(springs, bs, hist, store, step, parallel):
        inelastic_spring_pass(springs, bs, hist, store, step, parallel)
        if hist.cell_moment.shape[0] > 0:
            finish_cell_stress(springs, bs, hist)
    return inelastic
