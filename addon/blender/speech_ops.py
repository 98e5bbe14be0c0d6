"""Speech on a set-up face: Speak Text (espeak-ng) and Import Lip-Sync Cues, keyed like a FAP stream, with the
sound as a strip in the scene's sequencer.

The path, one function per arrow: text --espeak.synthesize--> phonemes with times + audio (one synthesis)
--espeak.speech_segments--> viseme segments (or a cue file --cue_files.read_cue_file--> segments)
--coarticulation.fap_tracks--> FAP tracks at the scene's frame rate (+ an expression layer)
--FapTracks.to_stream--> a FAP stream --fap_io.decode_stream--> checked FP positions --fap_io.key_stream--> one
action. Everything a user can get wrong (the text, the voice, a cue file, the frame range, the stream's values,
a missing espeak-ng) is checked before the WAV is written or the scene changes, so a refused run changes
nothing.

Where the WAV goes: next to the saved .blend (as a relative path); in an unsaved file, into the extension's
user folder (`bpy.utils.extension_path_user`, kept by Blender across sessions) when running as an installed
extension, else into `mpeg4_face_speech` in the system's temporary folder. The operator's Audio File option
overrides both. Its name holds a digest of the audio, so speaking the same sentence again rewrites the same
file instead of leaving a new one.

What Speak Text and the cue importer add is tagged (`face_data.CREATED_PROP`) and `remove_speech` takes it
away on Remove Set-Up: the strips, their sound data-blocks, the WAV files they wrote (when no other sound in
the file uses them), and the sequence editor if they created it. Replace (the default) also takes away the
face's earlier speech strips, whose mouth motion the new action replaces.
"""

from __future__ import annotations

import dataclasses
import hashlib
import math
import re
import tempfile
import wave
from pathlib import Path

import bpy
from bpy.props import BoolProperty, EnumProperty, FloatProperty, IntProperty, StringProperty
from bpy_extras.io_utils import ImportHelper

from ..errors import Mpeg4Error
from ..mpeg4.faps import Expression
from ..mpeg4.stream_timing import MAXFRAME
from ..speech import coarticulation, cue_files, espeak, wav
from ..speech.high_level import expression_values
from ..user_files import file_problem, output_problem
from . import fap_io, poll
from .face_data import CREATED_PROP
from .motion_options import GainAndClamp
from .reporting import Mpeg4Operator

FACE_PROP = "mpeg4_speech_face"  # on a strip: the face whose speech it is
WRITTEN_PROP = "mpeg4_written_file"  # on a sound: the WAV file we wrote for it (absolute path)
EDITOR_PROP = "mpeg4_created_sequence_editor"  # on a scene: speech created its sequence editor
USER_FOLDER = "speech"


def scene_fps(scene) -> float:
    return scene.render.fps / scene.render.fps_base


def frame_budget(scene, start_frame: int, extend: bool) -> int:
    """Frames the speech may take from `start_frame`: to Blender's last frame when the scene's range may be
    extended, else to the scene's end frame; never more than `coarticulation.MAX_SECONDS`."""
    end = MAXFRAME if extend else scene.frame_end
    if start_frame > end:
        where = f"Blender's last frame {MAXFRAME}" if extend else f"the scene's end frame {end}"
        fix = "" if extend else " (or turn on Extend Frame Range)"
        raise Mpeg4Error(f"the start frame {start_frame} is after {where}: choose an earlier start frame{fix}")
    return min(end - start_frame + 1, max(1, math.floor(coarticulation.MAX_SECONDS * scene_fps(scene))))


# ----------------------------------------------------------------------------- sequencer


def _strips(editor):
    """The top-level strips: `strips` in Blender 5.0 (and 4.4+), `sequences` before."""
    return editor.strips if hasattr(editor, "strips") else editor.sequences


def _all_strips(editor):
    return editor.strips_all if hasattr(editor, "strips_all") else editor.sequences_all


def strip_span(strip) -> tuple[int, int]:
    """(first frame, first frame after) of a strip as the sequencer shows it: `left_handle` and `right_handle` in
    Blender 5.1+, `frame_final_start` and `frame_final_end` before (deprecated in 5.1, gone in Blender 6)."""
    if hasattr(strip, "left_handle"):
        return strip.left_handle, strip.right_handle
    return strip.frame_final_start, strip.frame_final_end


def strip_content_start(strip) -> float:
    """The frame where a strip's source begins (its sound's time 0): `content_start` in Blender 5.1+,
    `frame_start` before (deprecated in 5.1, gone in Blender 6)."""
    return strip.content_start if hasattr(strip, "content_start") else strip.frame_start


def _free_channel(editor, first: int, last: int) -> int:
    """The lowest channel with no strip between frames `first` and `last`."""
    busy = {s.channel for s in _all_strips(editor) if strip_span(s)[0] <= last and strip_span(s)[1] > first}
    return next(c for c in range(1, len(busy) + 2) if c not in busy)


