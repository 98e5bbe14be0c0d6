"""ARKit capture files in and out (no bpy): Live Link Face CSV, NVIDIA Audio2Face JSON, plain CSV/JSON.

Formats, as their producers describe them:

- Live Link Face CSV: a header `Timecode,BlendShapeCount,EyeBlinkLeft,...,TongueOut,HeadYaw,HeadPitch,HeadRoll,
  LeftEyeYaw,LeftEyePitch,LeftEyeRoll,RightEyeYaw,RightEyePitch,RightEyeRoll` (the 52 names in PascalCase),
  then one row per captured frame: timecode `HH:MM:SS:FF.fff` (FF the frame of the timecode's rate, .fff a
  fraction of it), the count of values after it, the values. Readings chosen: the timecode's rate is 60 when
  any FF is 30 or more, else 30 (`timecode_fps` overrides); the capture's own rate is the nearest whole
  rate to its median frame step (a 60 fps take on a 30 fps timecode steps by half frames). Head and eye
  angles are radians about ARKit's face axes (x toward the face's left, y up, z out of the face), which are
  MPEG-4's: yaw about +y, pitch about +x, roll about +z, so they carry over with their signs. Eye roll has
  no FAP and is read and dropped.
- Audio2Face JSON (blendshape solve export): `{"exportFps", "numPoses", "numFrames", "facsNames": [...],
  "weightMat": [[one weight per pose] per frame]}`; other keys (trackPath, ...) are ignored.
- plain CSV: a header of ARKit names (camelCase or PascalCase, any subset; MediaPipe's `_neutral` is
  ignored), optionally a first column `time` (seconds) or `frame`; one row per frame; without time the
  frame rate is the caller's `fps`.
- plain JSON: `{"fps": 30, "frames": [...]}` where each frame is `{name: weight}` or MediaPipe's list of
  `{"categoryName": name, "score": weight}`.

Every value is checked before anything is returned. A wrong header, an unknown name, a row of the wrong
length, a value that is not a finite number, a weight outside 0..1 by more than `WEIGHT_TOLERANCE`, times
that do not increase, more than `MAX_FRAMES` frames, a file over `MAX_FILE_BYTES`, NUL or non-UTF-8 bytes
raise `ArkitError` naming the file and the line (CSV) or frame (JSON). Weights within the tolerance are
clipped into 0..1 (solvers overshoot a little).
"""

from __future__ import annotations

import json
import math
import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..mpeg4.stream_timing import MAX_STREAM_FPS, MIN_STREAM_FPS
from ..user_files import read_regular_file
from . import ArkitError
from .recipes import ARKIT_INDEX, ARKIT_NAMES, N_SHAPES

MAX_FILE_BYTES = 256 * 2**20  # as for .fap
MAX_FRAMES = 1_000_000  # 4.6 hours at 60 fps; a capture this long is a mistake, not a take
MAX_LINE_CHARS = 8192  # as for .fap: a Live Link row is under 1,000
WEIGHT_TOLERANCE = 0.01
ANGLE_LIMIT = math.pi  # |head or eye angle| beyond half a turn is not a measurement
_QUOTE = 40

LIVE_LINK_ROTATIONS = (
    "HeadYaw", "HeadPitch", "HeadRoll", "LeftEyeYaw", "LeftEyePitch", "LeftEyeRoll",
    "RightEyeYaw", "RightEyePitch", "RightEyeRoll",
)  # fmt: skip
_BY_LOWER = {name.lower(): name for name in ARKIT_NAMES}
_NUMBER = re.compile(r"[ \t]*[-+]?(?:[0-9]+\.?[0-9]*|\.[0-9]+)(?:[eE][-+]?[0-9]+)?[ \t]*", re.ASCII)
_TIMECODE = re.compile(r"(\d{1,2}):(\d{2}):(\d{2})[:;](\d{1,3})(?:\.(\d{1,6}))?")


