"""Bake the live deformation so the animation plays without this extension.

A bake steps through its frames with the live effect on and stores each frame's deformed positions as
soon as they are read, so memory does not grow with the number of frames:
- shape keys: one key per frame, added as the frame is baked, keyed to 1 on its frame and 0 on its
  neighbours;
- point cache: a .pc2 file streamed frame by frame, read by a Mesh Cache modifier put first in the stack;
  optionally Blender's Alembic exporter then writes the baked face (with its eyes, teeth and tongue).
When every frame is done the effect is turned off, which restores the rest mesh. Files are written under
temporary names and renamed into place only then: a cancelled or failed bake leaves no file, keeps an
existing cache, and takes back the keys it added.

`Bake.step` is what the bake operator's timer calls, a few frames per tick; `run` bakes in one go.
"""

from __future__ import annotations

import os
import tempfile
from collections.abc import Sequence

import bpy
import numpy as np

from ..errors import Mpeg4Error
from ..formats.pc2 import TEMP_SUFFIX, PointCacheWriter
from . import animation, elastic_rig, followers, live, rest_shape
from .face_data import CREATED_PROP
from .reporting import progress

CACHE_MODIFIER = "MPEG-4 Bake"
BAKED_KEY_PREFIX = "MPEG-4 frame "
CREATED_BASIS_PROP = "mpeg4_bake_created_basis"  # on the mesh: the bake added the Basis key


def deformed_positions(mesh) -> np.ndarray:
    block = mesh.shape_keys.key_blocks.get(rest_shape.SHAPE_KEY_NAME) if mesh.shape_keys else None
    if block is None:
        return rest_shape.read_positions(mesh)
    return rest_shape.read_key(block)


class Bake:
    """A bake in progress: `step` until `done`, then `finish`; `cancel` takes back everything it did.

    Objects are looked up by name on every call (a modal bake spans many event-loop turns).
    """

    def __init__(self, context, face, frames: Sequence[int]):
        if not face.mpeg4_face.enabled:
            raise Mpeg4Error(f"turn on Deform for {face.name} before baking")
        if face.mpeg4_face.engine == elastic_rig.ELASTIC:
            raise Mpeg4Error(
                f"{face.name} uses Elastic Bones: its import is baked into the skeleton's keys already (export it "
                "as glTF or Alembic as it is)"
            )
        if len(frames) == 0:
            raise Mpeg4Error("nothing to bake: the frame range is empty (End is before Start)")
        scene = context.scene
        self.face_name, self.scene_name = face.name, scene.name
        self.frames = frames
        self.baked = 0
        self.finishing = "storing the result"  # what `finish` does, for a progress line
        self._frame = (scene.frame_current, scene.frame_subframe)

    @property
    def done(self) -> bool:
        return self.baked == len(self.frames)

    def face(self):
        face = bpy.data.objects.get(self.face_name)
        if face is None or face.type != "MESH":
            raise Mpeg4Error(f"{self.face_name} was deleted or renamed during the bake")
        return face

    def step(self, count: int = 1) -> None:
        """Bake the next `count` frames (fewer at the end)."""
        scene = bpy.data.scenes.get(self.scene_name)
        if scene is None:
            raise Mpeg4Error(f"the scene {self.scene_name} was deleted or renamed during the bake")
        face = self.face()
        settings = face.mpeg4_face
        for frame in self.frames[self.baked : self.baked + count]:
            scene.frame_set(frame)
            if not settings.enabled or not live.apply_face(face):
                raise Mpeg4Error(settings.status or f"Deform was turned off for {face.name} during the bake")
            self._store(face, frame, deformed_positions(face.data))
            self.baked += 1

    def finish(self) -> list[str]:
        """Store the result of a done bake; on an error everything is taken back and the error raised."""
        self._restore_frame()
        try:
            return self._finish(self.face())
        except BaseException:
            self._discard()
            raise

    def cancel(self) -> None:
        """Take back everything the bake did (after a cancel or a failed step)."""
        self._discard()
        self._restore_frame()

    def _restore_frame(self) -> None:
        scene = bpy.data.scenes.get(self.scene_name)
        if scene is not None:
            scene.frame_set(self._frame[0], subframe=self._frame[1])

    def _store(self, face, frame: int, positions: np.ndarray) -> None:
        raise NotImplementedError

    def _finish(self, face) -> list[str]:
        raise NotImplementedError

    def _discard(self) -> None:
        raise NotImplementedError


def run(context, bake: Bake) -> list[str]:
    """Bake every frame left and store the result (a failure takes the bake back and is raised)."""
    try:
        with progress(context, len(bake.frames)) as update:
            while not bake.done:
                bake.step()
                update(bake.baked)
    except BaseException:
        bake.cancel()
        raise
    return bake.finish()


# ----------------------------------------------------------------------------- shape keys


