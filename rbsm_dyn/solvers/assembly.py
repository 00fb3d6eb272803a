"""Fast re-assembly of the spring stiffness into a fixed block pattern.

K = Σ_s B_sᵀ C_s B_s (Kawai 1978, eq. 8b; stiffness.py builds the same
matrix with NumPy at the reference), assembled here in the present
configuration for the Newton iterations of solvers/newton.py: the 6 × 6
block pattern of the body pairs that share a spring is found once
(BlockPattern), and each assembly is one compiled pass over the springs
writing into the blocks of a BSR matrix (no COO sort, no Python loop):
per spring, C = F T Fᵀ in the world frame (T = diag(k), or a damaging
spring's local tangent) and the blocks
G_aᵀ C G_a, G_aᵀ C G_b, G_bᵀ C G_a, G_bᵀ C G_b with G_a = [−I, [r_a]×],
G_b = [I, −[r_b]×] (r the world arms).  Serial: a spring's four blocks are
summed in spring order, the same result for any thread count.
"""
import numba as nb
import numpy as np
import scipy.sparse as sp

from ..physics.rotation import quat_matrix_np
from .passes import model_arrays


class BlockPattern:
    """The 6 × 6 block sparsity of K for a model: BSR indptr/indices over
    the body pairs (i, j) that share a spring (and every diagonal block),
    and for each spring the rows of its blocks (aa, ab, ba, bb; −1 for a
    ground end)."""

    def __init__(self, model):
        n = model.n_bodies
        sb = model.spring_bodies.astype(np.int64)
        a, b = sb[:, 0], sb[:, 1]
        inner = b < n
        rows = np.concatenate([np.arange(n), a[inner], b[inner]])
        cols = np.concatenate([np.arange(n), b[inner], a[inner]])
        key = np.unique(rows * n + cols)
        r, c = key // n, key % n
        self.n = n
        self.indptr = np.zeros(n + 1, dtype=np.int64)
        np.cumsum(np.bincount(r, minlength=n), out=self.indptr[1:])
        self.indices = c.astype(np.int64)

        def slot(i, j):
            return np.searchsorted(key, i * n + j)
        S = len(sb)
        self.slots = np.full((S, 4), -1, dtype=np.int64)
        self.slots[:, 0] = slot(a, a)
        self.slots[inner, 1] = slot(a[inner], b[inner])
        self.slots[inner, 2] = slot(b[inner], a[inner])
        self.slots[inner, 3] = slot(b[inner], b[inner])
        self.nblocks = len(key)

    def matrix(self, model, body_quat, spring_frames, spring_k, force=None, gap=None):
        """K (6N × 6N, CSR) with the bodies at body_quat (N+1, 4), spring
        frames (S, 4) and stiffnesses (S, 3) [N/m] or local stiffness
        matrices (S, 3, 3) (a damaging spring's tangent: not symmetric); with the spring forces
        on body a and the world gaps (S, 3), plus the geometric stiffness
        (_geometric; K is then not symmetric)."""
        rot = quat_matrix_np(body_quat)
        F = quat_matrix_np(spring_frames)
        data = np.zeros((self.nblocks, 6, 6))
        k = np.ascontiguousarray(spring_k)
        if k.ndim == 2:              # (S, 3): the diagonal of each local matrix
            T = np.zeros((len(k), 3, 3))
            T[:, [0, 1, 2], [0, 1, 2]] = k
            k = T
        _assemble(model_arrays(model)[1], rot, F, k, self.slots, data)
        if force is not None:
            sb = model.spring_bodies
            r_a = np.einsum("sij,sj->si", rot[sb[:, 0]], model.spring_arm_a)
            r_b = np.einsum("sij,sj->si", rot[sb[:, 1]], model.spring_arm_b)
            _geometric(sb, r_a, r_b, F, k, np.ascontiguousarray(force),
                       np.ascontiguousarray(gap), self.slots, data)
        K = sp.bsr_matrix((data, self.indices, self.indptr), shape=(6 * self.n, 6 * self.n))
        return K.tocsr()


@nb.njit(cache=True, inline="always")
def _world(F, T, C):
    """C = F T Fᵀ: a spring's local 3 × 3 stiffness in the world frame."""
    for i in range(3):
        for j in range(3):
            acc = 0.0
            for p in range(3):
                for q in range(3):
                    acc += F[i, p] * T[p, q] * F[j, q]
            C[i, j] = acc


