"""Shared test set-up: the repository root on sys.path so `import addon` works, and a private Blender
user folder so tests never read or write the real user's preferences and extensions."""

import os
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

# must be set before bpy is first imported
os.environ.setdefault("BLENDER_USER_RESOURCES", tempfile.mkdtemp(prefix="mpeg4-blender-user-"))