@dataclass(frozen=True, eq=False)
class Capture:
    """An ARKit capture: 52 weights per frame (ARKIT_NAMES order, 0..1), optionally the head's and eyes' turns."""

    name: str
    fps: float
    frame_numbers: np.ndarray  # (F,) int64, strictly increasing; time = frame_number / fps
    weights: np.ndarray  # (F, 52)
    head: np.ndarray | None = None  # (F, 3) pitch, yaw, roll in radians (MPEG-4 FAP 48-50 order)
    eyes: np.ndarray | None = None  # (F, 4) left yaw, right yaw, left pitch, right pitch in radians (FAP 23-26)
    present: tuple[str, ...] = ARKIT_NAMES  # the names the file had

    @property
    def n_frames(self) -> int:
        return len(self.frame_numbers)


def _quote(value) -> str:
    """A value as a message shows it: text quoted and cut to `_QUOTE` characters, other values as JSON has them."""
    if not isinstance(value, str):
        value = json.dumps(value)
        return value if len(value) <= _QUOTE else value[:_QUOTE] + "..."
    return repr(value if len(value) <= _QUOTE else value[:_QUOTE] + "...")


def arkit_name(label: str) -> str | None:
    """The ARKit name for a column label in camelCase or PascalCase (None if it is not one)."""
    return _BY_LOWER.get(label.strip().lower()) if label.strip()[:1].isalpha() else None


def _text(path, what: str) -> tuple[str, str]:
    source = Path(path).name
    data = read_regular_file(
        path, MAX_FILE_BYTES, ArkitError, f"{source}: the {what}", f"larger than {MAX_FILE_BYTES // 2**20} MiB"
    )
    if b"\0" in data:
        raise ArkitError(f"{source}: the {what} holds NUL bytes: it is not a text file")
    try:
        return data.decode("utf-8").removeprefix("\ufeff"), source
    except UnicodeDecodeError as exc:
        raise ArkitError(f"{source}: the {what} is not UTF-8 text (byte {exc.start})") from None


def read_capture(path, fps: float = 30.0, timecode_fps: float | None = None) -> Capture:
    """Any of the four formats, told apart by content: JSON with `weightMat` is Audio2Face, other JSON plain;
    CSV starting with `Timecode` is Live Link Face, other CSV plain. `fps` times files that carry no time."""
    text, source = _text(path, "capture")
    name = Path(path).stem
    if text.lstrip().startswith(("{", "[")):
        doc = _json(text, source)
        if isinstance(doc, dict) and "weightMat" in doc:
            return _audio2face(doc, source, name)
        return _plain_json(doc, source, name)
    lines = _lines(text, source)
    if lines[0][1].split(",")[0].strip().lower() == "timecode":
        return _live_link(lines, source, name, timecode_fps)
    return _plain_csv(lines, source, name, fps)


# --- CSV -----------------------------------------------------------------------------------------------


def _lines(text: str, source: str) -> list[tuple[int, str]]:
    """(line number, text) of the non-blank lines; the caps on line length and frame count checked first."""
    raw = text.splitlines()
    if len(raw) > MAX_FRAMES + 1 and sum(1 for line in raw if line.strip()) > MAX_FRAMES + 1:
        raise ArkitError(f"{source}: more than {MAX_FRAMES:,} frames: split the capture")
    lines = []
    for number, line in enumerate(raw, start=1):
        if len(line) > MAX_LINE_CHARS:
            raise ArkitError(f"{source}: line {number}: longer than {MAX_LINE_CHARS} characters")
        if line.strip():
            lines.append((number, line))
    if not lines:
        raise ArkitError(f"{source}: the file is empty")
    return lines


