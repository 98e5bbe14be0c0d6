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

from . import fap_io, live
from .reporting import property_callback

GAIN_TEXT = (
    "Scale the %s FAPs of imported streams and speech (1: as given). The last stream imported in place of "
    "the face's motion is keyed again at once"
)


@property_callback
def _rebind(self, context):
    live.settings_changed(self.id_data, rebind=True)


@property_callback
def _regain(self, context):
    face = self.id_data
    if fap_io.apply_gains(context, face):
        scene = context.scene
        scene.frame_set(scene.frame_current, subframe=scene.frame_subframe)  # show the new keys now


def _gain(label: str, what: str) -> FloatProperty:
    return FloatProperty(name=label, default=1.0, min=0.0, soft_max=2.0, update=_regain, description=GAIN_TEXT % what)


@property_callback
def _reapply(self, context):
    live.settings_changed(self.id_data, rebind=False)


class MPEG4_PG_face(bpy.types.PropertyGroup):
    enabled: BoolProperty(
        name="Deform",
        description="Deform this face from its feature point empties. Off shows the face exactly as it was set up",
        default=False,
        update=_reapply,
    )
    mode: EnumProperty(
        name="Mode",
        items=(
            (
                "PLANAR_BONES",
                "Planar Bones",
                "Each control triangle moves the skin near it like a bone, without "
                "over-stretching where triangles meet",
            ),
            ("SOFFD", "SoFFD", "Plain surface-oriented free-form deformation, for comparison"),
        ),
        default="PLANAR_BONES",
        update=_reapply,
    )
    keep_lips_apart: BoolProperty(
        name="Keep Lips Apart",
        description="Keep the skin of the two lips from passing through each other: lip vertices past the seam "
        "between the lips move back onto it (about 0.04 ms a frame). Off: only the lips' feature points are kept "
        "in order, and the skin between them can cross by a few millimetres in extreme poses",
        default=True,
        update=_reapply,
    )
    unfold_skin: BoolProperty(
        name="Unfold Skin",
        description="After every frame, smooth the skin's motion where a face turned over against the rest pose "
        "(where a feature point passed its neighbours, as the lip corner in a very wide smile), so that no face "
        "shows its back; there the point's own skin may then lag it by a few millimetres. The check costs about "
        "0.03 ms a frame, a frame with folds up to about 1 ms more. Off: the deformation exactly as the Planar "
        "Bones paper gives it",
        default=True,
        update=_reapply,
    )
    still_upper_face: BoolProperty(
        name="Still Skin Around Eyes",
        description="The brows', lids' and cheeks' control triangles move only the skin near them, and the skin "
        "between brow, lid, temple and cheek that none of them reaches stays still, the moving skin fading smoothly "
        "into it, as on a real face. Off: the "
        "Planar Bones paper's coverage, where every face vertex follows its nearest triangle and a brow raise "
        "moves the whole forehead and temple",
        default=True,
        update=_rebind,
    )
    engine: EnumProperty(
        name="Engine",
        description="How the feature points move the skin (switch with the Engine buttons, which build or remove "
        "the skeleton)",
        items=(
            ("PLANAR_BONES", "Planar Bones", "The control mesh's triangles move the skin (the mesh is written)"),
            (
                "ELASTIC_BONES",
                "Elastic Bones",
                "A reduced MPEG-4 skeleton with an elastic layer, skinned by an Armature modifier: plain skeletal "
                "animation that exports to glTF",
            ),
        ),
        default="PLANAR_BONES",
    )
    radius_fraction: FloatProperty(
        name="Radius",
        description="How far each control triangle reaches into the skin, relative to the distance to the "
        "nearest other feature point (raised where needed so the whole face moves)",
        default=1.0,
        min=0.05,
        soft_max=4.0,
        update=_rebind,
    )
    falloff_exponent: FloatProperty(
        name="Falloff",
        description="How quickly a triangle's pull fades with distance: higher values keep motion closer "
        "to the feature points",
        default=2.0,
        min=0.1,
        soft_max=8.0,
        update=_rebind,
    )
    use_masks: BoolProperty(
        name="Masks",
        description="Keep the upper and lower lips (and eyelids) from dragging each other along, using the "
        "upper_lip, lower_lip, upper_eyelid and lower_eyelid vertex groups",
        default=True,
        update=_rebind,
    )
    mask_image: PointerProperty(
        name="Mask Image",
        type=bpy.types.Image,
        update=_rebind,
        description="Lip and eyelid masks painted as a texture (red: upper lip, green: lower lip, blue: upper "
        "eyelids, alpha: lower eyelids), read at the face's UVs. Empty: use the vertex groups",
    )
    use_x_mirror: BoolProperty(
        name="X-Mirror",
        description="Moving or placing a left feature point moves or places its right partner too (mirrored "
        "across the face's X axis), and the other way round",
        default=False,
    )
    fp_collection: PointerProperty(name="Feature Points", type=bpy.types.Collection)
    binding_holder: PointerProperty(
        name="Binding", type=bpy.types.Text, description="Where the face's binding is saved (set up by Set Up Face)"
    )
    control_object: PointerProperty(name="Control Mesh", type=bpy.types.Object)
    # face parts: filled by name at set-up when empty; Set Up Face hooks them to their feature points
    left_eye: PointerProperty(
        name="Left Eye",
        type=bpy.types.Object,
        description="The left eyeball: turns about its centre (a sphere fitted to its mesh) to look where feature "
        "point 3.5 (left pupil) goes. Run Set Up Face after changing it",
    )
    right_eye: PointerProperty(
        name="Right Eye",
        type=bpy.types.Object,
        description="The right eyeball: turns about its centre to look where feature point 3.6 goes. Run Set Up "
        "Face after changing it",
    )
    upper_teeth: PointerProperty(
        name="Upper Teeth",
        type=bpy.types.Object,
        description="Fixed to the skull: moves only with the head. Run Set Up Face after changing it",
    )
    lower_teeth: PointerProperty(
        name="Lower Teeth",
        type=bpy.types.Object,
        description="Moves with the jaw (feature point 9.11). Run Set Up Face after changing it",
    )
    tongue: PointerProperty(
        name="Tongue",
        type=bpy.types.Object,
        description="Moves with feature point 6.2. Run Set Up Face after changing it",
    )
    lashes: PointerProperty(
        name="Lashes",
        type=bpy.types.Object,
        description="Eyelashes: follow the eyelids (a Surface Deform modifier bound to the face). Run Set Up Face "
        "after changing it",
    )
    brows: PointerProperty(
        name="Brows",
        type=bpy.types.Object,
        description="Eyebrow hair or cards: follow the brow skin (a Surface Deform modifier bound to the face). "
        "Run Set Up Face after changing it",
    )
    made_masks: StringProperty(
        name="Made Masks",
        description="The mask vertex groups Set Up Face made from the feature points (the face had none); "
        "edit them like any vertex group",
        default="",
    )
    gain_jaw: _gain("Jaw", "jaw")
    gain_lips: _gain("Lips", "lip")
    gain_eyelids: _gain("Eyelids", "eyelid")
    gain_eyes: _gain("Eyes", "eyeball")
    gain_brows: _gain("Brows", "eyebrow")
    gain_head: _gain("Head", "head")
    use_soft_limits: BoolProperty(
        name="Plausible Ranges",
        description="When importing or speaking, ease FAP values that go past what a face can do back into range "
        "(a smooth saturation per group, not a hard cut), and stop lids and lips where they meet",
        default=True,
        update=_regain,
    )
    fapu: FloatVectorProperty(
        name="FAPU",
        description="The face's measures that FAP values are relative to: iris diameter, eye separation, eye-nose "
        "and mouth-nose distances, mouth width (model units)",
        size=5,
        subtype="NONE",
        default=(0.0,) * 5,
    )
    status: StringProperty(name="Status", description="The last problem the live deformation met", default="")


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
