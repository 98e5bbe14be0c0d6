"""The 68 MPEG-4 Facial Animation Parameters (ISO/IEC 14496-2), visemes and expressions.

Directions are unit axes in the MPEG-4 face frame: x toward the face's own left, y up, z forward
(out of the face). Rotations are right-handed about the named axis, so that a positive value turns
the way the standard's direction column says (head_pitch +: down = about +x; head_yaw +: toward the
face's left = about +y; head_roll +: toward the face's right = about +z).

Column sources (research/mpeg4-fba.md section 3): names from visage FBAPs.h; FAPU from XFace
scaleFAPVect with Crystal.TTVS's fix for FAP 19 (stock XFace scales it by MNS, the standard and every
other source by IRISD); U/B, direction, group and FP from the cal3d-FDP table and Greta's AU editor;
quantiser step from the reference encoder. The sources agree on every column except that FAP 19 FAPU.
"""

from __future__ import annotations

from dataclasses import dataclass
from enum import IntEnum

import numpy as np

N_FAPS = 68
FAPU_NAMES = ("IRISD", "ES", "ENS", "MNS", "MW", "AU")

_AXES = {
    "left": (1.0, 0.0, 0.0),
    "right": (-1.0, 0.0, 0.0),
    "up": (0.0, 1.0, 0.0),
    "down": (0.0, -1.0, 0.0),
    "forward": (0.0, 0.0, 1.0),
}


@dataclass(frozen=True)
class Fap:
    number: int  # 1..68
    name: str
    fapu: str | None  # one of FAPU_NAMES; None for the high-level FAPs 1 and 2
    bidirectional: bool
    direction: str  # "left" | "right" | "up" | "down" | "forward" | rotation/pupil keywords
    group: int
    fp: str | None  # the feature point it moves (the rotation centre's owner for angular FAPs)
    quant_step: int

    @property
    def is_rotation(self) -> bool:
        return self.fapu == "AU"

    @property
    def axis(self) -> tuple[float, float, float] | None:
        """Unit translation axis in the face frame, or None for rotational and high-level FAPs."""
        return _AXES.get(self.direction) if not self.is_rotation else None


def _f(n, name, fapu, ub, direction, group, fp, qp):
    return Fap(n, name, fapu, ub == "B", direction, group, fp, qp)