def add_sound_strip(scene, path, frame: int, name: str | None = None, face=None):
    """A sound strip of the file `path` starting at `frame`, on a free channel of the scene's sequencer (made if
    the scene has none); tagged so Remove Set-Up takes it (and its sound) away. Mpeg4Error, and nothing added,
    if Blender cannot read the file as sound."""
    path = Path(path).resolve()
    created_editor = scene.sequence_editor is None
    editor = scene.sequence_editor_create()
    sounds_before = set(bpy.data.sounds)
    length = max(1, math.ceil(_duration_hint(path) * scene_fps(scene)))
    channel = _free_channel(editor, frame, frame + length - 1)
    folder = Path(bpy.path.abspath("//")).resolve() if bpy.data.filepath else None
    filepath = bpy.path.relpath(str(path)) if folder is not None and folder in path.parents else str(path)
    strip = _strips(editor).new_sound(name or path.stem, filepath, channel, frame)
    sound = strip.sound
    new_sound = sound is not None and sound not in sounds_before
    if sound is None or sound.samplerate <= 0:  # audaspace could not open it: Blender adds the strip anyway
        _strips(editor).remove(strip)
        if new_sound and sound.users == 0:
            bpy.data.sounds.remove(sound)
        if created_editor:
            scene.sequence_editor_clear()
        raise Mpeg4Error(f"{path}: Blender cannot read this file as sound")
    strip[CREATED_PROP] = True
    if face is not None:
        strip[FACE_PROP] = face.name
    if new_sound:
        sound[CREATED_PROP] = True
    if created_editor:
        scene[EDITOR_PROP] = True
    return strip


def _duration_hint(path: Path) -> float:
    """The length of a WAV file in seconds (0 for other files), to choose a channel before Blender reads it."""
    try:
        with wave.open(str(path), "rb") as file:
            return file.getnframes() / file.getframerate()
    except (OSError, EOFError, wave.Error, ZeroDivisionError):
        return 0.0


def _drop_sound(sound) -> None:
    """Remove a sound speech made once no strip uses it, and the WAV it wrote once no other sound uses that."""
    if sound is None or CREATED_PROP not in sound or sound.users > 0:
        return
    written = sound.get(WRITTEN_PROP)
    bpy.data.sounds.remove(sound)
    if written:
        _unlink_unused(Path(written))


def _unlink_unused(path: Path) -> None:
    """Delete a WAV speech wrote unless a sound in the file still plays it."""
    if not any(Path(bpy.path.abspath(s.filepath)).resolve() == path for s in bpy.data.sounds):
        path.unlink(missing_ok=True)


def remove_speech(face, keep=None) -> int:
    """Take away the face's speech strips in every scene (all but `keep`), their sounds and WAV files, and a
    sequence editor that speech created and left empty; returns how many strips went."""
    removed = 0
    for scene in bpy.data.scenes:
        editor = scene.sequence_editor
        if editor is None:
            continue
        for strip in list(_strips(editor)):
            if strip.get(CREATED_PROP) and strip.get(FACE_PROP) == face.name and strip != keep:
                sound = getattr(strip, "sound", None)
                _strips(editor).remove(strip)
                _drop_sound(sound)
                removed += 1
        if scene.get(EDITOR_PROP) and not len(_all_strips(editor)):
            scene.sequence_editor_clear()
            del scene[EDITOR_PROP]
    return removed


# ----------------------------------------------------------------------------- services


@dataclasses.dataclass(frozen=True)
class Layer:
    """An expression held over the whole speech: its name ("NONE" for none) and weight 0..1."""

    expression: str = "NONE"
    weight: float = 0.0


def _slug(text: str, words: int = 4) -> str:
    return "_".join(re.findall(r"[0-9a-z]+", text.lower())[:words])[:40] or "speech"


def user_folder() -> Path:
    """Where an unsaved file's speech goes (see the module docstring)."""
    package = __package__.rpartition(".")[0]
    if package.startswith("bl_ext."):
        return Path(bpy.utils.extension_path_user(package, path=USER_FOLDER, create=True))
    folder = Path(tempfile.gettempdir()) / "mpeg4_face_speech"
    folder.mkdir(exist_ok=True)
    return folder


def audio_path(speech: espeak.Speech, explicit: str = "") -> Path:
    """The WAV file for a synthesis: `explicit` if given, else named after the text and the audio's digest in
    the .blend's folder or the user folder."""
    if explicit:
        path = Path(bpy.path.abspath(explicit)).resolve()
        return path if path.suffix.lower() == ".wav" else path.with_name(path.name + ".wav")
    digest = hashlib.sha1(speech.samples.tobytes() + speech.sample_rate.to_bytes(4, "little")).hexdigest()[:8]
    folder = Path(bpy.path.abspath("//")) if bpy.data.filepath else user_folder()
    return folder.resolve() / f"speech_{_slug(speech.text)}_{digest}.wav"


