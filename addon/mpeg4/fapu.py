"""Facial Animation Parameter Units from the neutral face's feature points.

Each FAPU0 is a distance on the neutral face; one FAP unit is FAPU0 / 1024 (AU is fixed at 1e-5 rad).
Distances are measured along one axis of the face frame (x toward the face's left, y up), as the
standard defines them (e.g. ES0 = 3.5.x - 3.6.x), not as 3D Euclidean distances.
IRISD0 is the mean over the eyes that have both eyelid points; ENS0 is measured from the pupils'
mean height.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from ..errors import Mpeg4Error
from ..geometry.face_axes import BLENDER_FACE_AXES

AU = 1e-5  # radians per angular FAP unit


class FapuError(Mpeg4Error):
    """A FAPU cannot be computed from the given feature points."""


@dataclass(frozen=True)
class Fapu:
    IRISD0: float
    ES0: float
    ENS0: float
    MNS0: float
    MW0: float

    def unit(self, name: str) -> float:
        """Size of one FAP unit: FAPU0 / 1024 for distances, AU for angles."""
        if name == "AU":
            return AU
        return getattr(self, f"{name}0") / 1024.0

    def as_dict(self) -> dict[str, float]:
        return {"IRISD0": self.IRISD0, "ES0": self.ES0, "ENS0": self.ENS0, "MNS0": self.MNS0, "MW0": self.MW0}


_DEFINITIONS = {
    # name: (feature points, function of their face-frame positions)
    "ES0": (("3.5", "3.6"), lambda p: p["3.5"][0] - p["3.6"][0]),
    "ENS0": (("3.5", "3.6", "9.15"), lambda p: 0.5 * (p["3.5"][1] + p["3.6"][1]) - p["9.15"][1]),
    "MNS0": (("9.15", "2.2"), lambda p: p["9.15"][1] - p["2.2"][1]),
    "MW0": (("8.3", "8.4"), lambda p: p["8.3"][0] - p["8.4"][0]),
}
_EYELIDS = (("3.1", "3.3"), ("3.2", "3.4"))  # (upper, lower) per eye, for IRISD0


def compute_fapu(positions: Mapping[str, np.ndarray], axes: np.ndarray = BLENDER_FACE_AXES) -> Fapu:
    """FAPU from neutral FP positions (FP id -> (3,) in mesh coordinates; NaN counts as missing).

    `axes` holds the face frame's x (toward the face's left), y (up) and z (forward) as rows in mesh
    coordinates. Raises FapuError naming every FAPU that cannot be computed and the FPs it lacks.
    """
    axes = np.asarray(axes, dtype=np.float64)
    face = {}
    for fp_id, p in positions.items():
        p = np.asarray(p, dtype=np.float64)
        if p.shape == (3,) and np.all(np.isfinite(p)):
            face[fp_id] = axes @ p

    values, problems = {}, []
    irises = [face[top][1] - face[bottom][1] for top, bottom in _EYELIDS if top in face and bottom in face]
    if irises:
        values["IRISD0"] = float(np.mean(irises))
    else:
        absent = [fp_id for pair in _EYELIDS for fp_id in pair if fp_id not in face]
        problems.append(f"IRISD0 needs 3.1 and 3.3 (or 3.2 and 3.4); missing {', '.join(absent)}")
    for name, (ids, measure) in _DEFINITIONS.items():
        absent = [fp_id for fp_id in ids if fp_id not in face]
        if absent:
            problems.append(f"{name} needs {', '.join(ids)}; missing {', '.join(absent)}")
        else:
            values[name] = float(measure(face))
    if problems:
        raise FapuError("cannot compute FAPU: " + "; ".join(problems))
    bad = [f"{name} = {value:.6g}" for name, value in values.items() if not value > 0.0]
    if bad:
        raise FapuError(
            "FAPU must be positive on a neutral face (check the face's left/up axes and the FP placement): "
            + ", ".join(bad)
        )
    return Fapu(**values)


# each FAPU0 of a face modelled in any unit people use (an adult's ES0: 0.06 m, 6 cm, 60 mm; a doll's iris in
# metres, a giant's mouth in millimetres)
PLAUSIBLE_ANY_UNIT = (1e-5, 1e5)
PLAUSIBLE_FACTOR = 10.0  # FAPU from elsewhere against the face's own: another head, not another unit


def check_plausible(fapu: Fapu, source: str, like: Fapu | None = None) -> None:
    """Refuse FAPU that no face has in any unit (PLAUSIBLE_ANY_UNIT), or, with `like` (the face's own FAPU, in
    its units), FAPU more than PLAUSIBLE_FACTOR times larger or smaller than those: FapuError naming each."""
    bad = []
    for name, value in fapu.as_dict().items():
        low, high = PLAUSIBLE_ANY_UNIT
        if like is not None:
            own = like.as_dict()[name]
            low, high = own / PLAUSIBLE_FACTOR, own * PLAUSIBLE_FACTOR
        if not low <= value <= high:
            bad.append(f"{name} = {value:.4g} (plausible {low:.4g}..{high:.4g})")
    if bad:
        unit = "any unit" if like is None else f"the face's units, within {PLAUSIBLE_FACTOR:g}x of its own FAPU"
        raise FapuError(f"{source}: implausible FAPU ({unit}): {', '.join(bad)}")