class ShapeKeyBake(Bake):
    """One shape key per frame, added as each frame is baked."""

    def __init__(self, context, face, frames: Sequence[int]):
        super().__init__(context, face, frames)
        mesh = face.data
        self._created_basis = mesh.shape_keys is None
        if self._created_basis:
            live.pause(face)  # the Basis copies the mesh: it must get the rest shape, not the pose
            face.shape_key_add(name="Basis", from_mix=False)
            mesh[CREATED_BASIS_PROP] = True
        key = mesh.shape_keys
        # with keys on the mesh the live effect writes into a key of its own, which we read each frame
        self._created_own_key = rest_shape.SHAPE_KEY_NAME not in key.key_blocks
        self._created_anim = key.animation_data is None
        self._created_action = self._created_anim or key.animation_data.action is None
        self._added: list[str] = []

    def _store(self, face, frame: int, positions: np.ndarray) -> None:
        block = face.shape_key_add(name=f"{BAKED_KEY_PREFIX}{frame}", from_mix=False)
        self._added.append(block.name)
        block.data.foreach_set("co", positions.ravel())
        key = face.data.shape_keys
        fcurve = animation.ensure_fcurve(key, _value_path(block.name), 0, f"{face.name} MPEG-4 bake")
        if self._created_action:
            key.animation_data.action[CREATED_PROP] = True
        animation.set_keys(fcurve, np.array([frame - 1, frame, frame + 1], dtype=np.float64), np.array([0.0, 1.0, 0.0]))

    def _finish(self, face) -> list[str]:
        face.mpeg4_face.enabled = False  # restores the rest mesh
        if self._created_own_key:
            rest_shape.remove_own_shape_key(face)
        return [f"baked {len(self.frames)} frames to shape keys; live deformation turned off"]

    def _discard(self) -> None:
        face = bpy.data.objects.get(self.face_name)
        if face is None or face.type != "MESH" or face.data.shape_keys is None:
            return
        key = face.data.shape_keys
        _remove_baked_keys(face, self._added, drop_action=self._created_action)
        self._added = []
        if self._created_anim and key.animation_data is not None and key.animation_data.action is None:
            key.animation_data_clear()
        if self._created_own_key:
            rest_shape.remove_own_shape_key(face)
        if self._created_basis:
            _remove_created_basis(face)
        live.forget(face)  # the live effect goes on without the keys this bake added


def _value_path(name: str) -> str:
    return f'key_blocks["{name}"].value'


def _remove_baked_keys(face, names: list[str], drop_action: bool) -> None:
    """Remove baked shape keys; `drop_action`: the bake's action goes too, else only their F-curves do."""
    key = face.data.shape_keys
    anim = key.animation_data
    action = anim.action if anim is not None else None
    if action is not None and drop_action:
        anim.action = None
        if action.users == 0:
            bpy.data.actions.remove(action)
        action = None
    for name in names:
        block = key.key_blocks.get(name)
        if block is None:
            continue
        fcurve = animation.find_fcurve(key, _value_path(name), 0) if action is not None else None
        if fcurve is not None:
            for frame in [point.co[0] for point in fcurve.keyframe_points]:
                key.keyframe_delete(_value_path(name), frame=frame)  # the curve goes with its last key
        face.shape_key_remove(block)


def _remove_created_basis(face) -> None:
    mesh = face.data
    if mesh.get(CREATED_BASIS_PROP) and mesh.shape_keys is not None and len(mesh.shape_keys.key_blocks) == 1:
        face.shape_key_remove(mesh.shape_keys.key_blocks[0])
    if CREATED_BASIS_PROP in mesh:
        del mesh[CREATED_BASIS_PROP]


def bake_shape_keys(context, face, frames: Sequence[int]) -> list[str]:
    return run(context, ShapeKeyBake(context, face, frames))


# ----------------------------------------------------------------------------- point cache (and Alembic)


