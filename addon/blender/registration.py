"""Register and unregister everything, in one place; unregister mirrors register step by step."""

import bpy

from . import live, ops, panel, properties

CLASSES = (*properties.CLASSES, *ops.CLASSES, *panel.CLASSES)
HANDLERS = (
    (bpy.app.handlers.frame_change_post, live.on_frame_change),
    (bpy.app.handlers.depsgraph_update_post, live.on_depsgraph_update),
    (bpy.app.handlers.load_post, live.on_load_post),
)


def _remove_handler(handlers, function):
    # compare by name: a reloaded module brings new function objects
    for existing in [
        h
        for h in handlers
        if getattr(h, "__name__", None) == function.__name__ and getattr(h, "__module__", None) == function.__module__
    ]:
        handlers.remove(existing)


def register():
    for cls in CLASSES:
        bpy.utils.register_class(cls)
    properties.register_properties()
    bpy.types.TOPBAR_MT_file_import.append(ops.menu_import)
    bpy.types.TOPBAR_MT_file_export.append(ops.menu_export)
    for handlers, function in HANDLERS:
        _remove_handler(handlers, function)
        handlers.append(function)


def unregister():
    for handlers, function in reversed(HANDLERS):
        _remove_handler(handlers, function)
    bpy.types.TOPBAR_MT_file_export.remove(ops.menu_export)
    bpy.types.TOPBAR_MT_file_import.remove(ops.menu_import)
    properties.unregister_properties()
    for cls in reversed(CLASSES):
        bpy.utils.unregister_class(cls)
    live.forget()
