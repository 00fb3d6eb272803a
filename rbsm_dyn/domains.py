"""Domain decomposition of a model's bodies over P processes (MPI ranks).

Two ways to give each body an owner, both weighted by the spring points
that touch a body (its share of the spring pass; DESIGN.md §10):

* `rcb`: recursive coordinate bisection of the body centres (Berger and
  Bokhari, IEEE Trans. Computers 36, 1987): the set is cut across its
  longest extent at the weighted split of P//2 : P − P//2, and each side
  again;
* `metis`: METIS's k-way partition of the spring graph (Karypis and Kumar,
  SIAM J. Sci. Comput. 20, 1998; through pymetis), edges weighted by the
  spring points a pair of bodies shares.

`local_domains` turns the owners into each rank's share: its own bodies
and one layer of ghosts (the bodies its springs reach), the springs that
touch an own body, in the one-process order (so that every own body's
wrench is summed in the same order, and the same bits, as on one
process), and the lists of bodies each rank sends and receives per step.
A spring between two ranks is computed by both (its history is the same
on both: the same positions go in), so one exchange of ghost positions a
step suffices, none of wrenches.  Pure NumPy (and pymetis): no MPI here.
"""
from dataclasses import dataclass, field

import numpy as np


def body_weights(spring_bodies, n_bodies):
    """Spring points touching each body (N,) int64 (a support's at its body
    only), plus one: the body pass's share."""
    sb = np.asarray(spring_bodies)
    w = np.bincount(sb[:, 0], minlength=n_bodies + 1)
    w += np.bincount(sb[:, 1], minlength=n_bodies + 1)
    return w[:n_bodies].astype(np.int64) + 1


def rcb(points, weights, nparts):
    """Owner (N,) int32 of each point by recursive coordinate bisection."""
    points = np.asarray(points, dtype=float)
    weights = np.asarray(weights, dtype=float)
    owner = np.zeros(len(points), dtype=np.int32)
    todo = [(np.arange(len(points)), 0, int(nparts))]
    while todo:
        idx, first, parts = todo.pop()
        if parts == 1 or len(idx) == 0:
            owner[idx] = first
            continue
        left = parts // 2
        p = points[idx]
        axis = int(np.argmax(p.max(axis=0) - p.min(axis=0)))
        # stable: equal coordinates keep the bodies' order (a block mesh's
        # columns), so the cut is the same on every machine
        order = idx[np.argsort(p[:, axis], kind="stable")]
        cw = np.cumsum(weights[order])
        k = int(np.searchsorted(cw, cw[-1] * left / parts)) + 1
        k = min(max(k, 1), len(order) - 1)
        todo.append((order[:k], first, left))
        todo.append((order[k:], first + left, parts - left))
    return owner


def metis(spring_bodies, n_bodies, weights, nparts):
    """Owner (N,) int32 of each body by METIS on the spring graph."""
    import pymetis
    from scipy.sparse import coo_matrix
    sb = np.asarray(spring_bodies)
    inner = sb[:, 1] < n_bodies
    a, b = sb[inner, 0], sb[inner, 1]
    g = coo_matrix((np.ones(len(a), dtype=np.int64), (a, b)), shape=(n_bodies, n_bodies))
    g = (g + g.T).tocsr()
    g.sum_duplicates()
    _, parts = pymetis.part_graph(int(nparts), xadj=g.indptr, adjncy=g.indices,
                                  vweights=np.asarray(weights, dtype=np.int64),
                                  eweights=g.data.astype(np.int64))
    return np.asarray(parts, dtype=np.int32)


METHODS = ("rcb", "metis")


def decompose(model, nparts, method="rcb"):
    """Owner (N,) int32 of each body of `model` over nparts ranks."""
    if method not in METHODS:
        raise ValueError(f"unknown decomposition {method!r} (one of {', '.join(METHODS)})")
    n = model.n_bodies
    if nparts <= 1 or n == 0:
        return np.zeros(n, dtype=np.int32)
    w = body_weights(model.spring_bodies, n)
    if method == "metis":
        return metis(model.spring_bodies, n, w, nparts)
    return rcb(model.body_pos0[:n], w, nparts)


