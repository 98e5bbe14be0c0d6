"""Pose bone channels from bone transforms relative to rest (addon/elastic/armature_space.py), by hand."""

import numpy as np

from addon.elastic.armature_space import bone_basis, quaternions, rigid_inverse

RZ90 = np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])


def rigid(rotation=None, offset=(0.0, 0.0, 0.0)) -> np.ndarray:
    m = np.eye(4)
    m[:3, :3] = np.eye(3) if rotation is None else rotation
    m[:3, 3] = offset
    return m


# a root at the origin, unrotated; its child's head at x = 1, the child turned 90 degrees about z
REST = np.array([rigid(), rigid(RZ90, (1.0, 0.0, 0.0))])
PARENTS = (-1, 0)


def test_a_child_moving_with_its_parent_has_no_channels_of_its_own():
    up = rigid(offset=(0.0, 0.0, 2.0))
    basis = bone_basis(REST, PARENTS, np.array([up, up]))
    np.testing.assert_allclose(basis[0], up, atol=1e-15)
    np.testing.assert_allclose(basis[1], np.eye(4), atol=1e-15)


def test_a_translation_in_armature_space_is_turned_into_the_bone_frame():
    # +x in the armature is -y along the turned child (its y axis points along -x)
    basis = bone_basis(REST, PARENTS, np.array([np.eye(4), rigid(offset=(1.0, 0.0, 0.0))]))
    np.testing.assert_allclose(basis[1], rigid(offset=(0.0, -1.0, 0.0)), atol=1e-15)


def test_a_turn_about_the_bone_head_is_a_pure_rotation():
    head = np.array([1.0, 0.0, 0.0])
    turn = rigid(RZ90, head - RZ90 @ head)
    basis = bone_basis(REST, PARENTS, np.array([np.eye(4), turn]))
    np.testing.assert_allclose(basis[1], rigid(RZ90), atol=1e-15)
    np.testing.assert_allclose(quaternions(basis[1:, :3, :3]), [[np.sqrt(0.5), 0.0, 0.0, np.sqrt(0.5)]], atol=1e-15)


def test_blender_composition_gives_back_the_transforms():
    # P_b = P_parent M_parent^-1 M_b B_b must equal D_b M_b (skinning applies P_b M_b^-1 = D_b)
    rng = np.random.default_rng(1)
    q, _ = np.linalg.qr(rng.normal(size=(2, 3, 3)))
    q *= np.sign(np.linalg.det(q))[:, None, None]
    transforms = np.array([rigid(q[0], rng.normal(size=3)), rigid(q[1], rng.normal(size=3))])
    basis = bone_basis(REST, PARENTS, transforms)
    posed_root = REST[0] @ basis[0]
    posed_child = posed_root @ np.linalg.inv(REST[0]) @ REST[1] @ basis[1]
    np.testing.assert_allclose(posed_root, transforms[0] @ REST[0], atol=1e-12)
    np.testing.assert_allclose(posed_child, transforms[1] @ REST[1], atol=1e-12)


def test_quaternions_of_known_rotations_and_their_sign():
    half_turn_x = np.diag([1.0, -1.0, -1.0])
    q = quaternions(np.array([np.eye(3), half_turn_x, RZ90]))
    np.testing.assert_allclose(q, [[1, 0, 0, 0], [0, 1, 0, 0], [np.sqrt(0.5), 0, 0, np.sqrt(0.5)]], atol=1e-15)
    # next to a previous key of the other sign, the same rotation keeps that sign
    flipped = quaternions(RZ90[None], previous=np.array([[-0.7, 0.0, 0.0, -0.7]]))
    np.testing.assert_allclose(flipped, [[-np.sqrt(0.5), 0, 0, -np.sqrt(0.5)]], atol=1e-15)


def test_rigid_inverse_undoes_a_turn_and_a_shift():
    m = rigid(RZ90, (1.0, 2.0, 3.0))
    # x -> Rz x + t, so the inverse takes y to Rz^T (y - t): rotation [[0,1,0],[-1,0,0],[0,0,1]], shift (-2, 1, -3)
    np.testing.assert_allclose(rigid_inverse(m), rigid(RZ90.T, (-2.0, 1.0, -3.0)), atol=1e-15)
    np.testing.assert_allclose(rigid_inverse(m) @ m, np.eye(4), atol=1e-15)