def _rows(lines: list[tuple[int, str]], width: int, source: str) -> np.ndarray:
    """The data rows (after the header) as an (F, width) float array; every cell a finite number."""
    if len(lines) < 2:
        raise ArkitError(f"{source}: the header has no frames after it")
    for number, line in lines[1:]:
        if line.count(",") != width - 1:
            raise ArkitError(f"{source}: line {number}: {line.count(',') + 1} values, the header has {width} columns")
    try:  # all cells in numpy's C reader; a bad one is found and named below
        values = np.loadtxt([line for _number, line in lines[1:]], delimiter=",", comments=None, ndmin=2)
    except ValueError:
        values = np.zeros((0, width))
    if values.shape == (len(lines) - 1, width) and np.all(np.isfinite(values)):
        return values
    for number, line in lines[1:]:
        for cell in line.split(","):
            if _NUMBER.fullmatch(cell) is None or not math.isfinite(float(cell)):
                raise ArkitError(f"{source}: line {number}: {_quote(cell.strip())} is not a finite number")
    raise ArkitError(f"{source}: a number is out of range")  # every cell looks like a number: one overflowed


def _columns(header: list[str], number: int, source: str, allowed: dict[str, str]) -> list[tuple[int, str]]:
    """(column, ARKit name or an allowed extra) for each header cell; unknown or repeated names are errors."""
    out, seen = [], set()
    for column, label in enumerate(header):
        name = arkit_name(label) or allowed.get(label.strip().lower())
        if name is None:
            raise ArkitError(f"{source}: line {number}: unknown column {_quote(label.strip())} (not an ARKit name)")
        if name in seen:
            raise ArkitError(f"{source}: line {number}: column {name} appears twice")
        seen.add(name)
        out.append((column, name))
    if not any(name in ARKIT_INDEX for _column, name in out):
        raise ArkitError(f"{source}: line {number}: the header names none of ARKit's 52 blendshapes")
    return out


def _weights(values: np.ndarray, columns, lines, source: str) -> np.ndarray:
    """The (F, 52) weights from the named columns (0 where a name is absent), checked and clipped."""
    weights = np.zeros((len(values), N_SHAPES))
    for column, name in columns:
        if name in ARKIT_INDEX:
            weights[:, ARKIT_INDEX[name]] = values[:, column]
            _check_weights(values[:, column], name, lambda row: f"line {lines[row + 1][0]}", source)
    return np.clip(weights, 0.0, 1.0)


def _check_weights(column: np.ndarray, name: str, where, source: str) -> None:
    bad = np.flatnonzero((column < -WEIGHT_TOLERANCE) | (column > 1.0 + WEIGHT_TOLERANCE))
    if len(bad):
        row = int(bad[0])
        raise ArkitError(f"{source}: {where(row)}: {name} = {column[row]:g} is outside 0..1")


def _check_angles(values: np.ndarray, names, lines, source: str) -> None:
    bad = np.argwhere(np.abs(values) > ANGLE_LIMIT)
    if len(bad):
        row, column = (int(v) for v in bad[0])
        raise ArkitError(
            f"{source}: line {lines[row + 1][0]}: {names[column]} = {values[row, column]:g} is not an angle in "
            "radians (more than half a turn)"
        )


def _frames_from_times(times: np.ndarray, fps: float, where, source: str) -> np.ndarray:
    """Frame numbers at `fps` for increasing `times` (seconds); two rows on one frame are an error."""
    steps = np.diff(times)
    bad = np.flatnonzero(steps <= 0.0)
    if len(bad):
        raise ArkitError(f"{source}: {where(int(bad[0]) + 1)}: its time does not come after the previous row's")
    frames = np.round((times - times[0]) * fps).astype(np.int64)
    same = np.flatnonzero(np.diff(frames) <= 0)
    if len(same):
        raise ArkitError(f"{source}: {where(int(same[0]) + 1)}: falls on the same {fps:g} fps frame as the row before")
    return frames


def _check_fps(fps, where: str, source: str) -> float:
    if isinstance(fps, bool) or not isinstance(fps, int | float) or not MIN_STREAM_FPS <= fps <= MAX_STREAM_FPS:
        span = f"{MIN_STREAM_FPS:g} to {MAX_STREAM_FPS:g}"
        raise ArkitError(f"{source}: {where}: the frame rate {_quote(fps)} is not a number from {span}")
    return float(fps)


