"""Small geometric building blocks shared by set-up and fitting (no bpy)."""