class PointCacheBake(Bake):
    """Frames streamed into a .pc2 file read by a Mesh Cache modifier; with `export_alembic` Blender's
    Alembic exporter then writes the baked face to `alembic_path` (default: the cache's name, .abc).
    Both files are renamed into place only when everything succeeded."""

    def __init__(
        self,
        context,
        face,
        frames: Sequence[int],
        path: str | None = None,
        export_alembic: bool = False,
        alembic_path: str | None = None,
    ):
        super().__init__(context, face, frames)
        if not path:
            if not bpy.data.filepath:
                raise Mpeg4Error("save the .blend first (the cache goes next to it) or give a cache file path")
            path = f"//{bpy.path.clean_name(face.name)}_mpeg4.pc2"
        self.path = path
        self.alembic_path = (alembic_path or os.path.splitext(path)[0] + ".abc") if export_alembic else None
        if self.alembic_path:
            self.finishing = "exporting Alembic"
        for target in (self.path, self.alembic_path):
            folder = os.path.dirname(bpy.path.abspath(target)) if target else "."
            if not os.path.isdir(folder or "."):
                raise Mpeg4Error(f"folder does not exist: {folder}")
        start = float(frames[0])
        self._writer = PointCacheWriter(bpy.path.abspath(path), len(face.data.vertices), len(frames), start)
        self._alembic_temp: str | None = None
        self._modifier_before: tuple | None = None  # the cache modifier's settings before `finish` set it
        self._modifier_set = False

    def _store(self, face, frame: int, positions: np.ndarray) -> None:
        self._writer.write(positions)

    def _finish(self, face) -> list[str]:
        self._writer.close()
        # the modifier reads the complete cache under its temporary name until the Alembic export is done
        self._use_cache(face, self._writer.temp_path)
        notes = [f"baked {len(self.frames)} frames to {bpy.path.abspath(self.path)}; live deformation turned off"]
        if self.alembic_path:
            self._alembic_temp = _temporary_file(bpy.path.abspath(self.alembic_path))
            _export_alembic(face, self.frames, self._alembic_temp)
            os.replace(self._alembic_temp, bpy.path.abspath(self.alembic_path))
            self._alembic_temp = None
            notes.append(f"exported the baked face to {bpy.path.abspath(self.alembic_path)}")
        self._writer.commit()
        face.modifiers[CACHE_MODIFIER].filepath = self.path
        return notes

    def _use_cache(self, face, filepath: str) -> None:
        """Turn the live effect off and read `filepath` with the Mesh Cache modifier, first in the stack."""
        mod = face.modifiers.get(CACHE_MODIFIER)
        if mod is not None:
            index = face.modifiers.find(mod.name)
            self._modifier_before = (index, mod.cache_format, mod.filepath, mod.frame_start, mod.frame_scale)
        self._modifier_set = True
        face.mpeg4_face.enabled = False
        if mod is None:
            mod = face.modifiers.new(CACHE_MODIFIER, "MESH_CACHE")
        mod.cache_format = "PC2"
        mod.filepath = filepath
        mod.frame_start = float(self.frames[0])
        mod.frame_scale = 1.0
        face.modifiers.move(face.modifiers.find(mod.name), 0)

    def _discard(self) -> None:
        self._writer.discard()
        if self._alembic_temp is not None:
            if os.path.exists(self._alembic_temp):
                os.remove(self._alembic_temp)
            self._alembic_temp = None
        face = bpy.data.objects.get(self.face_name)
        if not self._modifier_set or face is None:
            return
        self._modifier_set = False
        mod = face.modifiers.get(CACHE_MODIFIER)
        if mod is not None and self._modifier_before is None:
            face.modifiers.remove(mod)
        elif mod is not None:
            index, mod.cache_format, mod.filepath, mod.frame_start, mod.frame_scale = self._modifier_before
            face.modifiers.move(face.modifiers.find(mod.name), index)
        face.mpeg4_face.enabled = True


def _temporary_file(path: str) -> str:
    """An empty file next to `path` to write it under (renamed into place when complete)."""
    fd, temp = tempfile.mkstemp(prefix=f".{os.path.basename(path)}.", suffix=TEMP_SUFFIX, dir=os.path.dirname(path))
    os.close(fd)
    return temp


def _export_alembic(face, frames: Sequence[int], filepath: str) -> None:
    """Blender's Alembic exporter on the face and the eyes, teeth and tongue that follow it (selected for it)."""
    view_layer = bpy.context.view_layer
    objects = [face, *(ob for ob in face.children if followers.DRIVER_TAG in ob)]
    selected = [ob for ob in view_layer.objects if ob.select_get()]
    active = view_layer.objects.active
    try:
        for ob in selected:
            ob.select_set(False)
        for ob in objects:
            ob.select_set(True)
        result = bpy.ops.wm.alembic_export(filepath=filepath, start=frames[0], end=frames[-1], selected=True)
    except RuntimeError as exc:
        raise Mpeg4Error(f"Alembic export failed: {' '.join(str(exc).split()).removeprefix('Error: ')}") from exc
    finally:
        for ob in objects:
            ob.select_set(False)
        for ob in selected:
            ob.select_set(True)
        view_layer.objects.active = active
    if result != {"FINISHED"} or os.path.getsize(filepath) == 0:
        raise Mpeg4Error("Blender's Alembic exporter wrote nothing")


def bake_point_cache(
    context, face, frames: Sequence[int], path: str | None = None, export_alembic: bool = False
) -> list[str]:
    return run(context, PointCacheBake(context, face, frames, path, export_alembic))


def remove_bakes(face) -> list[str]:
    """Remove what baking added: the Mesh Cache modifier, the baked shape keys, their action, a Basis it made."""
    notes = []
    mod = face.modifiers.get(CACHE_MODIFIER)
    if mod is not None:
        face.modifiers.remove(mod)
        notes.append("removed the point cache modifier (the .pc2 file stays on disk)")
    key = face.data.shape_keys
    if key is None:
        return notes
    baked = [block.name for block in key.key_blocks if block.name.startswith(BAKED_KEY_PREFIX)]
    anim = key.animation_data
    ours = anim is not None and anim.action is not None and CREATED_PROP in anim.action
    _remove_baked_keys(face, baked, drop_action=ours)
    _remove_created_basis(face)
    if baked:
        notes.append(f"removed {len(baked)} baked shape keys")
    return notes