def _live_link(lines, source: str, name: str, timecode_fps: float | None) -> Capture:
    number, header_line = lines[0]
    header = [cell.strip() for cell in header_line.split(",")]
    if len(header) < 3 or header[1].lower() != "blendshapecount":
        raise ArkitError(f"{source}: line {number}: a Live Link Face header starts Timecode,BlendShapeCount")
    extras = {label.lower(): label for label in LIVE_LINK_ROTATIONS}
    columns = _columns(header[2:], number, source, extras)
    timecodes, counts = [], []
    cells = []
    for row_number, line in lines[1:]:
        stamp, _, rest = line.partition(",")
        count, _, rest = rest.partition(",")
        match = _TIMECODE.fullmatch(stamp.strip())
        if match is None:
            raise ArkitError(f"{source}: line {row_number}: timecode {_quote(stamp.strip())} is not HH:MM:SS:FF.fff")
        timecodes.append([float(v) for v in match.groups()[:4]] + [float(f"0.{match[5] or 0}")])
        counts.append(count.strip())
        cells.append((row_number, rest))
    values = _rows([lines[0], *cells], len(header) - 2, source)
    for (row_number, _rest), count in zip(cells, counts, strict=True):
        if count != str(len(header) - 2):
            values_after = len(header) - 2
            raise ArkitError(f"{source}: line {row_number}: BlendShapeCount {_quote(count)} but {values_after} follow")
    parts = np.array(timecodes)
    rate = timecode_fps or (60.0 if parts[:, 3].max() >= 30 else 30.0)
    times = parts[:, 0] * 3600.0 + parts[:, 1] * 60.0 + parts[:, 2] + (parts[:, 3] + parts[:, 4]) / rate
    fps = rate
    if len(times) > 1:
        step = float(np.median(np.diff(times)))
        fps = float(round(1.0 / step)) if step > 0 else rate
    where = lambda row: f"line {lines[row + 1][0]}"  # noqa: E731
    frames = _frames_from_times(times, fps, where, source)
    weights = _weights(values, columns, lines, source)
    named = {label: column for column, label in columns if label in LIVE_LINK_ROTATIONS}
    head = eyes = None
    if all(label in named for label in LIVE_LINK_ROTATIONS[:3]):
        head = values[:, [named["HeadPitch"], named["HeadYaw"], named["HeadRoll"]]]
        _check_angles(head, ("HeadPitch", "HeadYaw", "HeadRoll"), lines, source)
        if not np.any(head):
            head = None  # a take without head tracking: the head is left alone
    eye_names = ("LeftEyeYaw", "RightEyeYaw", "LeftEyePitch", "RightEyePitch")
    if all(label in named for label in eye_names):
        eyes = values[:, [named[label] for label in eye_names]]
        _check_angles(eyes, eye_names, lines, source)
        if not np.any(eyes):
            eyes = None  # a take without eye tracking: the eyeLook* weights say where the eyes look
    present = tuple(label for _column, label in columns if label in ARKIT_INDEX)
    return Capture(name, fps, frames, weights, head, eyes, present)


def _plain_csv(lines, source: str, name: str, fps: float) -> Capture:
    number, header_line = lines[0]
    header = header_line.split(",")
    columns = _columns(header, number, source, {"time": "time", "frame": "frame", "_neutral": "_neutral"})
    for column, label in columns:
        if label in ("time", "frame") and column != 0:
            raise ArkitError(f"{source}: line {number}: {label} must be the first column")
    values = _rows(lines, len(header), source)
    where = lambda row: f"line {lines[row + 1][0]}"  # noqa: E731
    first = columns[0][1]
    if first == "time":
        times = values[:, 0]
        steps = np.diff(times)
        if len(steps) and np.median(steps) > 0:
            fps = float(round(1.0 / float(np.median(steps)), 3))
        frames = _frames_from_times(times, fps, where, source)
    elif first == "frame":
        if not np.array_equal(values[:, 0], np.round(values[:, 0])) or values[:, 0].min() < 0:
            raise ArkitError(f"{source}: the frame column must hold whole numbers from 0")
        frames = values[:, 0].astype(np.int64)
        _frames_from_times(values[:, 0], 1.0, where, source)
    else:
        frames = np.arange(len(values), dtype=np.int64)
    fps = _check_fps(fps, "frame rate", source)
    weights = _weights(values, columns, lines, source)
    present = tuple(label for _column, label in columns if label in ARKIT_INDEX)
    return Capture(name, fps, frames, weights, present=present)


