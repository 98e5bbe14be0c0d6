"""The chin's landmarks on a mid-plane profile (`scripts.bench.placement_readings`): the labiomental sulcus is the
profile's deepest notch seen from in front, the chin's front its most forward point below it, the throat the
point furthest inside the chord from the chin's front to the profile's end; a hand-made profile."""

import numpy as np

from scripts.bench.placement_readings import _outside, sulcus_and_throat

AXES = np.eye(3)  # left x, up y, forward z


def _profile(points):
    return np.array([[0.0, y, z] for y, z in points])


def test_sulcus_chin_and_throat_on_a_hand_made_profile():
    # down from the lower lip (y 20, z 5) into the sulcus (10, 0), out to the chin's front (0, 3), under the chin
    # back to the throat (-12, -40), then down the neck
    chain = _profile(
        [(20, 5), (15, 3), (10, 0), (5, 2), (0, 3), (-6, 0), (-10, -10), (-12, -40), (-30, -43), (-50, -45)]
    )
    assert sulcus_and_throat(chain, AXES) == (2, 4, 7)


def test_outside_a_chord_is_towards_the_front():
    chain = _profile([(0, 0), (1, 2), (2, -1), (3, 0)])
    distance = _outside(chain, chain[0], chain[-1], AXES)
    assert np.allclose(distance, [0.0, 2.0, -1.0, 0.0])
