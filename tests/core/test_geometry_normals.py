"""Vertex normals: area-weighted, unit length, zero off the mesh."""

import numpy as np

from addon.geometry.normals import vertex_normals


def test_a_fold_of_two_triangles_weighs_each_side_by_its_area():
    # a unit right triangle in z = 0 (normal +z, area 1/2) and one twice as large in x = 0 (normal +x, area 1)
    # share the edge (0,0,0)-(0,1,0); a fifth vertex is in no triangle
    vertices = np.array([[0, 0, 0], [0, 1, 0], [-1, 0, 0], [0, 0, 2], [5, 5, 5]], dtype=float)
    triangles = np.array([[0, 1, 2], [0, 1, 3]])
    normals = vertex_normals(vertices, triangles)
    shared = np.array([2.0, 0.0, 1.0]) / np.sqrt(5.0)  # 2 x area(+x) : 1 x area(+z) as cross products
    np.testing.assert_allclose(normals[0], shared)
    np.testing.assert_allclose(normals[1], shared)
    np.testing.assert_allclose(normals[2], [0, 0, 1])
    np.testing.assert_allclose(normals[3], [1, 0, 0])
    np.testing.assert_array_equal(normals[4], 0.0)
