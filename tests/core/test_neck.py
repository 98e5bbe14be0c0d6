"""Head-turn weights of a head on a body (`neck.head_turn_weights`) and the turn taken back (`neck.turn_back`), no
scene."""

import numpy as np

from addon.deform.neck import head_turn_weights, turn_back

AXES = np.eye(3)[[0, 2, 1]]  # x left, y up = mesh z, z forward = mesh y (a Z-up mesh)


def test_arms_at_the_necks_height_stay_and_the_head_turns_whole():
    """A head (within 2 chin heights of the vertical through 7.1), a neck below it and T-pose arms at 1.75 chin
    heights below 7.1 reaching 11 chin heights out (the Rocketbox male): the head weighs 1, the neck in between,
    the arms 0 from 4 chin heights out (a share of the turn swung them 24 cm and turned 519 faces over)."""
    spine, chin = np.array([0.0, 0.0, 0.0]), np.array([0.0, 0.05, -0.08])  # the chin 8 cm below 7.1
    drop = 0.08
    head = np.array([[x, 0.0, z] for x in np.linspace(-2 * drop, 2 * drop, 9) for z in np.linspace(-drop, 0.1, 5)])
    neck = np.array([[0.0, 0.0, -1.75 * drop], [drop, 0.0, -1.75 * drop]])
    arms = np.array([[x, 0.0, -1.75 * drop] for x in np.linspace(4 * drop, 11 * drop, 8)])
    body = np.array([[0.0, 0.0, -3 * drop]])
    weights = head_turn_weights(np.concatenate([head, neck, arms, body]), AXES, spine, chin)
    assert np.array_equal(weights[: len(head)], np.ones(len(head)))
    assert np.allclose(weights[len(head) : len(head) + 2], 0.5) and weights[-1] == 0.0
    assert np.array_equal(weights[len(head) + 2 : -1], np.zeros(len(arms)))


def test_the_body_takes_the_turn_back_by_its_share_of_the_angle_about_the_pivot():
    """A head turned 40 degrees about the vertical through a pivot: a vertex of share 1 goes back exactly to where
    it stood before the turn (the turn's transpose), share 0 stays, share 0.5 is turned back by 20 degrees about the
    pivot (hand-worked: (1, 0, 0) from the pivot turned by 40 then back by 20 lies at 20 degrees), and a share of 1
    beside a partial one comes out as Rodrigues' formula gives it (to rounding)."""
    angle = np.radians(40.0)
    c, s = np.cos(angle), np.sin(angle)
    turn = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])  # about z, the vertical here
    pivot = np.array([0.5, -0.25, 1.0])
    before = np.array([[1.0, 0.0, 0.0], [0.0, 2.0, 0.5], [1.0, 0.0, 0.0], [0.3, -0.7, 0.2]]) + pivot
    out = np.concatenate([(before - pivot) @ turn.T + pivot, [[9.0, 9.0, 9.0]]])  # the object's turn; one not listed
    share = np.array([1.0, 1.0, 0.5, 0.0])
    turned = out.copy()
    turn_back(turned, np.arange(4), share, turn, pivot)
    np.testing.assert_allclose(turned[:2], before[:2], rtol=0.0, atol=1e-15)  # the whole turn back
    half = np.radians(20.0)
    np.testing.assert_allclose(turned[2], pivot + [np.cos(half), np.sin(half), 0.0], rtol=0.0, atol=1e-15)
    np.testing.assert_array_equal(turned[3], out[3])  # share 0: the head's own vertex stays turned
    np.testing.assert_array_equal(turned[4], out[4])  # not listed: untouched
    one = out.copy()  # share 1 by Rodrigues (the share-1 vertex given a share just off 1 takes that path)
    turn_back(one, np.arange(2), np.array([np.nextafter(1.0, 0.0), 1.0]), turn, pivot)
    np.testing.assert_allclose(one[0], turned[0], rtol=0.0, atol=1e-15)
