"""The engine switch: Planar Bones or Elastic Bones per face, one operator and the panel row that calls it."""

import bpy
from bpy.props import EnumProperty

from . import elastic_rig, live, poll, rest_shape
from .reporting import Mpeg4Operator

ENGINES = (
    (elastic_rig.PLANAR, "Planar Bones", "The control mesh's triangles move the skin (the mesh is written)"),
    (
        elastic_rig.ELASTIC,
        "Elastic Bones",
        "A reduced MPEG-4 skeleton with an elastic layer, skinned by an Armature modifier (exports to glTF)",
    ),
)


def set_engine(face, engine: str) -> list[str]:
    """Switch `face` to `engine`; all checks come first, so a refused switch changes nothing."""
    settings = face.mpeg4_face
    if engine == settings.engine:
        return [f"{face.name} already uses {dict((e, n) for e, n, _d in ENGINES)[engine]}"]
    if engine == elastic_rig.ELASTIC:
        plan = elastic_rig.plan(face)
        notes = elastic_rig.build(face, plan)  # (building runs the handlers: the engine changes after it)
        settings.engine = engine
        live.forget(face)
        rest_shape.restore_rest(face.data)  # the mesh keeps its rest shape; the Armature modifier deforms it
    else:
        elastic_rig.remove(face)
        notes = [f"removed {face.name}'s Elastic Bones skeleton, its vertex groups and its Armature modifier"]
        settings.engine = engine
    live.refresh(face)
    return notes


class MPEG4_OT_set_engine(Mpeg4Operator, bpy.types.Operator):
    """Choose how the feature points move this face: Elastic Bones builds a skeleton with skin weights and an
    Armature modifier, Planar Bones takes them away again"""

    bl_idname = "mpeg4.set_engine"
    bl_label = "Set Engine"
    bl_options = {"REGISTER", "UNDO"}

    engine: EnumProperty(name="Engine", items=ENGINES)

    @classmethod
    def unavailable(cls, context):
        return poll.not_set_up(context)

    def run(self, context):
        return set_engine(poll.face(context), self.engine)


def draw_engine(layout, settings) -> None:
    row = layout.row(align=True)
    row.label(text="Engine")
    for engine, name, _description in ENGINES:
        row.operator(MPEG4_OT_set_engine.bl_idname, text=name, depress=settings.engine == engine).engine = engine


CLASSES = (MPEG4_OT_set_engine,)
