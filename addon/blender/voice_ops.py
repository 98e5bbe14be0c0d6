"""Lip-sync from a voice recording: a file (Lip-Sync from Audio) or a sound strip already in the sequencer.

The path, one function per arrow: the recording --recording.read_recording / from_aud_sound--> 16 kHz mono
samples --phone_alignment.alignment_steps (with a transcript) or recognition_steps (without)--> timed CMU
phones --phone_alignment.phone_segments--> viseme segments --> then as Speak Text (`speech_ops._play`):
co-articulation, the expression layer, one action, and the recording as a sound strip at the start frame.

The transcript is the Transcript text when given, else a .txt file with the recording's name beside it. The
recording, the transcript and the frame range are checked before decoding starts; decoding runs in steps
(a timer in a window, with progress in the status bar; Esc stops it and nothing changes), and the scene
changes only once it has finished. The strip Lip-Sync from Audio adds is tagged like Speak Text's, so Remove
Set-Up takes it away (the recording itself is the user's file and is never deleted); a strip the user had is
left alone.
"""

from __future__ import annotations

from pathlib import Path

import bpy
from bpy.props import BoolProperty, EnumProperty, IntProperty, StringProperty
from bpy_extras.io_utils import ImportHelper

from ..errors import Mpeg4Error
from ..speech import coarticulation, phone_alignment, recording
from . import fap_io, poll
from .modal_job import ModalJob
from .reporting import Mpeg4Operator
from .speech_ops import FACE_PROP, _play, _SpeechOptions, frame_budget, scene_fps, strip_content_start

AUDIO_GLOB = "*.wav;*.wave;*.flac;*.ogg;*.oga;*.mp3;*.m4a;*.aac;*.opus"


def transcript_beside(path: Path) -> Path | None:
    """The .txt file with the recording's name in its folder, if there is one."""
    for candidate in (path.with_suffix(".txt"), path.with_suffix(".TXT")):
        if candidate.is_file():
            return candidate
    return None


class LipSyncJob:
    """One take: the recording and transcript checked, the decoding in steps, then the keys and the strip."""

    def __init__(
        self,
        context,
        face,
        take: recording.Recording,
        transcript: str,
        options,
        layer,
        vad,
        accuracy,
        sound_file: Path | None,
        name: str,
        strip_name: str | None = None,
        accent: str = phone_alignment.DEFAULT_ACCENT,
    ):
        self.face_name = face.name
        self.strip_name = strip_name  # the sound strip the take comes from, kept whatever Replace removes
        self.take = take
        self.transcript = transcript
        self.options = options
        self.layer = layer
        self.sound_file = sound_file
        self.name = name
        self.max_frames = frame_budget(context.scene, options.start_frame, options.set_frame_range)
        coarticulation.frame_count(take.duration, scene_fps(context.scene), self.max_frames)
        if transcript:
            self.steps = phone_alignment.alignment_steps(
                take, transcript, vad_mode=vad, accuracy=accuracy, accent=accent
            )
        else:
            self.steps = phone_alignment.recognition_steps(take, vad_mode=vad, accuracy=accuracy)
        self.fraction = 0.0
        self.phones = None

    @property
    def done(self) -> bool:
        return self.phones is not None

    def step(self) -> None:
        try:
            self.fraction = next(self.steps)
        except StopIteration as stop:
            self.phones = stop.value

    def cancel(self) -> None:
        self.steps.close()

    def finish(self, context) -> list[str]:
        face = bpy.data.objects[self.face_name]
        segments = phone_alignment.phone_segments(self.phones, self.take.source)
        audio = None if self.sound_file is None else (lambda: (self.sound_file, False))  # never written or deleted
        editor = context.scene.sequence_editor
        source = None if self.strip_name is None or editor is None else editor.strips_all.get(self.strip_name)
        owner = source.pop(FACE_PROP, None) if source is not None else None  # a strip an earlier take added
        try:
            notes = _play(
                context,
                face,
                segments,
                self.take.duration,
                self.name,
                self.take.source,
                self.options,
                self.layer,
                self.max_frames,
                audio,
            )
        finally:
            if owner is not None:
                source[FACE_PROP] = owner
        how = "aligned with the transcript" if self.transcript else "recognised without a transcript (less exact)"
        phones, visemes = len(self.phones), len(segments)
        notes.insert(0, f"{self.take.duration:.2f} s of voice: {phones} phones {how}, {visemes} visemes")
        return notes