@dataclass
class Domain:
    """One rank's share of a model (indices into the one-process model).

    bodies (n,) global ids: the own bodies (n_own, ascending) then the
    ghosts (ascending); springs (s,) the spring points touching an own
    body, ascending (the one-process order); spring_bodies (s, 2) their
    bodies in local numbering (the ground: n); own_springs (s,) bool those
    whose body a is own (this rank reports them); faces (f,) the face rows
    they use, spring_slot (s,) their rows in `faces`; group_ptr, phase_ptr
    the local schedule (schedule); send, recv: {rank: local body ids} sent
    to and received from each neighbour each step, in ascending global id."""
    rank: int
    n_own: int
    bodies: np.ndarray
    springs: np.ndarray
    spring_bodies: np.ndarray
    own_springs: np.ndarray
    faces: np.ndarray
    spring_slot: np.ndarray
    group_ptr: np.ndarray
    phase_ptr: np.ndarray
    send: dict = field(default_factory=dict)
    recv: dict = field(default_factory=dict)
    #: contact (when the model has it): pairs (c,) the candidate pairs
    #: touching an own body (rows of the one-process list, ascending),
    #: pair_bodies (c, 2) their bodies in local numbering, own_pairs (c,)
    #: those whose body a is own
    pairs: np.ndarray = None
    pair_bodies: np.ndarray = None
    own_pairs: np.ndarray = None
    #: the Poisson correction: the cells linked to an own cell (global ids)
    linked: np.ndarray = None

    @property
    def n_local(self):
        return len(self.bodies)

    def ghost_counts(self):
        """(bodies received, bodies sent) per step."""
        return (sum(len(v) for v in self.recv.values()),
                sum(len(v) for v in self.send.values()))


def schedule(group_of, n_groups, phase_ptr):
    """The local group_ptr, phase_ptr of a rank's springs (group_of: the
    one-process group of each, ascending): an empty group 0 first, alone in
    phase 0, whose pass zeroes every local body's accumulators (the kernels'
    phase-0 groups clear their parts, physics/springs.py clear_part: one part
    here), then the one-process groups in their phases.  Each own body gets
    its contributions in the one-process order, and its running sums end at
    the same group boundaries (physics/springs.py add_wrench): the same sums,
    bit for bit."""
    counts = np.bincount(group_of, minlength=n_groups)
    group_ptr = np.zeros(n_groups + 2, dtype=np.int32)
    np.cumsum(counts, out=group_ptr[2:])
    phase = np.concatenate([[0], np.asarray(phase_ptr, dtype=np.int64) + 1]).astype(np.int32)
    return group_ptr, phase


def ragged(ptr, idx):
    """(new ptr, rows) of the CSR ranges ptr[i]..ptr[i+1] of the rows idx,
    in that order."""
    ptr = np.asarray(ptr, dtype=np.int64)
    idx = np.asarray(idx, dtype=np.int64)
    start = ptr[idx]
    count = ptr[idx + 1] - start
    new = np.zeros(len(count) + 1, dtype=np.int64)
    np.cumsum(count, out=new[1:])
    rows = np.repeat(start - new[:-1], count) + np.arange(new[-1], dtype=np.int64)
    return new, rows


