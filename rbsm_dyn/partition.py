"""Spring schedule: which springs a thread may process together.

The spring kernels add each spring's wrench straight into its two bodies'
accumulators (physics/springs.py).  To do that without atomics, and with
the same sums for any thread count, the bodies are cut into PARTS
contiguous ranges (the meshes number cells along a space-filling curve, so
a range is a compact region) and the springs into groups:

* phase 0: one group per part, the springs whose two bodies are both in
  that part (supports included: the ground takes nothing);
* phases 1..: the springs between two parts, one group per pair of parts,
  the pairs scheduled by the round-robin (circle) method so that no two
  groups of a phase share a part (an edge colouring of the complete graph
  K_P with P − 1 colours for even P; Lucas, Récréations mathématiques, 1883).

Groups of one phase run in parallel (prange); inside a group the springs
run in order, sorted by (a, b).  Every body's accumulator therefore gets
its contributions in one fixed order whatever the number of threads.
PARTS is a model constant, not the thread count: changing it changes the
order of the sums (round-off), changing the thread count does not.
"""
import numba as nb
import numpy as np

PARTS = 4   # even; enough for the 2-core reference machine to balance


def round_robin(p):
    """Rounds of the circle method for p (even) players: a list of p − 1
    rounds, each a list of p/2 disjoint pairs (i, j), i < j."""
    others = list(range(1, p))
    rounds = []
    for _ in range(p - 1):
        ring = [0] + others
        pairs = [tuple(sorted((ring[k], ring[p - 1 - k]))) for k in range(p // 2)]
        rounds.append(pairs)
        others = others[-1:] + others[:-1]
    return rounds


def spring_schedule(spring_bodies, n_bodies, parts=PARTS):
    """Order of the springs and the group/phase pointers.

    spring_bodies (S, 2): body a, body b (b = n_bodies for the ground).
    Returns (order (S,) permutation to apply to every per-spring array,
    group_ptr (G+1,) int32 spring ranges of the groups in the new order,
    phase_ptr (F+1,) int32 group ranges of the phases)."""
    a = np.ascontiguousarray(spring_bodies[:, 0], dtype=np.int64)
    b = np.ascontiguousarray(spring_bodies[:, 1], dtype=np.int64)
    # group id: parts first, then the pairs in round-robin order
    gid = np.empty((parts, parts), dtype=np.int64)
    for p in range(parts):
        gid[p, p] = p
    phase_ptr = [0, parts]
    g = parts
    for rnd in round_robin(parts):
        for (i, j) in rnd:
            gid[i, j] = g
            g += 1
        phase_ptr.append(g)
    # np.lexsort((b, a, group)) as one stable sort of a combined key (the
    # same permutation: both are stable), when it fits in 62 bits
    m = n_bodies + 1
    combined = g * m * m < 2**62
    group, key = _groups(a, b, n_bodies, parts, gid, combined)
    order = (np.argsort(key, kind="stable") if combined
             else np.lexsort((b, a, group)))
    counts = np.bincount(group, minlength=g)
    group_ptr = np.zeros(g + 1, dtype=np.int32)
    np.cumsum(counts, out=group_ptr[1:])
    return order, group_ptr, np.asarray(phase_ptr, dtype=np.int32)


@nb.njit(cache=True, nogil=True)
def _groups(a, b, n_bodies, parts, gid, combined):
    """Each spring's group (its bodies' parts, the ground in a's part) and,
    when ``combined``, its sort key (group·m + a)·m + b, m = n_bodies + 1:
    one pass, no temporaries (a build of 10⁶ cells has 4·10⁷ springs)."""
    n = len(a)
    group = np.empty(n, dtype=np.int64)
    key = np.empty(n if combined else 0, dtype=np.int64)
    d = max(n_bodies, 1)
    m = n_bodies + 1
    for i in range(n):
        pa = (a[i] * parts) // d
        pb = pa if b[i] == n_bodies else (min(b[i], n_bodies) * parts) // d
        g = gid[min(pa, pb), max(pa, pb)]
        group[i] = g
        if combined:
            key[i] = (g * m + a[i]) * m + b[i]
    return group, key
