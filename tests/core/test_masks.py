"""Mask images sampled at vertex UVs, as in the paper's Figure 9."""

import numpy as np
import pytest

from addon.deform.inputs import DeformError
from addon.deform.masks import image_masks, sample_image, vertex_uvs


def test_bilinear_samples_at_pixel_centres_and_between():
    pixels = np.zeros((2, 2, 1))
    pixels[0, 0, 0], pixels[0, 1, 0], pixels[1, 0, 0], pixels[1, 1, 0] = 0.0, 1.0, 2.0, 3.0  # row 0 = bottom
    uv = np.array([[0.25, 0.25], [0.75, 0.25], [0.25, 0.75], [0.5, 0.5], [0.0, 0.0], [2.0, 2.0]])
    np.testing.assert_allclose(sample_image(pixels, uv)[:, 0], [0.0, 1.0, 2.0, 1.5, 0.0, 3.0])


def test_vertex_uvs_average_face_corners():
    loop_vertex = np.array([0, 1, 2, 2, 1, 3])
    loop_uv = np.array([[0, 0], [1, 0], [0, 1], [0.2, 0.8], [0.6, 0.0], [1, 1]])
    np.testing.assert_allclose(vertex_uvs(loop_vertex, loop_uv, 5), [[0, 0], [0.8, 0], [0.1, 0.9], [1, 1], [0, 0]])


def test_channels_become_named_masks():
    pixels = np.zeros((4, 4, 4))
    pixels[:2, :, 0] = 1.0  # red: bottom half
    pixels[2:, :, 1] = 1.0  # green: top half
    masks = image_masks(pixels, np.array([[0.5, 0.1], [0.5, 0.9]]), ("upper_lip", "lower_lip"))
    np.testing.assert_allclose(masks["upper_lip"], [1.0, 0.0])
    np.testing.assert_allclose(masks["lower_lip"], [0.0, 1.0])
    with pytest.raises(DeformError, match="channels"):
        image_masks(pixels[..., :1], np.zeros((1, 2)), ("a", "b"))
    with pytest.raises(DeformError, match="finite"):
        sample_image(pixels, np.array([[np.nan, 0.0]]))
