"""MPEG-4 facial animation with Planar Bones, as a Blender extension.

Only the Blender side (`blender/`) imports bpy, and only when Blender registers the extension,
so the numerical core (`mpeg4/`, `deform/`) stays importable and testable without Blender.
"""


def register():
    from .blender import registration

    registration.register()


def unregister():
    from .blender import registration

    registration.unregister()
