"""Blender's Surface Deform modifier bound headless to a control mesh, for the comparison scripts.

`SurfaceDeform.bind` puts the modifier on a copy of a mesh object, binds it to a triangle control mesh
with `bpy.ops.object.surfacedeform_bind` inside `context.temp_override` and checks `modifier.is_bound`
(the operator returns FINISHED even when the bind fails; the reason only reaches Blender's log, which
is captured here). Surface Deform refuses a whole bind when one vertex sees a collinear or degenerate
configuration ("Target contains invalid polygons"), which symmetric faces over a symmetric FP
triangulation can hit; the helper then says so and retries once with the control mesh jittered by
`JITTER` metres. Positions go in and out as float32 through the `position` attribute, Blender's fast path.
"""

import os
import sys
import tempfile
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass

import bpy
import numpy as np

JITTER = 1e-6  # metres; far below the 0.1 mm scale of any facial detail


class SurfaceDeformError(RuntimeError):
    """Surface Deform would not bind, even after the jitter retry."""


def control_object(name: str, points: np.ndarray, triangles: np.ndarray) -> bpy.types.Object:
    """A triangle mesh object with these (M, 3) points and (T, 3) triangles, linked to the scene."""
    mesh = bpy.data.meshes.new(name)
    mesh.from_pydata(np.asarray(points, dtype=np.float64).tolist(), [], np.asarray(triangles).tolist())
    mesh.validate()
    obj = bpy.data.objects.new(name, mesh)
    bpy.context.scene.collection.objects.link(obj)
    return obj


def copy_object(source: bpy.types.Object, name: str) -> bpy.types.Object:
    """An unparented copy of `source` with its own mesh data and no modifiers, at the same world place."""
    obj = bpy.data.objects.new(name, source.data.copy())
    bpy.context.scene.collection.objects.link(obj)
    obj.matrix_world = source.matrix_world.copy()
    return obj


def write_positions(mesh: bpy.types.Mesh, positions: np.ndarray) -> None:
    """Set the (N, 3) vertex positions from a C-contiguous float32 buffer and tag the mesh."""
    mesh.attributes["position"].data.foreach_set("vector", positions.reshape(-1))
    mesh.update()


def read_positions(mesh: bpy.types.Mesh, out: np.ndarray) -> np.ndarray:
    """Fill the (N, 3) float32 `out` with the mesh's vertex positions."""
    mesh.attributes["position"].data.foreach_get("vector", out.reshape(-1))
    return out


@dataclass
class SurfaceDeform:
    """A copy of a mesh deformed by Surface Deform from a control mesh object."""

    obj: bpy.types.Object
    control: bpy.types.Object
    modifier: bpy.types.SurfaceDeformModifier
    control_offset: np.ndarray  # (M, 3) float32 jitter added to every control position (0 if none)
    log: list[str]  # what Surface Deform reported while binding

    @property
    def jittered(self) -> bool:
        return bool(self.control_offset.any())

    @classmethod
    def bind(
        cls,
        source: bpy.types.Object,
        control: bpy.types.Object,
        name: str = "Surface Deform",
        report: Callable[[str], None] = print,
        seed: int = 0,
    ) -> "SurfaceDeform":
        """Bind a copy of `source` to `control` (both in the same frame, control in its rest pose)."""
        obj = copy_object(source, name)
        modifier = obj.modifiers.new("Surface Deform", "SURFACE_DEFORM")
        modifier.target = control
        n_control = len(control.data.vertices)
        offset = np.zeros((n_control, 3), np.float32)
        log = _bind(obj, modifier)
        if not modifier.is_bound:
            reason = "; ".join(log) or "no reason logged"
            report(
                f"Surface Deform refused to bind {source.name!r} to {control.name!r} ({reason}); "
                f"retrying with the control mesh jittered by {JITTER:g} m"
            )
            rest = read_positions(control.data, np.empty((n_control, 3), np.float32))
            offset = np.random.default_rng(seed).uniform(-JITTER, JITTER, (n_control, 3)).astype(np.float32)
            write_positions(control.data, rest + offset)
            retry = _bind(obj, modifier)
            log += retry
            if not modifier.is_bound:
                raise SurfaceDeformError(
                    f"Surface Deform did not bind even with a {JITTER:g} m jitter: "
                    + ("; ".join(retry) or "no reason logged")
                )
            report(f"Surface Deform bound after jittering the control mesh by {JITTER:g} m")
        return cls(obj, control, modifier, offset, log)

    def move_control(self, positions: np.ndarray) -> None:
        """Move the control mesh to (M, 3) positions (float32 or float64), keeping the bind jitter."""
        write_positions(self.control.data, (positions + self.control_offset).astype(np.float32))

    def read_deformed(self, depsgraph: bpy.types.Depsgraph, out: np.ndarray) -> np.ndarray:
        """The evaluated (deformed) positions into the (N, 3) float32 `out`; the depsgraph must be current."""
        return read_positions(self.obj.evaluated_get(depsgraph).data, out)


def _bind(obj: bpy.types.Object, modifier: bpy.types.SurfaceDeformModifier) -> list[str]:
    """Bind and evaluate; the warnings Blender logged.

    The operator toggles: after a failed bind the next call only clears the stale bind data (it logs
    nothing and leaves the modifier unbound), so a silent unbound result is followed by one more call.
    """
    for _ in range(2):
        with _captured_output() as captured:
            with bpy.context.temp_override(object=obj, active_object=obj):
                bpy.ops.object.surfacedeform_bind(modifier=modifier.name)
            bpy.context.view_layer.update()
        prefix = f'Modifier: "{modifier.name}", '
        lines = [line.split(prefix, 1)[-1] for line in captured if "WARNING" in line]
        if modifier.is_bound or lines:
            break
    return list(dict.fromkeys(lines))


@contextmanager
def _captured_output() -> Iterator[list[str]]:
    """Capture what Blender's C code writes to stdout and stderr (its log) at the file-descriptor level."""
    lines: list[str] = []
    sys.stdout.flush()
    sys.stderr.flush()
    saved = [os.dup(1), os.dup(2)]
    with tempfile.TemporaryFile() as file:
        os.dup2(file.fileno(), 1)
        os.dup2(file.fileno(), 2)
        try:
            yield lines
        finally:
            sys.stdout.flush()
            sys.stderr.flush()
            for fd, copy in zip((1, 2), saved, strict=True):
                os.dup2(copy, fd)
                os.close(copy)
            file.seek(0)
            lines.extend(file.read().decode("utf-8", "replace").splitlines())
