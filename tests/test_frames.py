"""The build's rotation conversions (vectorised: no Python loop over
springs or bodies, issue 15): Shepperd's quaternion of a rotation matrix
and the spring frames (n, s, t) of unit normals."""
import numpy as np

from rbsm_dyn.physics.rotation import frames_from_normals, matrix_to_quat, quat_matrix_np


def _random_rotations(n, seed=1):
    # QR of Gaussian matrices, made proper (det +1): uniform on SO(3)
    q, r = np.linalg.qr(np.random.default_rng(seed).normal(size=(n, 3, 3)))
    q *= np.sign(np.diagonal(r, axis1=1, axis2=2))[:, None, :]
    q[np.linalg.det(q) < 0, :, 0] *= -1.0
    return q


def test_matrix_to_quat_inverts_the_quaternion_matrix():
    """Every branch of Shepperd's method (trace largest, and each diagonal
    entry largest: half turns about x, y, z): R(q(R)) = R to round-off,
    w ≥ 0, |q| = 1; one matrix gives one quaternion."""
    R = np.concatenate([_random_rotations(20000), np.eye(3)[None],
                        np.diag([1.0, -1, -1])[None], np.diag([-1.0, 1, -1])[None],
                        np.diag([-1.0, -1, 1])[None]])
    q = matrix_to_quat(R)
    assert q.shape == (len(R), 4)
    np.testing.assert_allclose(quat_matrix_np(q), R, atol=1e-14)
    assert np.all(q[:, 0] >= 0.0)
    np.testing.assert_allclose(np.linalg.norm(q, axis=1), 1.0, atol=1e-15)
    np.testing.assert_array_equal(matrix_to_quat(R[7]), q[7])


def test_spring_frames_are_right_handed_with_the_normal_first():
    rng = np.random.default_rng(2)
    n = rng.normal(size=(20000, 3))
    n = np.vstack([n / np.linalg.norm(n, axis=1)[:, None], np.eye(3), -np.eye(3)])
    q = np.empty((len(n), 4))
    frames_from_normals(n, q)
    R = quat_matrix_np(q)
    np.testing.assert_allclose(R[:, :, 0], n, atol=1e-15)
    np.testing.assert_allclose(np.einsum("sji,sjk->sik", R, R), np.broadcast_to(np.eye(3), R.shape),
                               atol=1e-14)
    np.testing.assert_allclose(np.linalg.det(R), 1.0, atol=1e-14)
    # the same frames (s from n × x, or n × y where |n_x| ≥ 0.9) as the matrix route
    e = np.where(np.abs(n[:, [0]]) < 0.9, [[1.0, 0, 0]], [[0, 1.0, 0]])
    s = np.cross(n, e)
    s /= np.linalg.norm(s, axis=1)[:, None]
    np.testing.assert_allclose(q, matrix_to_quat(np.stack([n, s, np.cross(n, s)], axis=2)),
                               atol=1e-15)