@nb.njit(cache=True, inline="always")
def _spring_blocks(arm_a, arm_b, Ra, Rb, C, G, CG, out):
    """out (4, 6, 6) = G_aᵀ C G_a, G_aᵀ C G_b, G_bᵀ C G_a, G_bᵀ C G_b of one
    spring (Kawai 1978, eq. 8b): G_a = [−I, [r_a]×], G_b = [I, −[r_b]×] with
    the world arms r = R arm; C its world 3 × 3 stiffness.  G (2, 3, 6) and
    CG (2, 3, 6) are scratch."""
    for e in range(2):
        arm = arm_a if e == 0 else arm_b
        R = Ra if e == 0 else Rb
        r0 = R[0, 0] * arm[0] + R[0, 1] * arm[1] + R[0, 2] * arm[2]
        r1 = R[1, 0] * arm[0] + R[1, 1] * arm[1] + R[1, 2] * arm[2]
        r2 = R[2, 0] * arm[0] + R[2, 1] * arm[1] + R[2, 2] * arm[2]
        sg = -1.0 if e == 0 else 1.0
        for i in range(3):
            for j in range(6):
                G[e, i, j] = 0.0
            G[e, i, i] = sg
        # u + θ × r = u − [r]× θ: the rotation columns are −sg [r]×
        G[e, 0, 4] = -sg * -r2
        G[e, 0, 5] = -sg * r1
        G[e, 1, 3] = -sg * r2
        G[e, 1, 5] = -sg * -r0
        G[e, 2, 3] = -sg * -r1
        G[e, 2, 4] = -sg * r0
        for i in range(3):
            for j in range(6):
                CG[e, i, j] = C[i, 0] * G[e, 0, j] + C[i, 1] * G[e, 1, j] \
                    + C[i, 2] * G[e, 2, j]
    for q in range(4):
        ea = 0 if q < 2 else 1
        eb = 0 if (q == 0 or q == 2) else 1
        for i in range(6):
            for j in range(6):
                out[q, i, j] = (G[ea, 0, i] * CG[eb, 0, j] + G[ea, 1, i] * CG[eb, 1, j]
                                + G[ea, 2, i] * CG[eb, 2, j])


@nb.njit(cache=True)
def _assemble(springs, rot, frames, k, slots, data):
    """Add Σ B_sᵀ C_s B_s of every spring (springs: physics/arrays.Springs,
    the Model's, as the explicit passes read it) into the BSR blocks."""
    spring_bodies = springs.spring_bodies
    arm_a = springs.spring_arm_a
    arm_b = springs.spring_arm_b
    n = rot.shape[0] - 1
    G = np.zeros((2, 3, 6))
    C = np.zeros((3, 3))
    CG = np.zeros((2, 3, 6))
    blocks = np.zeros((4, 6, 6))
    for s in range(spring_bodies.shape[0]):
        a = spring_bodies[s, 0]
        b = spring_bodies[s, 1]
        _world(frames[s], k[s], C)
        _spring_blocks(arm_a[s], arm_b[s], rot[a], rot[b], C, G, CG, blocks)
        ground = b >= n
        for q in range(4):
            if q > 0 and ground:
                continue
            blk = slots[s, q]
            for i in range(6):
                for j in range(6):
                    data[blk, i, j] += blocks[q, i, j]


@nb.njit(cache=True)
def assemble_triplets(listed, springs, rot, frames, k, rows, cols, vals):
    """COO triplets (global DOF row, column, value) of Σ B_sᵀ C_s B_s over
    the listed springs, 144 per spring (rows, cols, vals of length
    144 len(listed); the ground's blocks get row −1); k (len(listed), 3, 3)
    the springs' local stiffnesses, frames (S, 3, 3) world matrices
    (springs: physics/arrays.Springs)."""
    spring_bodies = springs.spring_bodies
    arm_a = springs.spring_arm_a
    arm_b = springs.spring_arm_b
    n = rot.shape[0] - 1
    G = np.zeros((2, 3, 6))
    C = np.zeros((3, 3))
    CG = np.zeros((2, 3, 6))
    blocks = np.zeros((4, 6, 6))
    p = 0
    for t in range(listed.shape[0]):
        s = listed[t]
        a = spring_bodies[s, 0]
        b = spring_bodies[s, 1]
        _world(frames[s], k[t], C)
        _spring_blocks(arm_a[s], arm_b[s], rot[a], rot[b], C, G, CG, blocks)
        for q in range(4):
            ra = a if q < 2 else b
            cb = a if (q == 0 or q == 2) else b
            off = ra >= n or cb >= n
            for i in range(6):
                for j in range(6):
                    rows[p] = -1 if off else 6 * ra + i
                    cols[p] = -1 if off else 6 * cb + j
                    vals[p] = blocks[q, i, j]
                    p += 1


