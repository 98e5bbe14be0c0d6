"""The add-on's own FDP file: a person's feature points (and optionally texture and FAPU) as JSON.

    {
      "format": "mpeg4-face-fdp",
      "version": 1,
      "feature_points": {"2.1": [0.0, -0.071, 0.043], "9.3": [0.0, -0.012, 0.089], ...},
      "texture_coordinates": {"9.3": [0.5, 0.41], ...},
      "image": "face.png",
      "fapu": {"IRISD0": 0.0093, "ES0": 0.0616, "ENS0": 0.0426, "MNS0": 0.0235, "MW0": 0.0503}
    }

- `feature_points` (required, at least one): FP id -> [x, y, z] in metres in the MPEG-4 face frame
  (x toward the face's own left, y up, z forward, out of the face); `Fdp.in_mesh(axes)` puts them in a
  mesh's coordinates.
- `texture_coordinates` (optional): FP id -> [u, v] in [0, 1] (u to the right of the picture, v up),
  only for FPs listed in `feature_points`.
- `image` (optional): the picture those UVs refer to, a path relative to the file's folder or absolute.
- `fapu` (optional): the five FAPU0 distances in metres (not divided by 1024), all positive.

Nothing else is allowed. The reader refuses, naming the file and the item: files over MAX_BYTES,
invalid UTF-8 or JSON (`user_json`: over-long numbers, deep nesting, NaN, repeated keys), unknown
keys or FP ids, wrong shapes, booleans or strings where numbers belong, coordinates beyond MAX_COORDINATE,
FAPU no face has (`fapu.check_plausible`), UVs outside the image. The writer checks the same and replaces the
file only when the whole text is written; write then read gives the same values bit for bit.
"""

from __future__ import annotations

import json
import math
import os
import tempfile
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..errors import Mpeg4Error
from ..mpeg4.fapu import Fapu, FapuError, check_plausible
from ..mpeg4.feature_points import FP_IDS, fp_index
from ..user_files import read_regular_file
from ..user_json import parse_json

FORMAT = "mpeg4-face-fdp"
VERSION = 1
MAX_BYTES = 1 << 20
MAX_IMAGE_PATH = 4096
MAX_COORDINATE = 1e4  # beyond any face's feature points about its origin, in any unit (float32 holds them)
FAPU_NAMES = ("IRISD0", "ES0", "ENS0", "MNS0", "MW0")
_KEYS = {"format", "version", "feature_points", "texture_coordinates", "image", "fapu"}


class FdpFileError(Mpeg4Error):
    """An FDP file that cannot be read or written; the message names the file and the item."""


@dataclass(frozen=True)
class Fdp:
    feature_points: dict[str, np.ndarray]  # FP id -> (3,) metres, MPEG-4 face frame
    texture_coordinates: dict[str, np.ndarray] = field(default_factory=dict)  # FP id -> (2,) in [0, 1]
    image: str | None = None
    fapu: Fapu | None = None

    def in_mesh(self, axes: np.ndarray) -> dict[str, np.ndarray]:
        """The feature points in the coordinates of a mesh whose face frame is `axes` (rows: left, up, forward)."""
        axes = np.asarray(axes, dtype=np.float64)
        return {fp_id: point @ axes for fp_id, point in self.feature_points.items()}


def read_fdp(path: str | os.PathLike) -> Fdp:
    too_large = f"larger than {MAX_BYTES} bytes; not an FDP file"
    name = str(Path(path))
    return parse_fdp(read_regular_file(path, MAX_BYTES, FdpFileError, name, too_large), name)


def parse_fdp(data: bytes, source: str = "FDP") -> Fdp:
    """The FDP in `data` (the bytes of a file); `source` names it in errors."""
    if len(data) > MAX_BYTES:
        raise FdpFileError(f"{source}: larger than {MAX_BYTES} bytes; not an FDP file")
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError as error:
        raise FdpFileError(f"{source}: not UTF-8 text (byte {error.start})") from None
    document = parse_json(text, FdpFileError, source)
    return _document_to_fdp(document, source)


def write_fdp(path: str | os.PathLike, fdp: Fdp) -> None:
    """Write `fdp` (checked first) to `path`, replacing it only once the new file is complete."""
    path = Path(path)
    text = fdp_text(fdp, str(path))
    folder = path.parent if str(path.parent) else Path(".")
    try:
        handle, temporary = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".partial", dir=folder)
    except OSError as error:
        raise FdpFileError(f"{path}: cannot write: {error.strerror or error}") from None
    try:
        with os.fdopen(handle, "w", encoding="utf-8", newline="\n") as stream:
            stream.write(text)
        os.replace(temporary, path)
    except OSError as error:
        Path(temporary).unlink(missing_ok=True)
        raise FdpFileError(f"{path}: cannot write: {error.strerror or error}") from None


