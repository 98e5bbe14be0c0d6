"""The 84 MPEG-4 feature points (ISO/IEC 14496-2 FDP, groups 2-11).

Left and right are always the face's own sides. The numbering parity changes between groups
(8.9, 9.4, 9.6 and 11.2 are on the right), so mirror partners are listed explicitly. The eye-corner
pairs follow the outer-with-outer reading (3.7 <-> 3.12, 3.11 <-> 3.8) so that the mirror of a point
is the anatomically symmetric one; the standard's wording ("left corner of the right eye") would pair
3.7 with 3.8, which are not mirror images of each other.

`surface` says what the point lies on: skin, eye, teeth, tongue, ear or hair. 7.1 (top of the spine,
the head's rotation centre) lies on no surface and is marked "inside".
Sources: research/mpeg4-fba.md section 4 (standard's FDP table as encoded by Greta, cal3d-FDP, XfaceEd).
"""

from __future__ import annotations

from dataclasses import dataclass

SURFACES = ("skin", "eye", "teeth", "tongue", "ear", "hair", "inside")


@dataclass(frozen=True)
class FeaturePoint:
    id: str
    name: str
    description: str
    mirror: str | None  # partner across the mid-line; None on the mid-line
    surface: str
    side: str  # "L", "R" (the face's own side) or "mid"

    @property
    def group(self) -> int:
        return int(self.id.split(".")[0])


def _fp(fp_id, name, description, mirror=None, surface="skin", side="mid"):
    return FeaturePoint(fp_id, name, description, mirror, surface, side)