def _play(context, face, segments, duration, name, source, options, layer, max_frames, audio=None) -> list[str]:
    """Co-articulate `segments`, check the stream on the face, then add the sound (`audio()` gives its file and
    whether we wrote it) and key the action; nothing changes if a check fails."""
    scene = context.scene
    tracks = coarticulation.fap_tracks(segments, scene_fps(scene), duration=duration, max_frames=max_frames)
    if layer.expression != "NONE":
        tracks = tracks.with_offsets(expression_values(layer.expression, layer.weight))
    # a replacing action keys only the frames that change (a silence costs two keys); an added one samples the
    # motion below it on every frame
    decoded = fap_io.decode_stream(context, face, tracks.to_stream(name, held=options.add), options, source)
    decoded = dataclasses.replace(decoded, name=name)
    notes = []
    strip = None
    if audio is not None:
        path, written = audio()
        try:
            strip = add_sound_strip(scene, path, options.start_frame, name, face)
        except Mpeg4Error:
            if written:
                _unlink_unused(path)
            raise
        if written:
            strip.sound[WRITTEN_PROP] = str(path)
        notes.append(f"added {path.name} as a sound strip on channel {strip.channel} at frame {options.start_frame}")
    if not options.add:
        replaced = remove_speech(face, keep=strip)
        if replaced:
            notes.append(f"removed {replaced} earlier speech strip(s) of {face.name}")
    notes = fap_io.key_stream(context, face, decoded, options) + notes
    if layer.expression != "NONE":
        notes.append(f"layered {layer.expression.lower()} at {layer.weight:.0%} over the speech")
    return notes


def speak_text(context, face, text, voice, rate, options, layer=Layer(), sound=True, audio_file="") -> list[str]:
    """Synthesise `text` with an espeak-ng voice and key it onto the face from `options.start_frame`, with its
    audio as a sound strip there (see the module docstring for where the WAV goes)."""
    scene = context.scene
    fap_io.require_setup(face)
    max_frames = frame_budget(scene, options.start_frame, options.set_frame_range)
    _check_audio_file(audio_file if sound else "")
    speech = espeak.synthesize(text, voice, rate=rate, max_seconds=max_frames / scene_fps(scene))
    return speak(context, face, speech, options, layer, sound, audio_file)


def _check_audio_file(audio_file: str) -> None:
    if audio_file and (problem := output_problem(bpy.path.abspath(audio_file))) is not None:
        raise Mpeg4Error(f"Audio File {audio_file[:60]}: {problem}")


def speak(context, face, speech: espeak.Speech, options, layer=Layer(), sound=True, audio_file="") -> list[str]:
    """Key one synthesis onto the face (and its audio as a sound strip): `speak_text` after espeak-ng. Its own
    entry, because espeak-ng varies its output a little from one synthesis of a text to the next."""
    fap_io.require_setup(face)
    max_frames = frame_budget(context.scene, options.start_frame, options.set_frame_range)
    _check_audio_file(audio_file if sound else "")
    segments = espeak.speech_segments(speech)
    short = speech.text if len(speech.text) <= 40 else speech.text[:39] + "…"

    def audio():
        path = audio_path(speech, audio_file)
        try:
            path.parent.mkdir(parents=True, exist_ok=True)
        except OSError as exc:
            raise Mpeg4Error(f"{path.parent}: cannot make the folder for the audio: {exc.strerror or exc}") from None
        wav.write_wav(path, speech.samples, speech.sample_rate)
        return path, True

    notes = _play(
        context,
        face,
        segments,
        speech.duration,
        f"Speech: {short}",
        f'"{short}"',
        options,
        layer,
        max_frames,
        audio if sound else None,
    )
    phonemes = len(speech.phonemes)
    notes.insert(0, f"spoke {speech.duration:.2f} s with espeak-ng voice {speech.voice!r} ({phonemes} phonemes)")
    return notes


def import_cues(context, face, path, options, layer=Layer(), audio_file="") -> list[str]:
    """Key a timed viseme/phoneme list or a Rhubarb cue file onto the face from `options.start_frame`, with
    `audio_file` (if given) as a sound strip there."""
    scene = context.scene
    fap_io.require_setup(face)
    max_frames = frame_budget(scene, options.start_frame, options.set_frame_range)
    path = Path(path)
    segments = cue_files.read_cue_file(path)
    audio = None
    if audio_file:
        sound_path = Path(bpy.path.abspath(audio_file))
        if (problem := file_problem(sound_path)) is not None:
            raise Mpeg4Error(f"audio file {str(sound_path)[:80]}: {problem}")

        def audio():
            return sound_path, False  # the user's own file: never written or deleted

    return _play(context, face, segments, None, path.stem, path.name, options, layer, max_frames, audio)


