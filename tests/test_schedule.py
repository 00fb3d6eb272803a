"""The springs' schedule (rbsm_dyn/partition.py): springs by group (the
parts of their two bodies, the pairs of parts in round-robin phases), then
by (a, b), ties in their given order — a stable sort, so that each body's
wrench is summed in one fixed order for any thread count."""
import numpy as np
import pytest

from rbsm_dyn.partition import PARTS, round_robin, spring_schedule


def _reference(sb, n, parts=PARTS):
    """The definition: np.lexsort((b, a, group)) with each spring's group
    from its bodies' parts (the ground in a's part)."""
    a, b = sb[:, 0].astype(np.int64), sb[:, 1].astype(np.int64)
    gid = {(p, p): p for p in range(parts)}
    g = parts
    for rnd in round_robin(parts):
        for pair in rnd:
            gid[pair] = g
            g += 1
    pa = a * parts // n
    pb = np.where(b == n, pa, np.minimum(b, n) * parts // n)
    group = np.array([gid[(min(x, y), max(x, y))] for x, y in zip(pa, pb)])
    order = np.lexsort((b, a, group))
    return order, np.concatenate([[0], np.cumsum(np.bincount(group, minlength=g))])


@pytest.mark.parametrize("layout", ["random", "faces then supports", "sorted", "ties"])
def test_the_schedule_is_the_stable_sort_by_group_then_bodies(layout):
    """The counting sort by group and the merge of (a, b) runs give the
    permutation of the stable sort by (group, a, b), for springs in any
    order: random, as the build makes them (the faces' springs sorted by
    their cells, then the supports'), already sorted, and with many equal
    (a, b) (a face's spring points) whose given order must stay."""
    rng = np.random.default_rng(7)
    n = 97
    if layout == "random":
        a = rng.integers(0, n, 5000)
        b = np.where(rng.random(5000) < 0.1, n, rng.integers(0, n, 5000))
    elif layout == "ties":
        a = rng.integers(0, 5, 5000)
        b = np.where(rng.random(5000) < 0.3, n, rng.integers(90, n, 5000))
    else:
        a0 = rng.integers(0, n - 1, 4000)
        b0 = np.minimum(a0 + rng.integers(1, 30, 4000), n - 1)
        k = np.lexsort((b0, a0))
        a, b = a0[k], b0[k]
        sup = np.sort(rng.integers(0, n, 600))
        a, b = np.concatenate([a, sup]), np.concatenate([b, np.full(600, n)])
        if layout == "sorted":
            k = np.lexsort((b, a))
            a, b = a[k], b[k]
    sb = np.stack([a, b], axis=1).astype(np.int32)
    order, group_ptr, phase_ptr = spring_schedule(sb, n)
    want, want_ptr = _reference(sb, n)
    assert np.array_equal(order, want)
    assert np.array_equal(group_ptr, want_ptr)
    assert phase_ptr[0] == 0 and phase_ptr[1] == PARTS and phase_ptr[-1] == len(group_ptr) - 1