def fdp_text(fdp: Fdp, source: str = "FDP") -> str:
    """The JSON text of `fdp`, after the same checks the reader makes."""
    document: dict[str, object] = {
        "format": FORMAT,
        "version": VERSION,
        "feature_points": _as_lists(fdp.feature_points, source, "feature_points"),
    }
    if fdp.texture_coordinates:
        document["texture_coordinates"] = _as_lists(fdp.texture_coordinates, source, "texture_coordinates")
    if fdp.image is not None:
        document["image"] = fdp.image
    if fdp.fapu is not None:
        document["fapu"] = {name: float(value) for name, value in fdp.fapu.as_dict().items()}
    _document_to_fdp(document, source)
    return json.dumps(document, indent=2, allow_nan=False) + "\n"


def _as_lists(points: Mapping[str, object], source: str, what: str) -> dict[object, object]:
    if not isinstance(points, Mapping):
        raise FdpFileError(f"{source}: {what} must map FP ids to coordinates")
    out: dict[object, object] = {}
    for fp_id in sorted(points, key=lambda f: fp_index(f) if f in FP_IDS else -1):
        try:
            out[fp_id] = np.asarray(points[fp_id], dtype=np.float64).tolist()
        except (TypeError, ValueError):
            raise FdpFileError(f"{source}: {what} {fp_id}: not a list of numbers") from None
    return out


def _document_to_fdp(document: object, source: str) -> Fdp:
    if not isinstance(document, dict):
        raise FdpFileError(f"{source}: the file must hold one JSON object")
    unknown = sorted(set(document) - _KEYS)
    if unknown:
        raise FdpFileError(f"{source}: unknown key(s) {', '.join(map(repr, unknown))}")
    if document.get("format") != FORMAT:
        raise FdpFileError(f"{source}: 'format' must be {FORMAT!r}, got {document.get('format')!r}")
    version = document.get("version")
    if type(version) is not int or version != VERSION:
        raise FdpFileError(f"{source}: FDP version {version!r}; this add-on reads version {VERSION}")
    if "feature_points" not in document:
        raise FdpFileError(f"{source}: no 'feature_points'; an FDP always gives feature points")
    points = _point_table(document["feature_points"], 3, source, "feature_points")
    if not points:
        raise FdpFileError(f"{source}: 'feature_points' is empty; an FDP always gives feature points")
    uvs = _point_table(document.get("texture_coordinates", {}), 2, source, "texture_coordinates")
    orphans = [fp_id for fp_id in uvs if fp_id not in points]
    if orphans:
        raise FdpFileError(f"{source}: texture_coordinates for FPs without a position: {', '.join(orphans)}")
    outside = [fp_id for fp_id, uv in uvs.items() if not np.all((uv >= 0.0) & (uv <= 1.0))]
    if outside:
        raise FdpFileError(
            f"{source}: texture_coordinates outside the image [0, 1]: "
            + ", ".join(f"{fp_id} {uvs[fp_id].tolist()}" for fp_id in outside)
        )
    image = document.get("image")
    if image is not None and (
        not isinstance(image, str) or not image or len(image) > MAX_IMAGE_PATH or any(ord(ch) < 32 for ch in image)
    ):
        raise FdpFileError(f"{source}: 'image' must be a non-empty path without control characters")
    fapu = _fapu(document["fapu"], source) if "fapu" in document else None
    return Fdp(points, uvs, image, fapu)


def _number(value: object) -> bool:
    return type(value) in (int, float) and math.isfinite(value)


def _point_table(table: object, size: int, source: str, what: str) -> dict[str, np.ndarray]:
    if not isinstance(table, dict):
        raise FdpFileError(f"{source}: '{what}' must be an object mapping FP ids to lists of {size} numbers")
    unknown = [fp_id for fp_id in table if fp_id not in FP_IDS]
    if unknown:
        raise FdpFileError(f"{source}: {what}: unknown MPEG-4 feature point(s) {', '.join(map(repr, unknown))}")
    out = {}
    for fp_id in sorted(table, key=fp_index):
        value = table[fp_id]
        if not (isinstance(value, list) and len(value) == size and all(_number(v) for v in value)):
            raise FdpFileError(f"{source}: {what} {fp_id}: expected a list of {size} finite numbers, got {value!r}")
        if size == 3 and max(map(abs, value)) > MAX_COORDINATE:
            raise FdpFileError(
                f"{source}: {what} {fp_id}: {value!r} is more than {MAX_COORDINATE:g} from the face's origin; "
                "an FDP gives a person's feature points in metres"
            )
        out[fp_id] = np.array(value, dtype=np.float64)
    return out


def _fapu(table: object, source: str) -> Fapu:
    if not isinstance(table, dict) or set(table) != set(FAPU_NAMES):
        raise FdpFileError(f"{source}: 'fapu' must give exactly {', '.join(FAPU_NAMES)}")
    bad = [name for name in FAPU_NAMES if not (_number(table[name]) and table[name] > 0)]
    if bad:
        raise FdpFileError(f"{source}: fapu {', '.join(bad)} must be positive numbers (metres)")
    fapu = Fapu(**{name: float(table[name]) for name in FAPU_NAMES})
    try:
        check_plausible(fapu, f"{source}: fapu")
    except FapuError as error:
        raise FdpFileError(str(error)) from None
    return fapu
