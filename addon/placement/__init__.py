"""Automatic feature point placement: a user's mesh -> orientation, scale, mid-plane -> the template aligned
and registered -> FPs transferred, refined, with confidences (no bpy)."""