# --- JSON ----------------------------------------------------------------------------------------------


def _json(text: str, source: str):
    def reject(constant):
        raise ArkitError(f"{source}: {constant} is not a number a capture may hold")

    def pairs(items):
        keys = [key for key, _ in items]
        if len(set(keys)) != len(keys):
            repeated = next(key for key in keys if keys.count(key) > 1)
            raise ArkitError(f"{source}: key {_quote(repeated)} appears twice in one object")
        return dict(items)

    try:
        return json.loads(text, parse_constant=reject, object_pairs_hook=pairs)
    except json.JSONDecodeError as exc:
        raise ArkitError(f"{source}: line {exc.lineno}: not valid JSON: {exc.msg}") from None
    except RecursionError:
        raise ArkitError(f"{source}: the JSON is nested too deeply") from None


def _number(value, where: str, source: str) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value):
        raise ArkitError(f"{source}: {where}: {_quote(value)} is not a finite number")
    return float(value)


def _names(labels, where: str, source: str) -> list[str]:
    if not isinstance(labels, list):
        raise ArkitError(f"{source}: {where} must be a list of ARKit names")
    names = []
    for label in labels:
        name = arkit_name(label) if isinstance(label, str) else None
        if name is None and label != "_neutral":
            raise ArkitError(f"{source}: {where}: {_quote(label)} is not one of ARKit's 52 blendshape names")
        if name in names:
            raise ArkitError(f"{source}: {where}: {name} appears twice")
        names.append(name)
    return names


def _audio2face(doc: dict, source: str, name: str) -> Capture:
    missing = [key for key in ("exportFps", "facsNames", "numFrames", "weightMat") if key not in doc]
    if missing:
        raise ArkitError(f"{source}: an Audio2Face export needs {', '.join(missing)}")
    fps = _check_fps(doc["exportFps"], "exportFps", source)
    names = _names(doc["facsNames"], "facsNames", source)
    rows = doc["weightMat"]
    count = doc["numFrames"]
    if not isinstance(rows, list):
        raise ArkitError(f"{source}: weightMat must be a list of frames")
    if isinstance(count, bool) or not isinstance(count, int) or count != len(rows):
        raise ArkitError(f"{source}: numFrames is {_quote(count)} but weightMat has {len(rows)} frames")
    if "numPoses" in doc and doc["numPoses"] != len(names):
        raise ArkitError(f"{source}: numPoses is {_quote(doc['numPoses'])} but facsNames has {len(names)} names")
    return _capture(rows, names, fps, source, name, "weightMat")


def _capture(rows, names, fps: float, source: str, name: str, what: str) -> Capture:
    if not rows:
        raise ArkitError(f"{source}: {what} has no frames")
    if len(rows) > MAX_FRAMES:
        raise ArkitError(f"{source}: more than {MAX_FRAMES:,} frames: split the capture")
    for frame, row in enumerate(rows):
        if not isinstance(row, list) or len(row) != len(names):
            size = len(row) if isinstance(row, list) else type(row).__name__
            raise ArkitError(f"{source}: {what} frame {frame}: {size} values for {len(names)} names")
    numbers = all(type(value) in (int, float) for row in rows for value in row)  # JSON's numbers, not its bools
    values = np.array(rows, dtype=np.float64) if numbers else None
    if values is None or not np.all(np.isfinite(values)):
        for frame, row in enumerate(rows):
            for value in row:
                _number(value, f"{what} frame {frame}", source)
    weights = np.zeros((len(rows), N_SHAPES))
    for column, label in enumerate(names):
        if label is not None:
            _check_weights(values[:, column], label, lambda row: f"{what} frame {row}", source)
            weights[:, ARKIT_INDEX[label]] = values[:, column]
    present = tuple(label for label in names if label is not None)
    return Capture(name, fps, np.arange(len(rows), dtype=np.int64), np.clip(weights, 0.0, 1.0), present=present)