@nb.njit(cache=True)
def changed_springs(k, k0, out):
    """Indices of the springs whose local stiffness k (S, 3, 3) differs from
    k0 into out; returns their count."""
    c = 0
    for s in range(k.shape[0]):
        for i in range(3):
            done = False
            for j in range(3):
                if k[s, i, j] != k0[s, i, j]:
                    out[c] = s
                    c += 1
                    done = True
                    break
            if done:
                break
    return c


@nb.njit(inline="always", cache=True)
def _skew(x, y, z, out):
    """out = [v]×, the cross-product matrix of v = (x, y, z)."""
    out[0, 0] = 0.0
    out[0, 1] = -z
    out[0, 2] = y
    out[1, 0] = z
    out[1, 1] = 0.0
    out[1, 2] = -x
    out[2, 0] = -y
    out[2, 1] = x
    out[2, 2] = 0.0


@nb.njit(cache=True)
def _geometric(spring_bodies, r_a, r_b, frames, k, f, d, slots, data):
    """Initial-stress (geometric) blocks of the spring wrenches, −∂w/∂θ
    (added to the material K of _assemble; not symmetric).  A spring with
    world force f on body a (−f on b), world gap d = (x_b + r_b) − (x_a + r_a)
    and C = F diag(k) Fᵀ:
    * its frame turns with the mean rotation ω = ½(δθ_a + δθ_b):
      δf = (−[f]× + C [d]×) ω (δf = [ω]× f − C [ω]× d);
    * its arms turn with their bodies in the moments r × f:
      δ(r_a × f) = (r_a fᵀ − (f·r_a) I) δθ_a, and −(r_b fᵀ − (f·r_b) I) δθ_b
      for the moment −r_b × f on b (a × (b × c) = b (a·c) − c (a·b))."""
    D = np.zeros((3, 3))
    C = np.zeros((3, 3))
    Fx = np.zeros((3, 3))
    Dx = np.zeros((3, 3))
    RaD = np.zeros((3, 3))
    RbD = np.zeros((3, 3))
    # (scratch filled in place: no allocation per spring)
    for s in range(spring_bodies.shape[0]):
        a = spring_bodies[s, 0]
        b = spring_bodies[s, 1]
        ground = slots[s, 1] < 0
        _world(frames[s], k[s], C)
        f0, f1, f2 = f[s, 0], f[s, 1], f[s, 2]
        d0, d1, d2 = d[s, 0], d[s, 1], d[s, 2]
        # D = −[f]× + C [d]×
        _skew(f0, f1, f2, Fx)
        _skew(d0, d1, d2, Dx)
        for i in range(3):
            for j in range(3):
                D[i, j] = -Fx[i, j] + C[i, 0] * Dx[0, j] + C[i, 1] * Dx[1, j] + C[i, 2] * Dx[2, j]
        ra = r_a[s]
        rb = r_b[s]
        # [r_a]× D and [r_b]× D
        for j in range(3):
            RaD[0, j] = -ra[2] * D[1, j] + ra[1] * D[2, j]
            RaD[1, j] = ra[2] * D[0, j] - ra[0] * D[2, j]
            RaD[2, j] = -ra[1] * D[0, j] + ra[0] * D[1, j]
            RbD[0, j] = -rb[2] * D[1, j] + rb[1] * D[2, j]
            RbD[1, j] = rb[2] * D[0, j] - rb[0] * D[2, j]
            RbD[2, j] = -rb[1] * D[0, j] + rb[0] * D[1, j]
        fra = f0 * ra[0] + f1 * ra[1] + f2 * ra[2]
        frb = f0 * rb[0] + f1 * rb[1] + f2 * rb[2]
        # J[row block][col θ]: the derivative of the wrench; K_G = −J
        for q in range(4):
            if q > 0 and ground:
                continue
            blk = slots[s, q]
            row_b = q >= 2          # rows of body b
            col_b = q == 1 or q == 3
            sg = -1.0 if row_b else 1.0
            for i in range(3):
                for j in range(3):
                    # force rows: ±D/2 on θ columns (3 + j)
                    data[blk, i, 3 + j] -= sg * 0.5 * D[i, j]
                    # moment rows: ±[r]× D/2
                    data[blk, 3 + i, 3 + j] -= sg * 0.5 * (RbD[i, j] if row_b else RaD[i, j])
            if (not row_b) and (not col_b):
                for i in range(3):
                    for j in range(3):
                        data[blk, 3 + i, 3 + j] -= ra[i] * f[s, j] - (fra if i == j else 0.0)
            if row_b and col_b:
                for i in range(3):
                    for j in range(3):
                        data[blk, 3 + i, 3 + j] += rb[i] * f[s, j] - (frb if i == j else 0.0)