FAPS: tuple[Fap, ...] = (
    _f(1, "viseme", None, "-", "-", 1, None, 1),
    _f(2, "expression", None, "-", "-", 1, None, 1),
    _f(3, "open_jaw", "MNS", "U", "down", 2, "2.1", 4),
    _f(4, "lower_t_midlip", "MNS", "B", "down", 2, "2.2", 2),
    _f(5, "raise_b_midlip", "MNS", "B", "up", 2, "2.3", 2),
    _f(6, "stretch_l_cornerlip", "MW", "B", "left", 2, "2.4", 2),
    _f(7, "stretch_r_cornerlip", "MW", "B", "right", 2, "2.5", 2),
    _f(8, "lower_t_lip_lm", "MNS", "B", "down", 2, "2.6", 2),
    _f(9, "lower_t_lip_rm", "MNS", "B", "down", 2, "2.7", 2),
    _f(10, "raise_b_lip_lm", "MNS", "B", "up", 2, "2.8", 2),
    _f(11, "raise_b_lip_rm", "MNS", "B", "up", 2, "2.9", 2),
    _f(12, "raise_l_cornerlip", "MNS", "B", "up", 2, "2.4", 2),
    _f(13, "raise_r_cornerlip", "MNS", "B", "up", 2, "2.5", 2),
    _f(14, "thrust_jaw", "MNS", "U", "forward", 2, "2.1", 1),
    _f(15, "shift_jaw", "MW", "B", "right", 2, "2.1", 1),
    _f(16, "push_b_lip", "MNS", "B", "forward", 2, "2.3", 1),
    _f(17, "push_t_lip", "MNS", "B", "forward", 2, "2.2", 1),
    _f(18, "depress_chin", "MNS", "B", "up", 2, "2.10", 1),
    _f(19, "close_t_l_eyelid", "IRISD", "B", "down", 3, "3.1", 1),
    _f(20, "close_t_r_eyelid", "IRISD", "B", "down", 3, "3.2", 1),
    _f(21, "close_b_l_eyelid", "IRISD", "B", "up", 3, "3.3", 1),
    _f(22, "close_b_r_eyelid", "IRISD", "B", "up", 3, "3.4", 1),
    _f(23, "yaw_l_eyeball", "AU", "B", "yaw", 3, "3.5", 128),
    _f(24, "yaw_r_eyeball", "AU", "B", "yaw", 3, "3.6", 128),
    _f(25, "pitch_l_eyeball", "AU", "B", "pitch", 3, "3.5", 128),
    _f(26, "pitch_r_eyeball", "AU", "B", "pitch", 3, "3.6", 128),
    _f(27, "thrust_l_eyeball", "ES", "B", "forward", 3, "3.5", 1),
    _f(28, "thrust_r_eyeball", "ES", "B", "forward", 3, "3.6", 1),
    _f(29, "dilate_l_pupil", "IRISD", "B", "dilate", 3, "3.5", 1),
    _f(30, "dilate_r_pupil", "IRISD", "B", "dilate", 3, "3.6", 1),
    _f(31, "raise_l_i_eyebrow", "ENS", "B", "up", 4, "4.1", 2),
    _f(32, "raise_r_i_eyebrow", "ENS", "B", "up", 4, "4.2", 2),
    _f(33, "raise_l_m_eyebrow", "ENS", "B", "up", 4, "4.3", 2),
    _f(34, "raise_r_m_eyebrow", "ENS", "B", "up", 4, "4.4", 2),
    _f(35, "raise_l_o_eyebrow", "ENS", "B", "up", 4, "4.5", 2),
    _f(36, "raise_r_o_eyebrow", "ENS", "B", "up", 4, "4.6", 2),
    _f(37, "squeeze_l_eyebrow", "ES", "B", "right", 4, "4.1", 1),
    _f(38, "squeeze_r_eyebrow", "ES", "B", "left", 4, "4.2", 1),
    _f(39, "puff_l_cheek", "ES", "B", "left", 5, "5.1", 2),
    _f(40, "puff_r_cheek", "ES", "B", "right", 5, "5.2", 2),
    _f(41, "lift_l_cheek", "ENS", "U", "up", 5, "5.3", 2),
    _f(42, "lift_r_cheek", "ENS", "U", "up", 5, "5.4", 2),
    _f(43, "shift_tongue_tip", "MW", "B", "right", 6, "6.1", 1),
    _f(44, "raise_tongue_tip", "MNS", "B", "up", 6, "6.1", 1),
    _f(45, "thrust_tongue_tip", "MW", "B", "forward", 6, "6.1", 1),
    _f(46, "raise_tongue", "MNS", "B", "up", 6, "6.2", 1),
    _f(47, "tongue_roll", "AU", "U", "roll", 6, "6.3", 512),
    _f(48, "head_pitch", "AU", "B", "pitch", 7, "7.1", 170),
    _f(49, "head_yaw", "AU", "B", "yaw", 7, "7.1", 170),
    _f(50, "head_roll", "AU", "B", "roll", 7, "7.1", 170),
    _f(51, "lower_t_midlip_o", "MNS", "B", "down", 8, "8.1", 2),
    _f(52, "raise_b_midlip_o", "MNS", "B", "up", 8, "8.2", 2),
    _f(53, "stretch_l_cornerlip_o", "MW", "B", "left", 8, "8.3", 2),
    _f(54, "stretch_r_cornerlip_o", "MW", "B", "right", 8, "8.4", 2),
    _f(55, "lower_t_lip_lm_o", "MNS", "B", "down", 8, "8.5", 2),
    _f(56, "lower_t_lip_rm_o", "MNS", "B", "down", 8, "8.6", 2),
    _f(57, "raise_b_lip_lm_o", "MNS", "B", "up", 8, "8.7", 2),
    _f(58, "raise_b_lip_rm_o", "MNS", "B", "up", 8, "8.8", 2),
    _f(59, "raise_l_cornerlip_o", "MNS", "B", "up", 8, "8.3", 2),
    _f(60, "raise_r_cornerlip_o", "MNS", "B", "up", 8, "8.4", 2),
    _f(61, "stretch_l_nose", "ENS", "B", "left", 9, "9.1", 1),
    _f(62, "stretch_r_nose", "ENS", "B", "right", 9, "9.2", 1),
    _f(63, "raise_nose", "ENS", "B", "up", 9, "9.3", 1),
    _f(64, "bend_nose", "ENS", "B", "right", 9, "9.3", 1),
    _f(65, "raise_l_ear", "ENS", "B", "up", 10, "10.1", 1),
    _f(66, "raise_r_ear", "ENS", "B", "up", 10, "10.2", 1),
    _f(67, "pull_l_ear", "ENS", "B", "left", 10, "10.3", 1),
    _f(68, "pull_r_ear", "ENS", "B", "right", 10, "10.4", 1),
)

_BY_NAME = {fap.name: fap for fap in FAPS}


def fap(key: int | str) -> Fap:
    """A FAP by number (1..68) or name."""
    if isinstance(key, str):
        try:
            return _BY_NAME[key]
        except KeyError:
            raise KeyError(f"unknown FAP name {key!r}") from None
    if not 1 <= key <= N_FAPS:
        raise KeyError(f"FAP number {key} is outside 1..{N_FAPS}")
    return FAPS[key - 1]