# ----------------------------------------------------------------------------- operators


_EXPRESSIONS = (("NONE", "None", "Speech only"),) + tuple(
    (e.name, e.name.title(), f"Hold {e.name.lower()} (FAP 2 table) over the speech") for e in Expression if e
)


class _SpeechOptions(GainAndClamp):
    """The options Speak Text and Import Lip-Sync Cues share with Import FAP Stream."""

    start_frame: IntProperty(name="Start Frame", description="The scene frame where the speech starts")
    expression: EnumProperty(name="Expression", items=_EXPRESSIONS, default="NONE")
    intensity: FloatProperty(
        name="Intensity", default=0.6, min=0.0, max=1.0, subtype="FACTOR", description="How strong the expression is"
    )
    mode: EnumProperty(
        name="Motion",
        items=(
            (
                "REPLACE",
                "Replace",
                "The speech replaces the feature points' motion and the face's earlier speech strips (your own "
                "animation is kept in the file and comes back on Remove)",
            ),
            ("ADD", "Add", "The speech is added to the motion already there"),
        ),
        default="REPLACE",
    )
    set_frame_range: BoolProperty(
        name="Extend Frame Range",
        default=True,
        description="Extend the scene's end frame to the end of the speech (off: the speech must fit in the "
        "scene's frame range)",
    )

    @classmethod
    def unavailable(cls, context):
        return poll.not_set_up(context)

    def _start(self, context) -> None:
        if not self.properties.is_property_set("start_frame"):
            self.start_frame = context.scene.frame_current

    def _options(self) -> fap_io.ImportOptions:
        return fap_io.ImportOptions(
            start_frame=self.start_frame,
            gain=self.gain,
            clamp=self.clamp or None,
            add=self.mode == "ADD",
            set_frame_range=self.set_frame_range,
        )

    def _layer(self) -> Layer:
        return Layer(self.expression, self.intensity)


class MPEG4_OT_speak_text(_SpeechOptions, Mpeg4Operator, bpy.types.Operator):
    """Speak a text with espeak-ng: the face's mouth is keyed in one action and the voice is added as a sound strip
    at the start frame"""

    bl_idname = "mpeg4.speak_text"
    bl_label = "Speak Text"
    bl_options = {"REGISTER", "UNDO"}

    text: StringProperty(name="Text", description="What the face says (English with the default voice)")
    voice: StringProperty(
        name="Voice",
        default=espeak.DEFAULT_VOICE,
        description="An espeak-ng voice name: en, en-us, en-gb-x-rp, de, fr, …",
    )
    rate: IntProperty(
        name="Rate",
        default=espeak.DEFAULT_RATE,
        min=espeak.RATE_RANGE[0],
        max=espeak.RATE_RANGE[1],
        description="Speaking rate in words per minute",
    )
    sound: BoolProperty(name="Sound Strip", default=True, description="Add the voice as a sound strip")
    audio_filepath: StringProperty(
        name="Audio File",
        subtype="FILE_PATH",
        options={"SKIP_SAVE"},
        description="Where to write the voice as WAV (empty: next to the .blend, or the extension's user folder "
        "while the file is unsaved)",
    )

    def invoke(self, context, _event):
        self._start(context)
        return context.window_manager.invoke_props_dialog(self, width=420)

    def run(self, context):
        return speak_text(
            context,
            poll.face(context),
            self.text,
            self.voice,
            self.rate,
            self._options(),
            self._layer(),
            self.sound,
            self.audio_filepath,
        )


class MPEG4_OT_import_cues(_SpeechOptions, Mpeg4Operator, bpy.types.Operator, ImportHelper):
    """Key the mouth from timed visemes or phonemes (TSV/JSON) or Rhubarb Lip Sync mouth cues, with an optional
    audio file as a sound strip at the start frame"""

    bl_idname = "mpeg4.import_cues"
    bl_label = "Import Lip-Sync Cues"
    bl_options = {"REGISTER", "UNDO"}

    filename_ext = ".tsv"
    filter_glob: StringProperty(default="*.tsv;*.txt;*.json", options={"HIDDEN"})
    audio_filepath: StringProperty(
        name="Audio File",
        subtype="FILE_PATH",
        options={"SKIP_SAVE"},
        description="The recording the cues were made from, added as a sound strip (empty: none)",
    )

    def invoke(self, context, event):
        self._start(context)
        return ImportHelper.invoke(self, context, event)

    def run(self, context):
        return import_cues(
            context, poll.face(context), self.filepath, self._options(), self._layer(), self.audio_filepath
        )


CLASSES = (MPEG4_OT_speak_text, MPEG4_OT_import_cues)
