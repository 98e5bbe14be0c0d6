"""The MPEG-4 face frame and how it sits in a mesh's coordinates.

MPEG-4 measures a face in its own frame: x toward the face's own left, y up, z forward (out of the
face). A frame is given as a (3, 3) matrix whose rows are those three unit axes in mesh coordinates,
so `axes @ v_mesh` is v in the face frame and `v_face @ axes` is back in the mesh.
"""

import numpy as np

# A Blender character: Z up, facing -Y, its left side on +X.
BLENDER_FACE_AXES = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, -1.0, 0.0]])
