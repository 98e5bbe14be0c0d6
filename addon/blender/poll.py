"""Why an operator cannot run now (the text its poll shows), and the face an operator acts on.

Shared by every operator module; it sits below them all (face_data, binding_store), so none of them has
to import another's private checks.
"""

from ..errors import Mpeg4Error
from . import binding_store, face_data


def face(context):
    """The face the user means; Mpeg4Error when there is none."""
    found = face_data.active_face(context)
    if found is None:
        raise Mpeg4Error("select the face mesh (or one of its feature point empties) first")
    return found


def no_face(context) -> str | None:
    found = face_data.active_face(context)
    if found is None:
        return "Select the face mesh (or one of its feature point empties) first"
    if found.mode != "OBJECT":
        return f"{found.name} is in {found.mode.title().replace('_', ' ')} Mode: go back to Object Mode"
    return None


def not_set_up(context) -> str | None:
    reason = no_face(context)
    if reason is None and not binding_store.is_bound(face_data.active_face(context)):
        return f"{face_data.active_face(context).name} is not set up: run Set Up Face first"
    return reason
