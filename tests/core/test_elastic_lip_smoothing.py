"""Elastic Bones' last smoothing on the lips' skin (`elastic.skinning.smooth_lips`, step 5), hand-worked."""

import numpy as np

from addon.elastic.skinning import check_weights, smooth_lips

PATH = np.array([[0, 1], [1, 2], [2, 3], [3, 4], [4, 5]])  # six vertices in a row


def test_a_lip_weight_step_is_eased_where_the_lips_act_and_nowhere_else():
    lip = np.array([1.0, 1.0, 1.0, 0.0, 0.0, 0.0])  # a lip bone's weight ending in one step (a mask's edge)
    weights = np.stack([1.0 - lip, lip], axis=1)  # columns: head (the leftover), lip
    out = smooth_lips(weights, PATH, steps=1, lip_rows=[1], sides={}, root=0, reach=np.ones(6))
    # one step v <- (v + mean of the neighbours) / 2 gives the lip column 1, 1, 0.75, 0.25, 0, 0; each row moves
    # toward it by that share: vertex 2 to 1 + 0.75 (0.75 - 1), vertex 3 to 0.25 * 0.25
    np.testing.assert_allclose(out[:, 1], [1.0, 1.0, 0.8125, 0.0625, 0.0, 0.0], atol=1e-15)
    check_weights(out, 6, 2)  # rows still sum to 1
    # the step across edge 2-3 was 1, now 0.75: the slope a displacement multiplies to fold a face
    assert np.abs(np.diff(out[:, 1])).max() == 0.75
    np.testing.assert_array_equal(out[4:], weights[4:])  # beyond the lips' reach nothing changes


def test_skin_the_lip_bones_do_not_reach_keeps_its_weights():
    weights = np.array([[1.0, 0.0, 0.0], [0.5, 0.5, 0.0], [0.0, 1.0, 0.0], [0.2, 0.8, 0.0]])
    out = smooth_lips(
        weights, np.array([[0, 1], [1, 2], [2, 3]]), steps=3, lip_rows=[2], sides={}, root=0, reach=np.ones(4)
    )
    np.testing.assert_array_equal(out, weights)


def test_a_lip_bone_stays_within_its_side_mask_and_the_head_takes_the_rest():
    lip = np.array([1.0, 1.0, 1.0, 0.0, 0.0, 0.0])
    weights = np.stack([1.0 - lip, lip], axis=1)
    side = np.array([1.0, 1.0, 1.0, 0.0, 1.0, 1.0])  # vertex 3 is on the other side of the opening
    out = smooth_lips(weights, PATH, steps=1, lip_rows=[1], sides={1: side}, root=0, reach=np.ones(6))
    # vertex 2 as without the mask; vertex 3's smoothed lip weight 0.25 is taken off (its share is then 0)
    np.testing.assert_allclose(out[:, 1], [1.0, 1.0, 0.8125, 0.0, 0.0, 0.0], atol=1e-15)
    check_weights(out, 6, 2)


def test_on_the_lining_the_move_is_scaled_by_its_reach():
    lip = np.array([1.0, 1.0, 1.0, 0.0, 0.0, 0.0])
    weights = np.stack([1.0 - lip, lip], axis=1)
    out = smooth_lips(weights, PATH, steps=1, lip_rows=[1], sides={}, root=0, reach=np.full(6, 0.5))
    np.testing.assert_allclose(out[:, 1], [1.0, 1.0, 1.0 - 0.5 * 0.75 * 0.25, 0.5 * 0.25 * 0.25, 0.0, 0.0], atol=1e-15)
