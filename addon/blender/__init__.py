"""The Blender side: properties, operators, panel, handlers and importers. Everything here may import bpy."""