def local_domains(owner, spring_bodies, spring_slot, group_ptr, phase_ptr, pairs=None,
                  links=None):
    """The Domain of every rank (list, by rank) from the owners (N,);
    `pairs` (P, 2): contact's candidate pairs (b = N: the ground), whose
    other bodies join a rank's ghosts after its springs' (so that the
    springs' local numbering does not change with them); `links`: the
    Poisson correction's (cell_slot_ptr, slot_cell, slot_s0, slot_s1)
    (physics/poisson.py): an own cell's force needs its linked neighbours'
    pressures, so those neighbours (`linked`) get their own links' springs
    and cells too (a second layer of ghosts)."""
    owner = np.asarray(owner, dtype=np.int32)
    n = len(owner)
    nparts = int(owner.max()) + 1 if n else 1
    sb = np.asarray(spring_bodies)
    a, b = sb[:, 0].astype(np.int64), sb[:, 1].astype(np.int64)
    owner_g = np.append(owner, -1)              # the ground: no one's
    n_groups = len(group_ptr) - 1
    group_of = np.repeat(np.arange(n_groups), np.diff(np.asarray(group_ptr, dtype=np.int64)))
    doms = []
    for r in range(nparts):
        mine = owner_g == r
        keep = np.flatnonzero(mine[a] | mine[b])
        own = np.flatnonzero(owner == r)
        linked = None
        if links is not None:
            sptr, scell, ss0, ss1 = links
            _, k = ragged(sptr, own)
            linked = np.setdiff1d(np.asarray(scell)[k], own)
            _, k = ragged(sptr, linked)
            _, extra = ragged(np.stack([ss0[k], ss1[k]], axis=1).reshape(-1)
                              if len(k) else np.zeros(1, np.int64),
                              np.arange(0, 2 * len(k), 2))
            keep = np.union1d(keep, extra)
        reach = np.concatenate([a[keep], b[keep]])
        reach = np.unique(reach[reach < n])
        ghost = np.setdiff1d(reach, own, assume_unique=True)
        if pairs is not None:
            pa, pb = pairs[:, 0].astype(np.int64), pairs[:, 1].astype(np.int64)
            pm = np.flatnonzero(mine[pa] | mine[pb])
            met = np.concatenate([pa[pm], pb[pm]])
            ghost = np.concatenate([ghost, np.setdiff1d(met[met < n],
                                                        np.concatenate([own, ghost]))])
        bodies = np.concatenate([own, ghost])
        g2l = np.full(n + 1, -1, dtype=np.int64)
        g2l[bodies] = np.arange(len(bodies))
        g2l[n] = len(bodies)
        lsb = np.stack([g2l[a[keep]], g2l[b[keep]]], axis=1).astype(sb.dtype)
        faces, slot = np.unique(np.asarray(spring_slot)[keep], return_inverse=True)
        gp, pp = schedule(group_of[keep], n_groups, phase_ptr)
        dom = Domain(rank=r, n_own=len(own), bodies=bodies, springs=keep, spring_bodies=lsb,
                     linked=linked,
                     own_springs=mine[a[keep]], faces=faces,
                     spring_slot=slot.astype(np.asarray(spring_slot).dtype),
                     group_ptr=gp, phase_ptr=pp)
        if pairs is not None:
            dom.pairs = pm
            dom.pair_bodies = np.stack([g2l[pa[pm]], g2l[pb[pm]]], axis=1).astype(np.int32)
            dom.own_pairs = mine[pa[pm]]
        go = owner[ghost]
        for q in np.unique(go):
            dom.recv[int(q)] = len(own) + np.flatnonzero(go == q)
        doms.append(dom)
    # what r sends q: q's ghosts that r owns, in q's order, as r's local ids
    for dq in doms:
        for r, where in dq.recv.items():
            g = dq.bodies[where]
            dr = doms[r]
            dq_ids = np.searchsorted(dr.bodies[:dr.n_own], g)
            dr.send[dq.rank] = dq_ids
    return doms


def summary(doms, n_springs):
    """Balance and ghost figures of a decomposition: dict of the largest
    rank's spring points over the mean, the spring points computed twice
    (share of all), the ghosts per rank (largest), bodies exchanged a step."""
    counts = np.array([len(d.springs) for d in doms], dtype=float)
    ghosts = [d.ghost_counts()[0] for d in doms]
    return {"imbalance": float(counts.max() / counts.mean()) if len(counts) else 1.0,
            "duplicated": float(counts.sum() / max(n_springs, 1) - 1.0),
            "ghosts_max": int(max(ghosts) if ghosts else 0),
            "exchanged": int(sum(ghosts))}
