"""Reader for XFace's `.fdp` XML (file version 0.2), for what it carries.

An XFace FDP describes an XFace head, not a person's measurements: it lists the head's FAPU (FAPU0 in
model units, not divided by 1024), a global translation and axis-angle rotation, the meshes (the
`Rest` entity and morph targets) with bindings of sub-meshes to items (eyes with their rotation pivots,
teeth, tongue, hair), and per FP and sub-mesh the control vertex, the vertices it influences and its
FAP influences. It carries no FP coordinates: those are the control vertices of meshes it names but
does not contain. Facts from research/mpeg4-fba.md §7.3 (XFace's FDPLoader): the `fap` attribute of an
influence is 0-based (FAP number - 1), vertex indices are unsigned 16-bit, the rotation is an axis and
an angle in radians (XFace keeps it as an axis-angle it converts to and from quaternions).

Safety: the file is at most MAX_BYTES, a DOCTYPE or ENTITY declaration is refused before parsing (no
entity expansion, no external references), and every count comes from the text actually present, never
from a number in the file (`<model fdpcount>` is reported, not used). Every problem raises one
`XfaceFdpError` naming the file and the element.
"""

from __future__ import annotations

import math
import os
import re
import xml.etree.ElementTree as ET
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..errors import Mpeg4Error
from ..mpeg4.fapu import Fapu, FapuError, check_plausible
from ..mpeg4.feature_points import FP_IDS
from ..user_files import read_regular_file

MAX_BYTES = 16 << 20
VERSION = "0.2"
MAX_VERTEX_INDEX = 65535  # XFace stores vertex indices as unsigned short
N_FAPS = 68
INFLUENCE_TYPES = frozenset(
    {"RaisedCosInfluenceSph", "RaisedCosInfluenceWaveX", "RaisedCosInfluenceWaveY", "RaisedCosInfluenceWaveZ"}
)
_DECLARATION = re.compile(rb"<!\s*(DOCTYPE|ENTITY)", re.IGNORECASE)
# the XML declaration's encoding; expat reads these (and UTF-16 by its byte order mark) and nothing else
_ENCODING = re.compile(rb"""^(?:\xef\xbb\xbf)?<\?xml[^>]*?\bencoding\s*=\s*["']([^"']*)["']""")
ENCODINGS = frozenset({"utf-8", "utf8", "us-ascii", "ascii", "iso-8859-1", "latin-1", "latin1"})


class XfaceFdpError(Mpeg4Error):
    """An XFace .fdp file that cannot be read; the message names the file and the element."""


@dataclass(frozen=True)
class XfaceEntity:
    alias: str  # "Rest" is the neutral face; the others are morph targets
    category: str  # Expression, Viseme or Modifier
    meshes: tuple[tuple[str, str], ...]  # (file, format)


@dataclass(frozen=True)
class XfaceBind:
    entity: str  # alias of the entity it is listed under
    item: str  # Hair, LeftEye, RightEye, LowerTeeth, UpperTeeth, Tongue
    submesh: str
    pivot: np.ndarray | None  # (3,) model units, for the eyes


@dataclass(frozen=True)
class XfaceInfluence:
    fap: int  # FAP number, 1-based (the file's 0-based value + 1)
    kind: str  # one of INFLUENCE_TYPES
    weight: float  # negative reverses the direction


@dataclass(frozen=True)
class XfaceFeaturePoint:
    fp_id: str
    mesh: str  # the sub-mesh it affects
    control_vertex: int
    zone: np.ndarray  # (k,) int32 the vertices it influences
    influences: tuple[XfaceInfluence, ...]