def _plain_json(doc, source: str, name: str) -> Capture:
    if not isinstance(doc, dict) or set(doc) != {"fps", "frames"}:
        raise ArkitError(f'{source}: a plain ARKit JSON is {{"fps": ..., "frames": [...]}} (or an Audio2Face export)')
    fps = _check_fps(doc["fps"], "fps", source)
    frames = doc["frames"]
    if not isinstance(frames, list):
        raise ArkitError(f"{source}: frames must be a list")
    if len(frames) > MAX_FRAMES:
        raise ArkitError(f"{source}: more than {MAX_FRAMES:,} frames: split the capture")
    seen: dict[str, int] = {}
    rows = []
    for frame, entry in enumerate(frames):
        if isinstance(entry, list):  # MediaPipe: [{"categoryName": ..., "score": ...}, ...]
            items = []
            for item in entry:
                if not isinstance(item, dict) or "categoryName" not in item or "score" not in item:
                    raise ArkitError(f"{source}: frame {frame}: a category list holds {{categoryName, score}} objects")
                items.append((item["categoryName"], item["score"]))
        elif isinstance(entry, dict):
            items = list(entry.items())
        else:
            raise ArkitError(f"{source}: frame {frame}: expected an object of name: weight")
        row = {}
        for label, value in items:
            (key,) = _names([label], f"frame {frame}", source)
            if key is not None:
                if key in row:
                    raise ArkitError(f"{source}: frame {frame}: {key} appears twice")
                row[key] = _number(value, f"frame {frame}: {key}", source)
                seen.setdefault(key, len(seen))
        rows.append(row)
    names = list(seen)
    if not names:
        raise ArkitError(f"{source}: no frame names any of ARKit's 52 blendshapes")
    table = [[row.get(label, 0.0) for label in names] for row in rows]
    return _capture(table, names, fps, source, name, "frames")


# --- writing -------------------------------------------------------------------------------------------


def live_link_header() -> list[str]:
    return ["Timecode", "BlendShapeCount", *(n[0].upper() + n[1:] for n in ARKIT_NAMES), *LIVE_LINK_ROTATIONS]


def format_live_link_csv(capture: Capture) -> str:
    """A capture as Live Link Face CSV (timecode at the capture's own rate, from 00:00:00:00)."""
    header = live_link_header()
    rate = max(1, round(capture.fps))
    out = [",".join(header)]
    rotations = np.zeros((capture.n_frames, len(LIVE_LINK_ROTATIONS)))
    if capture.head is not None:
        rotations[:, [1, 0, 2]] = capture.head  # pitch, yaw, roll -> yaw, pitch, roll
    if capture.eyes is not None:
        rotations[:, [3, 6, 4, 7]] = capture.eyes
    count = len(header) - 2
    for frame, weights, turns in zip(capture.frame_numbers, capture.weights, rotations, strict=True):
        seconds, ff = divmod(int(frame), rate)
        minutes, s = divmod(seconds, 60)
        h, m = divmod(minutes, 60)
        cells = [f"{h:02d}:{m:02d}:{s:02d}:{ff:02d}.000", str(count)]
        cells += [f"{v:.6g}" for v in weights] + [f"{v:.6g}" for v in turns]
        out.append(",".join(cells))
    return "\n".join(out) + "\n"


def write_live_link_csv(capture: Capture, path) -> None:
    Path(path).write_text(format_live_link_csv(capture), encoding="utf-8")
