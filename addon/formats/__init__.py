"""File formats other than MPEG-4's own (no bpy)."""
