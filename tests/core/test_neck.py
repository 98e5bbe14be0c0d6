"""Head-turn weights of a head on a body (`neck.head_turn_weights`), no scene."""

import numpy as np

from addon.deform.neck import head_turn_weights

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