@dataclass(frozen=True)
class XfaceFdp:
    version: str
    model_fdp_count: int | None  # as written in <model fdpcount>; not checked against anything
    fapu: Fapu | None  # FAPU0 in model units
    translation: np.ndarray  # (3,)
    rotation_axis: np.ndarray  # (3,)
    rotation_angle: float  # radians
    entities: tuple[XfaceEntity, ...]
    binds: tuple[XfaceBind, ...]
    feature_points: tuple[XfaceFeaturePoint, ...]

    @property
    def fp_ids(self) -> tuple[str, ...]:
        """The FPs it lists (once each, in file order)."""
        return tuple(dict.fromkeys(point.fp_id for point in self.feature_points))

    def pivots(self) -> dict[str, np.ndarray]:
        """Item -> pivot of the binds that have one (the eyes)."""
        return {bind.item: bind.pivot for bind in self.binds if bind.pivot is not None}

    def rotation_matrix(self) -> np.ndarray:
        """(3, 3) the global rotation (identity when the angle is 0)."""
        if self.rotation_angle == 0.0:
            return np.eye(3)
        x, y, z = self.rotation_axis / np.linalg.norm(self.rotation_axis)
        k = np.array([[0.0, -z, y], [z, 0.0, -x], [-y, x, 0.0]])
        return np.eye(3) + math.sin(self.rotation_angle) * k + (1.0 - math.cos(self.rotation_angle)) * (k @ k)


def read_xface_fdp(path: str | os.PathLike) -> XfaceFdp:
    too_large = f"larger than {MAX_BYTES} bytes; not an XFace FDP"
    name = str(Path(path))
    return parse_xface_fdp(read_regular_file(path, MAX_BYTES, XfaceFdpError, name, too_large), name)


def parse_xface_fdp(data: bytes, source: str = "XFace FDP") -> XfaceFdp:
    """The XFace FDP in `data` (a file's bytes); `source` names it in errors."""
    if len(data) > MAX_BYTES:
        raise XfaceFdpError(f"{source}: larger than {MAX_BYTES} bytes; not an XFace FDP")
    if _DECLARATION.search(data):
        raise XfaceFdpError(f"{source}: DOCTYPE and ENTITY declarations are not accepted")
    declared = _ENCODING.match(data)
    if declared and declared[1].decode("ascii", "replace").lower() not in ENCODINGS:
        name = declared[1][:40].decode("ascii", "replace")
        raise XfaceFdpError(f"{source}: the XML declares the encoding {name!r}; an XFace FDP is UTF-8")
    try:
        root = ET.fromstring(data)
    except ET.ParseError as error:
        line, column = error.position
        raise XfaceFdpError(f"{source}: not well-formed XML at line {line}, column {column + 1}") from None
    if root.tag != "xfdp":
        raise XfaceFdpError(f"{source}: root element <{root.tag}>, expected <xfdp>")
    head = _only(root, "head", source)
    source_element = _only(root, "source", source)
    version = _attribute(_only(head, "file", source), "version", source)
    if version != VERSION:
        raise XfaceFdpError(f"{source}: <file version={version!r}>; XFace FDP version {VERSION} is read")
    model = head.find("model")
    count = None if model is None else _integer(model, "fdpcount", 0, 1 << 31, source)
    fapu_element = head.find("fapu")
    fapu = None
    if fapu_element is not None:
        values = {name: _real(fapu_element, name, source) for name in ("IRISD0", "ES0", "ENS0", "MNS0", "MW0")}
        if not all(value > 0.0 for value in values.values()):
            raise XfaceFdpError(f"{source}: <fapu> values must be positive, got {values}")
        fapu = Fapu(**values)
        try:
            check_plausible(fapu, f"{source}: <fapu>")
        except FapuError as error:
            raise XfaceFdpError(str(error)) from None
    translation = np.zeros(3)
    if (element := head.find("translation")) is not None:
        translation = np.array([_real(element, name, source) for name in "xyz"])
    axis, angle = np.zeros(3), 0.0
    if (element := head.find("rotation")) is not None:
        axis = np.array([_real(element, f"axis_{name}", source) for name in "xyz"])
        angle = _real(element, "axis_angle", source)
        if angle != 0.0 and not np.any(axis):
            raise XfaceFdpError(f"{source}: <rotation> turns by {angle} about a zero axis")
    entities, binds = _entities(source_element, source)
    return XfaceFdp(
        version=version,
        model_fdp_count=count,
        fapu=fapu,
        translation=translation,
        rotation_axis=axis,
        rotation_angle=angle,
        entities=entities,
        binds=binds,
        feature_points=_feature_points(root, source),
    )


