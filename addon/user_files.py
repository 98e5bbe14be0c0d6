"""Reading a file a user named, safely: only a regular file, and never more than a cap (no bpy).

A FIFO (opening one waits for a writer), a device (/dev/zero never ends) or a folder is refused before it is
opened; the open is non-blocking and re-checked with fstat, so a FIFO swapped in between cannot block either.
The file's size is a hint only (a file may grow; /proc files claim 0): at most `max_bytes + 1` bytes are read.
A path that another reader opens (an image, a sound) or that is written is checked by `file_problem` and
`output_problem`, which give the reason (a name over NAME_MAX bytes among them) instead of raising.
"""

from __future__ import annotations

import os
import stat

from .errors import Mpeg4Error

_FILE_KINDS = (
    (stat.S_ISDIR, "a directory"),
    (stat.S_ISFIFO, "a named pipe (FIFO)"),
    (stat.S_ISCHR, "a character device"),
    (stat.S_ISBLK, "a block device"),
    (stat.S_ISSOCK, "a socket"),
)
# O_NONBLOCK changes nothing for a regular file; for a FIFO it makes the open return at once
_OPEN_FLAGS = os.O_RDONLY | getattr(os, "O_BINARY", 0) | getattr(os, "O_NONBLOCK", 0)


class _Unreadable(Exception):
    """Why the file cannot be read, without naming it; `too_large` marks the size cap."""

    def __init__(self, problem: str, too_large: bool = False):
        super().__init__(problem)
        self.problem = problem
        self.too_large = too_large


def _not_regular(mode: int) -> _Unreadable:
    kind = next((name for is_kind, name in _FILE_KINDS if is_kind(mode)), "a special file")
    return _Unreadable(f"not a regular file but {kind}")


def read_regular_file(path, max_bytes: int, error: type[Mpeg4Error], name: str, too_large: str) -> bytes:
    """The bytes of the regular file `path`, at most `max_bytes` of them. Otherwise `error` (the reader's own
    Mpeg4Error) with the message "`name`: why", where `too_large` says why for a file over the cap."""
    try:
        return _read(path, max_bytes)
    except _Unreadable as exc:
        raise error(f"{name}: {too_large if exc.too_large else exc.problem}") from None


def _read(path, max_bytes: int) -> bytes:
    try:
        mode = os.stat(path).st_mode
        fd = os.open(path, _OPEN_FLAGS) if stat.S_ISREG(mode) else None
    except (OSError, ValueError) as exc:  # ValueError: a path with a NUL character
        raise _Unreadable(f"cannot read the file: {exc}") from None
    if fd is None:
        raise _not_regular(mode)
    try:
        with open(fd, "rb") as file:
            info = os.fstat(fd)
            if not stat.S_ISREG(info.st_mode):
                raise _not_regular(info.st_mode)
            if info.st_size > max_bytes:
                raise _Unreadable("too large", too_large=True)
            data = file.read(info.st_size + 1)
            if len(data) > info.st_size:
                data += file.read(max_bytes + 1 - len(data))
    except OSError as exc:
        raise _Unreadable(f"cannot read the file: {exc}") from None
    if len(data) > max_bytes:
        raise _Unreadable("too large", too_large=True)
    return data


NAME_MAX = 255  # bytes of one path component on the file systems Blender runs on


def file_problem(path) -> str | None:
    """Why `path` is not a regular file that could be read (missing, a special file, a name too long), or None;
    for a file that is opened later by another reader (an image, a sound), without opening it."""
    try:
        mode = os.stat(path).st_mode
    except (OSError, ValueError) as exc:
        return f"cannot read the file: {getattr(exc, 'strerror', None) or exc}"
    return None if stat.S_ISREG(mode) else _not_regular(mode).problem


def output_problem(path) -> str | None:
    """Why a file could not be written at `path` whatever the folder holds (a name longer than NAME_MAX bytes,
    a NUL character), or None."""
    text = os.fspath(path)
    if "\0" in text:
        return "the path holds a NUL character"
    long = next((part for part in text.split(os.sep) if len(part.encode("utf-8", "surrogateescape")) > NAME_MAX), None)
    if long is not None:
        return f"the name {long[:20]}... is longer than {NAME_MAX} bytes"
    return None
