"""The one exception base for problems a user can cause and fix (a bad file, missing feature points, a
mesh that cannot be bound). Its message is written for the user; the Blender layer turns it into a
report in one place (`blender/reporting.py`). Anything else that escapes is a bug."""


class Mpeg4Error(ValueError):
    """A problem with the user's input or data; `str(error)` says what is wrong and how to fix it."""