def _only(parent: ET.Element, tag: str, source: str) -> ET.Element:
    found = parent.findall(tag)
    if len(found) != 1:
        raise XfaceFdpError(f"{source}: <{parent.tag}> must hold exactly one <{tag}>, found {len(found)}")
    return found[0]


def _attribute(element: ET.Element, name: str, source: str) -> str:
    value = element.get(name)
    if value is None or not value.strip():
        raise XfaceFdpError(f"{source}: <{element.tag}> lacks the attribute {name!r}")
    return value.strip()


def _real(element: ET.Element, name: str, source: str) -> float:
    text = _attribute(element, name, source)
    try:
        value = float(text)
    except ValueError:
        value = math.nan
    if not math.isfinite(value):
        raise XfaceFdpError(f"{source}: <{element.tag} {name}={text!r}> is not a finite number")
    return value


def _integer(element: ET.Element, name: str, low: int, high: int, source: str) -> int:
    text = _attribute(element, name, source)
    if not re.fullmatch(r"[+-]?\d{1,10}", text) or not low <= int(text) <= high:
        raise XfaceFdpError(f"{source}: <{element.tag} {name}={text!r}> must be an integer in {low}..{high}")
    return int(text)


def _entities(element: ET.Element, source: str) -> tuple[tuple[XfaceEntity, ...], tuple[XfaceBind, ...]]:
    entities, binds = [], []
    for entity in element.findall("entity"):
        alias = _attribute(entity, "alias", source)
        category = _attribute(entity, "category", source)
        meshes = tuple(
            (_attribute(mesh, "file", source), _attribute(mesh, "format", source)) for mesh in entity.findall("mesh")
        )
        entities.append(XfaceEntity(alias, category, meshes))
        for bind in entity.findall("bind"):
            present = [name for name in ("pivotX", "pivotY", "pivotZ") if bind.get(name) is not None]
            if present and len(present) != 3:
                raise XfaceFdpError(f"{source}: <bind item={bind.get('item')!r}> gives only {', '.join(present)}")
            pivot = np.array([_real(bind, name, source) for name in present]) if present else None
            binds.append(XfaceBind(alias, _attribute(bind, "item", source), _attribute(bind, "submesh", source), pivot))
    return tuple(entities), tuple(binds)


def _feature_points(root: ET.Element, source: str) -> tuple[XfaceFeaturePoint, ...]:
    points, seen = [], set()
    for element in root.findall("fdp"):
        fp_id = _attribute(element, "name", source)
        mesh = _attribute(element, "affects", source)
        where = f"{source}: <fdp name={fp_id!r} affects={mesh!r}>"
        if fp_id not in FP_IDS:
            raise XfaceFdpError(f"{where}: {fp_id!r} is not an MPEG-4 feature point")
        if (fp_id, mesh) in seen:
            raise XfaceFdpError(f"{where}: listed twice")
        seen.add((fp_id, mesh))
        control = _integer(element, "index", 0, MAX_VERTEX_INDEX, where)
        indices = element.findall("indices")
        if len(indices) > 1:
            raise XfaceFdpError(f"{where}: more than one <indices>")
        tokens = (indices[0].text or "").split() if indices else []
        if not all(re.fullmatch(r"\d{1,5}", token) and int(token) <= MAX_VERTEX_INDEX for token in tokens):
            raise XfaceFdpError(f"{where}: <indices> must be vertex numbers 0..{MAX_VERTEX_INDEX}")
        influences = []
        for influence in element.findall("influence"):
            fap = _integer(influence, "fap", 0, N_FAPS - 1, where) + 1  # 0-based in the file
            kind = _attribute(influence, "type", where)
            if kind not in INFLUENCE_TYPES:
                raise XfaceFdpError(f"{where}: unknown influence type {kind!r}")
            influences.append(XfaceInfluence(fap, kind, _real(influence, "weight", where)))
        zone = np.array([int(token) for token in tokens], dtype=np.int32)
        points.append(XfaceFeaturePoint(fp_id, mesh, control, zone, tuple(influences)))
    return tuple(points)