class _LipSyncOperator(ModalJob, _SpeechOptions, Mpeg4Operator):
    """Options and the modal run shared by the file and the strip operators."""

    TICK_SECONDS = 0.05
    CANCELLED_MESSAGE = "Lip-sync cancelled: nothing changed"

    transcript: StringProperty(
        name="Transcript",
        description="What is said, word for word (empty: a .txt file with the recording's name beside it, or none). "
        "With a transcript the phones are aligned to the words; without, they are recognised, which is less "
        "accurate",
    )
    use_transcript_file: BoolProperty(
        name="Transcript File",
        default=True,
        description="When Transcript is empty, read the transcript from a .txt file with the recording's name",
    )
    vad_mode: IntProperty(
        name="Voice Activity",
        default=phone_alignment.DEFAULT_VAD_MODE,
        min=0,
        max=3,
        description="How strictly pauses are told from speech when a long recording is cut into pieces "
        "(0 loose .. 3 strict; raise it for noisy recordings)",
    )
    accuracy: EnumProperty(
        name="Accuracy",
        items=(
            ("STANDARD", "Standard", "PocketSphinx's usual search"),
            ("HIGH", "High", "A wider search: fewer errors on noisy or unusual speech, slower"),
        ),
        default="STANDARD",
    )

    accent: EnumProperty(
        name="Accent",
        items=[
            (key, name, f"Align the transcript as espeak-ng's voice {key} pronounces it")
            for key, name in phone_alignment.ACCENTS.items()
        ],
        default=phone_alignment.DEFAULT_ACCENT,
        description="The speaker's accent (with a transcript): the words are aligned as it pronounces them",
    )

    def draw(self, _context):
        layout = self.layout
        layout.use_property_split = True
        layout.prop(self, "transcript")
        layout.prop(self, "use_transcript_file")
        if not self.transcript.strip():
            layout.label(text="Without a transcript the mouth is less exact", icon="INFO")
        layout.prop(self, "accent")
        for name in ("start_frame", "expression", "intensity", "mode", "set_frame_range", "vad_mode", "accuracy"):
            layout.prop(self, name)

    def _transcript(self, audio_path: Path | None) -> str:
        if self.transcript.strip():
            return self.transcript
        if self.use_transcript_file and audio_path is not None:
            beside = transcript_beside(audio_path)
            if beside is not None:
                return phone_alignment.read_transcript_file(beside)
        return ""

    def _make_job(self, context) -> LipSyncJob:
        raise NotImplementedError

    def run(self, context):
        job = self._job or self._make_job(context)
        self._job = None
        while not job.done:
            job.step()
        return job.finish(context)

    # in a window (after the file browser): a timer decodes a second of audio per step, Esc cancels
    def execute(self, context):
        if bpy.app.background or context.window is None or self._job is not None:
            return Mpeg4Operator.execute(self, context)
        return self.start_job(context)

    def _progress_total(self) -> int:
        return 100

    def _show_progress(self):
        job = self._job
        self._show_text(f"{job.name}: {job.fraction:.0%} decoded   Esc: cancel", int(job.fraction * 100))


class MPEG4_OT_lipsync_audio(_LipSyncOperator, bpy.types.Operator, ImportHelper):
    """Animate the mouth from a voice recording (WAV, FLAC, OGG, MP3), aligned to its transcript when there is
    one; the recording is added as a sound strip at the start frame"""

    bl_idname = "mpeg4.lipsync_audio"
    bl_label = "Lip-Sync from Audio"
    bl_options = {"REGISTER", "UNDO"}

    filename_ext = ".wav"
    filter_glob: StringProperty(default=AUDIO_GLOB, options={"HIDDEN"})

    def invoke(self, context, event):
        self._start(context)
        return ImportHelper.invoke(self, context, event)

    def _make_job(self, context) -> LipSyncJob:
        face = poll.face(context)
        fap_io.require_setup(face)
        path = Path(bpy.path.abspath(self.filepath)).resolve()
        budget = frame_budget(context.scene, self.start_frame, self.set_frame_range) / scene_fps(context.scene)
        take = recording.read_recording(path, min(recording.DEFAULT_MAX_SECONDS, budget + 1.0))
        return LipSyncJob(
            context,
            face,
            take,
            self._transcript(path),
            self._options(),
            self._layer(),
            self.vad_mode,
            self.accuracy,
            path,
            f"Lip-Sync: {path.stem}",
            accent=self.accent,
        )


def _active_sound_strip(context):
    editor = context.scene.sequence_editor
    strip = None if editor is None else editor.active_strip
    return strip if strip is not None and strip.type == "SOUND" and strip.sound is not None else None


class MPEG4_OT_lipsync_strip(_LipSyncOperator, bpy.types.Operator):
    """Animate the mouth from the active sound strip of the sequencer, from the strip's first frame (its sound
    stays as it is)"""

    bl_idname = "mpeg4.lipsync_strip"
    bl_label = "Lip-Sync from Sound Strip"
    bl_options = {"REGISTER", "UNDO"}

    @classmethod
    def unavailable(cls, context):
        reason = poll.not_set_up(context)
        if reason is None and _active_sound_strip(context) is None:
            return "Make a sound strip the active strip of the sequencer first"
        return reason

    def invoke(self, context, _event):
        strip = _active_sound_strip(context)
        if strip is not None and not self.properties.is_property_set("start_frame"):
            self.start_frame = int(strip_content_start(strip))
        return context.window_manager.invoke_props_dialog(self, width=420)

    def _make_job(self, context) -> LipSyncJob:
        face = poll.face(context)
        strip = _active_sound_strip(context)
        if strip is None:
            raise Mpeg4Error("make a sound strip the active strip of the sequencer first")
        if not self.properties.is_property_set("start_frame"):
            self.start_frame = int(strip_content_start(strip))
        sound = strip.sound
        path = Path(bpy.path.abspath(sound.filepath)).resolve() if sound.filepath else None
        budget = frame_budget(context.scene, self.start_frame, self.set_frame_range) / scene_fps(context.scene)
        cap = min(recording.DEFAULT_MAX_SECONDS, budget + 1.0)
        if sound.packed_file is None and path is not None:
            take = recording.read_recording(path, cap)
        elif sound.factory is not None:  # packed into the .blend: Blender's own decoder reads it
            take = recording.from_aud_sound(sound.factory, f"sound strip {strip.name!r}", cap)
        else:
            raise Mpeg4Error(f"sound strip {strip.name!r}: its sound cannot be read here; unpack it to a file")
        transcript = self._transcript(path if sound.packed_file is None else None)
        return LipSyncJob(
            context,
            face,
            take,
            transcript,
            self._options(),
            self._layer(),
            self.vad_mode,
            self.accuracy,
            None,
            f"Lip-Sync: {strip.name}",
            strip.name,
            accent=self.accent,
        )


CLASSES = (MPEG4_OT_lipsync_audio, MPEG4_OT_lipsync_strip)
