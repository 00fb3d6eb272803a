"""The force passes every solver shares: springs, then the auxiliary stress.

The explicit step (physics/integrate.py run_dynamic) and dynamic relaxation
(physics/relax.py run_relax) call this, then contact (explicit only) and
their own body pass; the output steps and Newton's residual call it alone
(solvers/passes.py).  A container that is None prunes its pass before
typing (physics/arrays.py): an elastic scene without the Poisson
correction compiles the elastic spring pass and nothing else here.
"""
import numba as nb

from .inelastic import finish_cell_stress, inelastic_spring_pass
from .poisson import poisson_pass
from .springs import elastic_spring_pass

JIT = dict(cache=True, nogil=True, error_model="numpy")


@nb.njit(**JIT)
def spring_forces(springs, bs, hist, aux, store, substep, parallel):
    """Wrenches of all springs and of the auxiliary stress on the bodies
    (bs.body_wrench, bs.body_support), at the present positions.

    springs     arrays.Springs
    bs          arrays.BodyState (store: also bs.spring_force, output steps)
    hist        arrays.SpringHistory (inelastic pass, history updated) or
                None (elastic pass)
    aux         arrays.PoissonSlots or None (no Poisson correction)
    substep     an explicit step's forces (physics/inelastic.py)
    parallel    None: one thread (small models)"""
    if hist is None:
        elastic_spring_pass(springs, bs, store, parallel)
    else:
        inelastic_spring_pass(springs, bs, hist, store, substep, parallel)
        if hist.cell_moment.shape[0] > 0:
            finish_cell_stress(springs, bs, hist)
    if aux is not None:
        poisson_pass(aux, bs, hist, parallel)
