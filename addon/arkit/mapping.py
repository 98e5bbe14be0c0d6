"""ARKit weights <-> FAP values through the recipe table (no bpy).

Forward (a capture drives an MPEG-4 face): weights (F, 52) @ targets (52, 68) -> FAP values, the way a
blendshape rig adds its targets. Head and eye turns, where a capture has them, go straight to FAPs 48-50
and 23-26 and replace what the eyeLook* weights say of the eyes (both measure the same gaze).

Backward (an MPEG-4 stream drives an ARKit avatar): per frame the weights in [0, 1] whose FAPs move the
face's feature points closest to where the stream moves them, by bounded least squares
(scipy.optimize.lsq_linear) in feature-point motion: each FAP counts by how far it moves the points on this
face (decode.translation_basis, FAPU-scaled; eyeball turns by the arc of the pupil), not by its raw number.
FAPs no recipe uses (the head's) do not enter the fit; the head is carried over as it is.
"""

from __future__ import annotations

import numpy as np

from ..mpeg4.decode import EYEBALL_RADIUS_PER_ES0, fap_scale, fap_to_fp, translation_basis
from ..mpeg4.fap_file import FapStream
from ..mpeg4.faps import N_FAPS
from ..mpeg4.fapu import AU, Fapu
from . import ArkitError
from .recipes import N_SHAPES, RecipeTable, load_recipes

HEAD_FAPS = (48, 49, 50)  # pitch, yaw, roll
EYE_FAPS = (23, 24, 25, 26)  # yaw left, yaw right, pitch left, pitch right


def weights_to_faps(weights: np.ndarray, table: RecipeTable | None = None) -> np.ndarray:
    """(F, 52) weights -> (F, 68) FAP values (FAPU; AU for angles)."""
    table = table or load_recipes()
    weights = np.asarray(weights, dtype=np.float64).reshape(-1, N_SHAPES)
    return weights @ table.targets


def capture_faps(capture, table: RecipeTable | None = None) -> tuple[np.ndarray, np.ndarray]:
    """A capture's (F, 68) FAP values and (68,) mask of the FAPs it sets: the recipes' FAPs, and the head's and
    eyes' own turns where the capture has them (radians -> AU)."""
    table = table or load_recipes()
    values = weights_to_faps(capture.weights, table)
    mask = np.any(table.targets != 0.0, axis=0)
    if capture.head is not None:
        values[:, [n - 1 for n in HEAD_FAPS]] = capture.head / AU
        mask[[n - 1 for n in HEAD_FAPS]] = True
    if capture.eyes is not None:
        values[:, [n - 1 for n in EYE_FAPS]] = capture.eyes / AU
        mask[[n - 1 for n in EYE_FAPS]] = True
    return values, mask


def capture_to_stream(capture, table: RecipeTable | None = None) -> FapStream:
    """A capture as a FAP stream (integral FAP values, every frame carrying the FAPs it sets), ready for the
    playback path and for writing as .fap."""
    values, mask = capture_faps(capture, table)
    n_frames = len(values)
    masks = np.broadcast_to(mask, (n_frames, N_FAPS)).copy()
    return FapStream(
        version="2.1",
        name=capture.name,
        fps=capture.fps,
        frame_numbers=np.asarray(capture.frame_numbers, dtype=np.int64),
        mask=masks,
        values=np.where(masks, np.round(values), 0.0),
        viseme=np.zeros((n_frames, 4)),
        expression=np.zeros((n_frames, 6)),
    )


def motion_metric(fapu: Fapu) -> np.ndarray:
    """(68, D) how far one unit of each FAP moves the feature points on a face with `fapu` (model units): the
    translation basis, then one column per eyeball angle FAP (the pupil's arc about a default eyeball)."""
    basis = translation_basis(fapu).reshape(N_FAPS, -1)
    radius = EYEBALL_RADIUS_PER_ES0 * fapu.ES0
    eyes = np.zeros((N_FAPS, len(EYE_FAPS)))
    for column, number in enumerate(EYE_FAPS):
        eyes[number - 1, column] = fap_scale(fapu)[number - 1] * radius
    return np.hstack([basis, eyes])


def faps_to_weights(values: np.ndarray, fapu: Fapu, table: RecipeTable | None = None) -> np.ndarray:
    """(F, 68) FAP values -> (F, 52) ARKit weights in [0, 1]: per frame, the bounded least-squares fit of the
    feature points' motion (see the module's docstring)."""
    try:  # imported here: Blender ships numpy, not scipy, and the rest of the bridge must load without it
        from scipy.optimize import lsq_linear
    except ImportError as error:
        raise ArkitError(
            f"FAP -> ARKit weights need scipy, which Blender does not ship and which is not installed ({error}); "
            "install the MPEG-4 Face extension from its zip, which brings scipy's wheel for Windows x64, macOS and "
            "Linux x64, or install scipy into Blender's Python"
        ) from None
    table = table or load_recipes()
    values = np.asarray(values, dtype=np.float64).reshape(-1, N_FAPS)
    metric = motion_metric(fapu)
    design = table.targets @ metric  # (52, D): each shape's motion
    used = np.any(design != 0.0, axis=0)
    design = design[:, used]
    target = (values @ metric)[:, used]  # (F, D')
    # one QR turns each frame's (D' x 52) problem into a 52 x 52 one with the same solution
    q, r = np.linalg.qr(design.T)
    projected = target @ q  # (F, 52)
    weights = np.empty((len(values), N_SHAPES))
    # bvls stops when the cost changes by less than tol (relative); scipy's 1e-10 left up to 1.3 um of feature-point
    # motion unfitted where recipes overlap (the lower lip's rise in mouthPress, mouthClose and the smiles)
    for frame, b in enumerate(projected):
        weights[frame] = lsq_linear(r, b, bounds=(0.0, 1.0), method="bvls", tol=1e-13).x if np.any(b) else 0.0
    return np.clip(weights, 0.0, 1.0)


def round_trip(values: np.ndarray, fapu: Fapu, table: RecipeTable | None = None) -> tuple[np.ndarray, np.ndarray]:
    """FAP values -> ARKit weights -> FAP values: (weights (F, 52), FAP values (F, 68)); the head FAPs are
    carried over unchanged (ARKit's weights have no head)."""
    table = table or load_recipes()
    values = np.asarray(values, dtype=np.float64).reshape(-1, N_FAPS)
    weights = faps_to_weights(values, fapu, table)
    back = weights_to_faps(weights, table)
    head = [n - 1 for n in HEAD_FAPS]
    back[:, head] = values[:, head]
    return weights, back


def fp_distances(neutral: np.ndarray, a: np.ndarray, b: np.ndarray, fapu: Fapu, **decode_options) -> np.ndarray:
    """(F, 84) distance between the feature points two FAP streams put on one face (NaN where an FP is
    missing), decoded as played (decode.fap_to_fp)."""
    pa = fap_to_fp(neutral, a, fapu, **decode_options)
    pb = fap_to_fp(neutral, b, fapu, **decode_options)
    return np.linalg.norm(pa - pb, axis=2)
