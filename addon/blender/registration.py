"""Register and unregister everything, in one place; unregister mirrors register step by step."""

import bpy

from . import (
    arkit_ops,
    auto_placement_ops,
    elastic_ops,
    fitting_ops,
    live,
    menus,
    ops,
    panel,
    properties,
    speech_ops,
    voice_ops,
)

CLASSES = (
    *properties.CLASSES,
    *ops.CLASSES,
    *elastic_ops.CLASSES,
    *speech_ops.CLASSES,
    *voice_ops.CLASSES,
    *fitting_ops.CLASSES,
    *arkit_ops.CLASSES,
    *auto_placement_ops.CLASSES,
    *menus.CLASSES,
    *panel.CLASSES,
)
HANDLERS = (
    (bpy.app.handlers.frame_change_post, live.on_frame_change),
    (bpy.app.handlers.depsgraph_update_post, live.on_depsgraph_update),
    (bpy.app.handlers.load_post, live.on_load_post),
    (bpy.app.handlers.undo_post, live.on_undo_redo),
    (bpy.app.handlers.redo_post, live.on_undo_redo),
)


def _remove_handler(handlers, function):
    # compare by name: a reloaded module brings new function objects
    same = [
        h
        for h in handlers
        if (getattr(h, "__name__", None), getattr(h, "__module__", None)) == (function.__name__, function.__module__)
    ]
    for existing in same:
        handlers.remove(existing)


def register():
    for cls in CLASSES:
        bpy.utils.register_class(cls)
    properties.register_properties()
    for menu, entry in menus.MENU_ENTRIES:
        menu.append(entry)
    for handlers, function in HANDLERS:
        _remove_handler(handlers, function)
        handlers.append(function)


def unregister():
    for handlers, function in reversed(HANDLERS):
        _remove_handler(handlers, function)
    for menu, entry in reversed(menus.MENU_ENTRIES):
        menu.remove(entry)
    properties.unregister_properties()
    for cls in reversed(CLASSES):
        bpy.utils.unregister_class(cls)
    live.forget()
