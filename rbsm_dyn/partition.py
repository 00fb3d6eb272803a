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
    # np.lexsort((b, a, group)) in O(S): a counting sort by group, then the
    # runs of (a, b) within each group merged (the build makes a group's
    # springs as two runs: the faces', sorted by their cells, then the
    # supports'), stable, so the same permutation
    order, counts = _by_group(a, b, n_bodies, parts, gid, g)
    group_ptr = np.zeros(g + 1, dtype=np.int32)
    np.cumsum(counts, out=group_ptr[1:])
    _merge_runs(order, a, b, group_ptr)
    return order, group_ptr, np.asarray(phase_ptr, dtype=np.int32)


@nb.njit(cache=True, nogil=True)
def _group_of(a, b, n_bodies, parts, gid):
    """A spring's group: its bodies' parts (the ground in a's part)."""
    d = max(n_bodies, 1)
    pa = (a * parts) // d
    pb = pa if b == n_bodies else (min(b, n_bodies) * parts) // d
    return gid[min(pa, pb), max(pa, pb)]


@nb.njit(cache=True, nogil=True)
def _by_group(a, b, n_bodies, parts, gid, n_groups):
    """(the springs' order by group, stable (a counting sort), the groups'
    sizes): two passes, no per-spring temporaries (a build of 10⁶ cells has
    4·10⁷ springs)."""
    n = len(a)
    counts = np.zeros(n_groups, dtype=np.int64)
    for i in range(n):
        counts[_group_of(a[i], b[i], n_bodies, parts, gid)] += 1
    at = np.zeros(n_groups, dtype=np.int64)
    for k in range(1, n_groups):
        at[k] = at[k - 1] + counts[k - 1]
    order = np.empty(n, dtype=np.int64)
    for i in range(n):
        g = _group_of(a[i], b[i], n_bodies, parts, gid)
        order[at[g]] = i
        at[g] += 1
    return order, counts


@nb.njit(cache=True, nogil=True, inline="always")
def _before(a, b, i, j):
    """(a, b) of spring j before that of spring i (lexicographic)."""
    return a[j] < a[i] or (a[j] == a[i] and b[j] < b[i])


@nb.njit(cache=True, nogil=True)
def _merge_runs(order, a, b, group_ptr):
    """Sort each group's range of `order` by (a, b), stably, in place: a
    natural merge sort (adjacent non-decreasing runs merged pairwise until
    one is left; a sorted range costs one pass)."""
    most = 0
    for g in range(len(group_ptr) - 1):
        most = max(most, group_ptr[g + 1] - group_ptr[g])
    tmp = np.empty(0, dtype=np.int64)
    for g in range(len(group_ptr) - 1):
        lo, hi = np.int64(group_ptr[g]), np.int64(group_ptr[g + 1])
        while True:
            # the runs' starts
            starts = [lo]
            for k in range(lo + 1, hi):
                if _before(a, b, order[k - 1], order[k]):
                    starts.append(k)
            if len(starts) == 1:
                break
            if len(tmp) == 0:
                tmp = np.empty(most, dtype=np.int64)
            starts.append(hi)
            for r in range(0, len(starts) - 2, 2):
                s0, s1, s2 = starts[r], starts[r + 1], starts[r + 2]
                i, j, k = s0, s1, 0
                while i < s1 and j < s2:
                    # a tie takes the left run's first: stable
                    if _before(a, b, order[i], order[j]):
                        tmp[k] = order[j]
                        j += 1
                    else:
                        tmp[k] = order[i]
                        i += 1
                    k += 1
                while i < s1:
                    tmp[k] = order[i]
                    i += 1
                    k += 1
                while j < s2:
                    tmp[k] = order[j]
                    j += 1
                    k += 1
                order[s0:s2] = tmp[:k]
