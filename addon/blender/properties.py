"""Per-face settings (`Object.mpeg4_face`) and per-scene settings (`Scene.mpeg4`)."""

import bpy
from bpy.props import (
    BoolProperty,
    EnumProperty,
    FloatProperty,
    FloatVectorProperty,
    PointerProperty,
    StringProperty,
)


def _rebind(self, context):
    from . import live

    live.settings_changed(self.id_data, rebind=True)


def _reapply(self, context):
    from . import live

    live.settings_changed(self.id_data, rebind=False)


class MPEG4_PG_face(bpy.types.PropertyGroup):
    enabled: BoolProperty(
        name="Deform",
        description="Deform this face from its feature point empties (off restores the rest mesh exactly)",
        default=False,
        update=_reapply,
    )
    mode: EnumProperty(
        name="Mode",
        items=(
            ("PLANAR_BONES", "Planar Bones", "Per-region frames (face, edge, apex): no over-warping"),
            ("SOFFD", "SoFFD", "Plain surface-oriented free-form deformation (baseline)"),
        ),
        default="PLANAR_BONES",
        update=_reapply,
    )
    radius_fraction: FloatProperty(
        name="Radius",
        description="Affection radius of each control triangle as a fraction of the distance to its nearest "
        "other feature point (raised where needed so the whole face is covered)",
        default=1.0,
        min=0.05,
        soft_max=4.0,
        update=_rebind,
    )
    falloff_exponent: FloatProperty(
        name="Falloff",
        description="Exponent n of the cosine falloff (eq. 9)",
        default=2.0,
        min=0.1,
        soft_max=8.0,
        update=_rebind,
    )
    use_masks: BoolProperty(
        name="Masks",
        description="Stop motion crossing the mouth and eye openings with the upper_lip, lower_lip, "
        "upper_eyelid and lower_eyelid vertex groups",
        default=True,
        update=_rebind,
    )
    mask_image: PointerProperty(
        name="Mask Image",
        type=bpy.types.Image,
        update=_rebind,
        description="Masks painted as a texture (R: upper lip, G: lower lip, B: upper eyelids, A: lower "
        "eyelids), sampled at the face's UVs; when empty, the vertex groups of those names are used",
    )
    fp_collection: PointerProperty(name="Feature Points", type=bpy.types.Collection)
    control_object: PointerProperty(name="Control Mesh", type=bpy.types.Object)
    left_eye: PointerProperty(
        name="Left Eyeball", type=bpy.types.Object, description="Turns with FP 3.5 (FAPs 23, 25) about its origin"
    )
    right_eye: PointerProperty(
        name="Right Eyeball", type=bpy.types.Object, description="Turns with FP 3.6 (FAPs 24, 26) about its origin"
    )
    lower_teeth: PointerProperty(
        name="Lower Teeth", type=bpy.types.Object, description="Moves with FP 9.11, i.e. with the jaw"
    )
    tongue: PointerProperty(name="Tongue", type=bpy.types.Object, description="Moves with FP 6.2")
    fapu: FloatVectorProperty(
        name="FAPU0",
        description="IRISD0, ES0, ENS0, MNS0, MW0 of the neutral face (model units)",
        size=5,
        subtype="NONE",
        default=(0.0,) * 5,
    )
    status: StringProperty(name="Status", description="Last problem the live deformation met", default="")


class MPEG4_PG_scene(bpy.types.PropertyGroup):
    fill_partners: BoolProperty(
        name="Fill From Partners",
        description="When importing, a FAP missing in a frame takes its left/right or inner/outer lip "
        "partner's value before holding its last value",
        default=False,
    )


CLASSES = (MPEG4_PG_face, MPEG4_PG_scene)


def register_properties():
    bpy.types.Object.mpeg4_face = PointerProperty(type=MPEG4_PG_face)
    bpy.types.Scene.mpeg4 = PointerProperty(type=MPEG4_PG_scene)


def unregister_properties():
    del bpy.types.Scene.mpeg4
    del bpy.types.Object.mpeg4_face