# Left/right pairs (_l FAP, _r FAP). The standard gives mirrored pairs mirrored positive directions,
# so copying a value to the partner always gives the symmetric motion.
LEFT_RIGHT_PAIRS: tuple[tuple[int, int], ...] = (
    (6, 7), (8, 9), (10, 11), (12, 13), (19, 20), (21, 22), (23, 24), (25, 26), (27, 28), (29, 30),
    (31, 32), (33, 34), (35, 36), (37, 38), (39, 40), (41, 42), (53, 54), (55, 56), (57, 58),
    (59, 60), (61, 62), (65, 66), (67, 68),
)  # fmt: skip
# Inner/outer lip counterparts (inner, outer).
INNER_OUTER_LIP_PAIRS: tuple[tuple[int, int], ...] = (
    (4, 51), (5, 52), (6, 53), (7, 54), (8, 55), (9, 56), (10, 57), (11, 58), (12, 59), (13, 60),
)  # fmt: skip


class Viseme(IntEnum):
    """FAP 1 viseme_select values; the phonemes each stands for are in VISEME_PHONEMES."""

    NONE = 0
    PP = 1
    FF = 2
    TH = 3
    DD = 4
    KK = 5
    CH = 6
    SS = 7
    NN = 8
    RR = 9
    AA = 10
    E = 11
    IH = 12
    OH = 13
    OU = 14


VISEME_PHONEMES: dict[Viseme, tuple[str, ...]] = {
    Viseme.NONE: (),
    Viseme.PP: ("p", "b", "m"),
    Viseme.FF: ("f", "v"),
    Viseme.TH: ("T", "D"),
    Viseme.DD: ("t", "d"),
    Viseme.KK: ("k", "g"),
    Viseme.CH: ("tS", "dZ", "S"),
    Viseme.SS: ("s", "z"),
    Viseme.NN: ("n", "l"),
    Viseme.RR: ("r",),
    Viseme.AA: ("A:",),
    Viseme.E: ("e",),
    Viseme.IH: ("I",),
    Viseme.OH: ("Q",),
    Viseme.OU: ("U",),
}


class Expression(IntEnum):
    """FAP 2 expression_select values."""

    NEUTRAL = 0
    JOY = 1
    SADNESS = 2
    ANGER = 3
    FEAR = 4
    DISGUST = 5
    SURPRISE = 6


@dataclass(frozen=True)
class VisemeValue:
    """FAP 1: result = select1 * blend/63 + select2 * (1 - blend/63)."""

    select1: Viseme
    select2: Viseme
    blend: int  # 0..63
    definition: bool = False

    @classmethod
    def from_fields(cls, fields) -> VisemeValue:
        s1, s2, blend, definition = (int(v) for v in fields)
        return cls(Viseme(s1), Viseme(s2), blend, bool(definition))

    def fields(self) -> tuple[int, int, int, int]:
        return int(self.select1), int(self.select2), self.blend, int(self.definition)


@dataclass(frozen=True)
class ExpressionValue:
    """FAP 2: result = select1 * intensity1/63 + select2 * intensity2/63 (additive, not convex)."""

    select1: Expression
    intensity1: int  # 0..63
    select2: Expression = Expression.NEUTRAL
    intensity2: int = 0
    init_face: bool = False
    definition: bool = False

    @classmethod
    def from_fields(cls, fields) -> ExpressionValue:
        s1, i1, s2, i2, init_face, definition = (int(v) for v in fields)
        return cls(Expression(s1), i1, Expression(s2), i2, bool(init_face), bool(definition))

    def fields(self) -> tuple[int, int, int, int, int, int]:
        fields = (self.select1, self.intensity1, self.select2, self.intensity2, self.init_face, self.definition)
        return tuple(int(v) for v in fields)


def viseme_weights(fields: np.ndarray) -> np.ndarray:
    """(F, 4) FAP 1 fields -> (F, 15) weight of each viseme; out-of-range selects are an error."""
    fields = np.asarray(fields, dtype=np.float64).reshape(-1, 4)
    select = fields[:, :2].astype(np.int64)
    if np.any((select < 0) | (select > 14)):
        raise ValueError("viseme_select must be in 0..14")
    blend = np.clip(fields[:, 2], 0.0, 63.0) / 63.0
    out = np.zeros((len(fields), 15))
    rows = np.arange(len(fields))
    np.add.at(out, (rows, select[:, 0]), blend)
    np.add.at(out, (rows, select[:, 1]), 1.0 - blend)
    return out


def expression_weights(fields: np.ndarray) -> np.ndarray:
    """(F, 6) FAP 2 fields -> (F, 7) intensity of each expression in 0..1 (neutral column included)."""
    fields = np.asarray(fields, dtype=np.float64).reshape(-1, 6)
    select = fields[:, [0, 2]].astype(np.int64)
    if np.any((select < 0) | (select > 6)):
        raise ValueError("expression_select must be in 0..6")
    intensity = np.clip(fields[:, [1, 3]], 0.0, 63.0) / 63.0
    out = np.zeros((len(fields), 7))
    rows = np.arange(len(fields))
    np.add.at(out, (rows, select[:, 0]), intensity[:, 0])
    np.add.at(out, (rows, select[:, 1]), intensity[:, 1])
    return out