_TABLE = (
    # group 2: chin, jaw, inner lip
    _fp("2.1", "chin_bottom", "bottom of the chin, on the mid-line"),
    _fp("2.2", "inner_upper_lip_mid", "middle of the inner upper lip contour"),
    _fp("2.3", "inner_lower_lip_mid", "middle of the inner lower lip contour"),
    _fp("2.4", "inner_lip_corner_l", "left corner of the inner lip contour", "2.5", side="L"),
    _fp("2.5", "inner_lip_corner_r", "right corner of the inner lip contour", "2.4", side="R"),
    _fp("2.6", "inner_upper_lip_l", "inner upper lip, midway between 2.2 and 2.4", "2.7", side="L"),
    _fp("2.7", "inner_upper_lip_r", "inner upper lip, midway between 2.2 and 2.5", "2.6", side="R"),
    _fp("2.8", "inner_lower_lip_l", "inner lower lip, midway between 2.3 and 2.4", "2.9", side="L"),
    _fp("2.9", "inner_lower_lip_r", "inner lower lip, midway between 2.3 and 2.5", "2.8", side="R"),
    _fp("2.10", "chin_boss", "chin boss, on the mid-line"),
    _fp("2.11", "chin_l", "chin, left corner", "2.12", side="L"),
    _fp("2.12", "chin_r", "chin, right corner", "2.11", side="R"),
    _fp("2.13", "jaw_corner_l", "left corner of the jaw bone", "2.14", side="L"),
    _fp("2.14", "jaw_corner_r", "right corner of the jaw bone", "2.13", side="R"),
    # group 3: eyes
    _fp("3.1", "upper_eyelid_l", "centre of the upper inner left eyelid", "3.2", side="L"),
    _fp("3.2", "upper_eyelid_r", "centre of the upper inner right eyelid", "3.1", side="R"),
    _fp("3.3", "lower_eyelid_l", "centre of the lower inner left eyelid", "3.4", side="L"),
    _fp("3.4", "lower_eyelid_r", "centre of the lower inner right eyelid", "3.3", side="R"),
    _fp("3.5", "pupil_l", "centre of the left pupil", "3.6", "eye", side="L"),
    _fp("3.6", "pupil_r", "centre of the right pupil", "3.5", "eye", side="R"),
    _fp("3.7", "eye_outer_corner_l", "left (outer) corner of the left eye", "3.12", side="L"),
    _fp("3.8", "eye_inner_corner_r", "left (inner) corner of the right eye", "3.11", side="R"),
    _fp("3.9", "lower_outer_eyelid_l", "centre of the lower outer left eyelid", "3.10", side="L"),
    _fp("3.10", "lower_outer_eyelid_r", "centre of the lower outer right eyelid", "3.9", side="R"),
    _fp("3.11", "eye_inner_corner_l", "right (inner) corner of the left eye", "3.8", side="L"),
    _fp("3.12", "eye_outer_corner_r", "right (outer) corner of the right eye", "3.7", side="R"),
    _fp("3.13", "upper_outer_eyelid_l", "centre of the upper outer left eyelid", "3.14", side="L"),
    _fp("3.14", "upper_outer_eyelid_r", "centre of the upper outer right eyelid", "3.13", side="R"),
    # group 4: eyebrows
    _fp("4.1", "eyebrow_inner_l", "right (inner) corner of the left eyebrow", "4.2", side="L"),
    _fp("4.2", "eyebrow_inner_r", "left (inner) corner of the right eyebrow", "4.1", side="R"),
    _fp("4.3", "eyebrow_top_l", "uppermost point of the left eyebrow", "4.4", side="L"),
    _fp("4.4", "eyebrow_top_r", "uppermost point of the right eyebrow", "4.3", side="R"),
    _fp("4.5", "eyebrow_outer_l", "left (outer) corner of the left eyebrow", "4.6", side="L"),
    _fp("4.6", "eyebrow_outer_r", "right (outer) corner of the right eyebrow", "4.5", side="R"),
    # group 5: cheeks
    _fp("5.1", "cheek_l", "centre of the left cheek, at the height of 8.3", "5.2", side="L"),
    _fp("5.2", "cheek_r", "centre of the right cheek, at the height of 8.4", "5.1", side="R"),
    _fp("5.3", "cheek_bone_l", "left cheek bone", "5.4", side="L"),
    _fp("5.4", "cheek_bone_r", "right cheek bone", "5.3", side="R"),
    # group 6: tongue
    _fp("6.1", "tongue_tip", "tip of the tongue", surface="tongue"),
    _fp("6.2", "tongue_body", "centre of the tongue body", surface="tongue"),
    _fp("6.3", "tongue_border_l", "left border of the tongue", "6.4", "tongue", side="L"),
    _fp("6.4", "tongue_border_r", "right border of the tongue", "6.3", "tongue", side="R"),
    # group 7: head
    _fp("7.1", "spine_top", "top of the spine: centre of head rotation", surface="inside"),
    # group 8: outer lip
    _fp("8.1", "outer_upper_lip_mid", "middle of the outer upper lip contour"),
    _fp("8.2", "outer_lower_lip_mid", "middle of the outer lower lip contour"),
    _fp("8.3", "outer_lip_corner_l", "left corner of the outer lip contour", "8.4", side="L"),
    _fp("8.4", "outer_lip_corner_r", "right corner of the outer lip contour", "8.3", side="R"),
    _fp("8.5", "outer_upper_lip_l", "outer upper lip, midway between 8.3 and 8.1", "8.6", side="L"),
    _fp("8.6", "outer_upper_lip_r", "outer upper lip, midway between 8.4 and 8.1", "8.5", side="R"),
    _fp("8.7", "outer_lower_lip_l", "outer lower lip, midway between 8.3 and 8.2", "8.8", side="L"),
    _fp("8.8", "outer_lower_lip_r", "outer lower lip, midway between 8.4 and 8.2", "8.7", side="R"),
    _fp("8.9", "cupid_bow_r", "right high point of the Cupid's bow", "8.10", side="R"),
    _fp("8.10", "cupid_bow_l", "left high point of the Cupid's bow", "8.9", side="L"),
    # group 9: nose and teeth
    _fp("9.1", "nostril_l", "left nostril border", "9.2", side="L"),
    _fp("9.2", "nostril_r", "right nostril border", "9.1", side="R"),
    _fp("9.3", "nose_tip", "nose tip"),
    _fp("9.4", "nose_bottom_edge_r", "bottom right edge of the nose", "9.5", side="R"),
    _fp("9.5", "nose_bottom_edge_l", "bottom left edge of the nose", "9.4", side="L"),
    _fp("9.6", "nose_bone_upper_r", "right upper edge of the nose bone", "9.7", side="R"),
    _fp("9.7", "nose_bone_upper_l", "left upper edge of the nose bone", "9.6", side="L"),
    _fp("9.8", "upper_teeth_top", "top of the upper teeth, middle", surface="teeth"),
    _fp("9.9", "lower_teeth_bottom", "bottom of the lower teeth, middle", surface="teeth"),
    _fp("9.10", "upper_teeth_bottom", "bottom of the upper teeth, middle", surface="teeth"),
    _fp("9.11", "lower_teeth_top", "top of the lower teeth, middle", surface="teeth"),
    _fp("9.12", "nose_bone_lower_mid", "middle lower edge of the nose bone (nose bump)"),
    _fp("9.13", "nose_bone_lower_l", "left lower edge of the nose bone", "9.14", side="L"),
    _fp("9.14", "nose_bone_lower_r", "right lower edge of the nose bone", "9.13", side="R"),
    _fp("9.15", "nose_base", "bottom middle edge of the nose (nose base)"),
    # group 10: ears
    _fp("10.1", "ear_upper_contact_l", "upper contact point between left ear and face", "10.2", "ear", "L"),
    _fp("10.2", "ear_upper_contact_r", "upper contact point between right ear and face", "10.1", "ear", "R"),
    _fp("10.3", "ear_lower_contact_l", "lower contact point between left ear and face", "10.4", "ear", "L"),
    _fp("10.4", "ear_lower_contact_r", "lower contact point between right ear and face", "10.3", "ear", "R"),
    _fp("10.5", "ear_lobe_bottom_l", "bottom of the left ear lobe", "10.6", "ear", "L"),
    _fp("10.6", "ear_lobe_bottom_r", "bottom of the right ear lobe", "10.5", "ear", "R"),
    _fp("10.7", "ear_lobe_contact_l", "lower contact point between left lobe and face", "10.8", "ear", "L"),
    _fp("10.8", "ear_lobe_contact_r", "lower contact point between right lobe and face", "10.7", "ear", "R"),
    _fp("10.9", "ear_top_l", "upper point of the left ear", "10.10", "ear", "L"),
    _fp("10.10", "ear_top_r", "upper point of the right ear", "10.9", "ear", "R"),
    # group 11: hairline and skull
    _fp("11.1", "hairline_mid", "middle of the hair-forehead border", surface="hair"),
    _fp("11.2", "hairline_r", "right end of the hair-forehead border", "11.3", "hair", "R"),
    _fp("11.3", "hairline_l", "left end of the hair-forehead border", "11.2", "hair", "L"),
    _fp("11.4", "skull_top", "top of the skull", surface="hair"),
    _fp("11.5", "hair_top", "hair thickness over 11.4", surface="hair"),
    _fp("11.6", "skull_back", "back of the skull", surface="hair"),
)

FEATURE_POINTS: tuple[FeaturePoint, ...] = _TABLE
FP_IDS: tuple[str, ...] = tuple(fp.id for fp in FEATURE_POINTS)
_INDEX = {fp_id: i for i, fp_id in enumerate(FP_IDS)}
N_FEATURE_POINTS = len(FEATURE_POINTS)


def fp_index(fp_id: str) -> int:
    """Row of `fp_id` in FEATURE_POINTS (and in every (84, 3) position array)."""
    try:
        return _INDEX[fp_id]
    except KeyError:
        raise KeyError(f"unknown MPEG-4 feature point {fp_id!r}") from None


def feature_point(fp_id: str) -> FeaturePoint:
    return FEATURE_POINTS[fp_index(fp_id)]


def mirror_index() -> list[int]:
    """For each FP row, the row of its mirror partner (itself on the mid-line)."""
    return [fp_index(fp.mirror) if fp.mirror else i for i, fp in enumerate(FEATURE_POINTS)]
