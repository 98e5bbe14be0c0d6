"""Speak Text and Import Lip-Sync Cues on the sample head: one action and one sound strip, the mouth following the
cues, every bad input refused with the scene unchanged, and Remove taking all of it away."""

import os

import bpy
import numpy as np
import pytest

from addon.blender import face_data, speech_ops
from addon.speech import espeak, wav
from tests.markers import needs_espeak

from .helpers import select, set_up_sample
from .test_hardening import snapshot, unset_sample


def strips(scene=None):
    editor = (scene or bpy.context.scene).sequence_editor
    return [] if editor is None else list(speech_ops._strips(editor))


def scene_state(folder):
    """The snapshot of the file plus what speech adds: strips, sounds, the sequence editor and files on disk."""
    scene = bpy.context.scene
    return {
        **snapshot(),
        "strips": sorted((s.name, s.channel, *speech_ops.strip_span(s)) for s in strips()),
        "sounds": sorted(s.name for s in bpy.data.sounds),
        "editor": scene.sequence_editor is not None,
        "files": sorted(os.listdir(folder)),
    }


def gap(head, frame) -> float:
    """FP 2.2's height above FP 2.3 (m, head-local Z) at `frame`."""
    bpy.context.scene.frame_set(frame)
    empties = face_data.fp_empties(head)
    return empties["2.2"].location.z - empties["2.3"].location.z


def saved_sample(tmp_path):
    head = set_up_sample()
    bpy.ops.wm.save_as_mainfile(filepath=str(tmp_path / "face.blend"))
    head = bpy.data.objects["Head"]
    select(head)
    return head


def tone(path, seconds=1.5, rate=22050):
    t = np.arange(int(seconds * rate)) / rate
    wav.write_wav(path, (8000 * np.sin(2 * np.pi * 220 * t)).astype(np.int16), rate)
    return path


# ----------------------------------------------------------------------------- Speak Text


@needs_espeak
def test_speak_text_keys_one_action_and_adds_one_sound_strip_at_the_start_frame(tmp_path):
    head = saved_sample(tmp_path)
    scene = bpy.context.scene
    scene.render.fps = 25
    actions, sounds, before = set(bpy.data.actions), set(bpy.data.sounds), strips()
    assert bpy.ops.mpeg4.speak_text(text="Hello world", start_frame=7) == {"FINISHED"}

    (action,) = set(bpy.data.actions) - actions
    assert action.name == "Speech: Hello world"
    empties = face_data.fp_empties(head)
    assert {ob.animation_data.action for ob in empties.values()} == {action}
    (strip,) = [s for s in strips() if s not in before]
    assert strip.type == "SOUND" and speech_ops.strip_span(strip)[0] == 7
    (sound,) = set(bpy.data.sounds) - sounds
    assert strip.sound == sound and sound.filepath.startswith("//speech_hello_world_")
    written = tmp_path / sound.filepath.removeprefix("//")
    assert written.is_file() and sound[speech_ops.WRITTEN_PROP] == str(written)  # next to the saved .blend
    frames = speech_ops.strip_span(strip)[1] - speech_ops.strip_span(strip)[0]
    assert 0.5 < frames / 25 < 1.5 and scene.frame_end >= 7 + frames - 1
    gaps = [gap(head, f) for f in range(7, 7 + frames)]
    assert max(gaps) - min(gaps) > 0.002  # the mouth opens and closes by millimetres


@needs_espeak
def test_speaking_again_replaces_the_earlier_speech_and_its_audio(tmp_path):
    saved_sample(tmp_path)
    assert bpy.ops.mpeg4.speak_text(text="Hello world", start_frame=1) == {"FINISHED"}
    first = {s.name for s in strips()}
    assert bpy.ops.mpeg4.speak_text(text="Good morning", start_frame=40) == {"FINISHED"}
    assert {s.name for s in strips()} == first - {"Speech: Hello world"} | {"Speech: Good morning"}
    assert [p.name for p in tmp_path.glob("*.wav")] == [bpy.data.sounds[0].filepath.removeprefix("//")]
    assert bpy.ops.mpeg4.speak_text(text="Hello world", start_frame=1, mode="ADD") == {"FINISHED"}
    assert len(strips()) == len(first) + 1 and len(list(tmp_path.glob("*.wav"))) == 2


def test_an_unsaved_file_writes_the_audio_to_a_folder_of_its_own():
    assert not bpy.data.filepath
    speech = espeak.Speech("Hello world", "en", (), np.zeros(100, np.int16), 22050)
    path = speech_ops.audio_path(speech)
    assert path.parent == speech_ops.user_folder().resolve() and path.parent.is_dir()  # the checkout: the temp folder
    assert path.name.startswith("speech_hello_world_") and path.suffix == ".wav"


# ----------------------------------------------------------------------------- cue files


def test_the_cue_importer_keys_the_mouth_from_rhubarb_cues(tmp_path):
    head = set_up_sample()
    scene = bpy.context.scene
    scene.render.fps = 25
    cues = tmp_path / "talk.tsv"
    cues.write_text("0.00\tX\n0.20\tA\n0.60\tD\n1.00\tA\n1.40\tX\n1.60\tX\n")
    audio = tone(tmp_path / "talk.wav")
    rest = gap(head, 0)
    assert bpy.ops.mpeg4.import_cues(filepath=str(cues), start_frame=0, audio_filepath=str(audio)) == {"FINISHED"}
    assert bpy.data.actions.get("talk") is not None
    pressed, opened, pressed_again = gap(head, 10), gap(head, 20), gap(head, 30)  # centres of A, D, A
    assert pressed <= 0.0 and pressed_again <= 0.0  # A = PP: the inner lips meet (and press)
    assert opened > rest + 0.004  # D = AA: open by several millimetres
    (strip,) = [s for s in strips() if s.get(speech_ops.FACE_PROP) == head.name]
    assert speech_ops.strip_span(strip)[0] == 0 and strip.sound.filepath == str(audio)
    assert speech_ops.WRITTEN_PROP not in strip.sound  # the user's file: Remove leaves it alone


def test_our_timed_label_files_key_visemes_and_phonemes(tmp_path):
    head = set_up_sample()
    bpy.context.scene.render.fps = 25
    labels = tmp_path / "labels.json"
    labels.write_text(
        '{"segments": [{"start": 0, "end": 0.2, "label": "_"}, {"start": 0.2, "end": 0.6, "label": "m"},'
        ' {"start": 0.6, "end": 1.0, "label": "AA"}, {"start": 1.0, "end": 1.2, "label": "10"}]}'
    )
    assert bpy.ops.mpeg4.import_cues(filepath=str(labels), start_frame=0) == {"FINISHED"}
    assert gap(head, 10) <= 0.0 and gap(head, 20) > gap(head, 10) + 0.004


# ----------------------------------------------------------------------------- bad input


def _speak(**options):
    """A bad Speak Text: `prepare(folder)` gives the call that must fail."""
    return lambda folder: lambda: bpy.ops.mpeg4.speak_text(**{"start_frame": 1, **options})


def _cues(text, **options):
    """A bad cue import: `prepare(folder)` writes the cue file and gives the call that must fail."""

    def prepare(folder):
        path = folder / "cues.tsv"
        path.write_text(text)
        return lambda: bpy.ops.mpeg4.import_cues(filepath=str(path), **{"start_frame": 1, **options})

    return prepare


BAD = {
    "empty text": (_speak(text="   "), "the text to speak is empty"),
    "unknown phoneme": (_cues("0 0.1 _\n0.1 0.3 zz\n"), "'zz' at 0.100 s: unknown phoneme or viseme"),
    "unknown viseme number": (_cues("0 0.1 _\n0.1 0.3 15\n"), "'15' at 0.100 s: unknown phoneme or viseme"),
    "unknown Rhubarb shape": (_cues("0.0\tX\n0.3\tQ\n0.6\tX\n"), "unknown Rhubarb mouth shape"),
    "overlapping times": (_cues("0 0.3 _\n0.2 0.4 p\n"), "overlaps"),
    "negative time": (_cues("-0.1 0.3 _\n0.3 0.4 p\n"), "negative start time"),
    "unsorted times": (_cues("0.3 0.4 p\n0 0.3 _\n"), "times are not sorted"),
    "cues too long for the frame range": (
        _cues("0 0.5 _\n0.5 500 AA\n", set_frame_range=False),
        r"more than the \d+ frames allowed",
    ),
    "start after the end frame": (_cues("0 0.5 AA\n", set_frame_range=False, start_frame=100_000), "is after"),
    "missing audio file": (_cues("0 0.5 AA\n", audio_filepath="/nonexistent/talk.wav"), "audio file .*No such file"),
}


@pytest.mark.parametrize("case", BAD)
def test_a_bad_input_is_refused_and_changes_nothing(tmp_path, case):
    prepare, message = BAD[case]
    saved_sample(tmp_path)
    call = prepare(tmp_path)
    before = scene_state(tmp_path)
    with pytest.raises(RuntimeError, match=message):
        call()
    assert scene_state(tmp_path) == before


def test_audio_blender_cannot_read_is_refused_and_changes_nothing(tmp_path):
    saved_sample(tmp_path)
    not_sound = tmp_path / "notes.wav"
    not_sound.write_text("not a sound")
    call = _cues("0 0.5 AA\n", audio_filepath=str(not_sound))(tmp_path)
    before = scene_state(tmp_path)
    with pytest.raises(RuntimeError, match="cannot read this file as sound"):
        call()
    assert scene_state(tmp_path) == before


@needs_espeak
@pytest.mark.parametrize(
    ("options", "message"),
    [
        ({"text": "Hello", "voice": "xx-no-such-voice"}, "espeak-ng has no voice 'xx-no-such-voice'"),
        (
            {"text": "This sentence is far too long for five frames.", "set_frame_range": False, "start_frame": 246},
            "text too long",
        ),
    ],
)
def test_speak_text_refuses_what_espeak_cannot_say_and_changes_nothing(tmp_path, options, message):
    saved_sample(tmp_path)
    before = scene_state(tmp_path)
    with pytest.raises(RuntimeError, match=message):
        bpy.ops.mpeg4.speak_text(**options)
    assert scene_state(tmp_path) == before


def test_missing_espeak_says_how_to_install_it_and_changes_nothing(tmp_path, monkeypatch):
    saved_sample(tmp_path)
    monkeypatch.setattr(espeak, "_engine", None)
    monkeypatch.setattr(espeak, "find_library", lambda: (str(tmp_path / "libespeak-ng.so.1"), None))
    before = scene_state(tmp_path)
    with pytest.raises(RuntimeError, match=r"espeak-ng is not installed .*pip install espeakng-loader"):
        bpy.ops.mpeg4.speak_text(text="Hello world")
    assert scene_state(tmp_path) == before


def test_speak_text_needs_a_set_up_face():
    unset_sample()
    assert not bpy.ops.mpeg4.speak_text.poll()
    assert not bpy.ops.mpeg4.import_cues.poll()


# ----------------------------------------------------------------------------- Remove


@needs_espeak
def test_remove_after_speak_text_leaves_the_file_as_before_set_up(tmp_path):
    head = unset_sample()
    bpy.ops.wm.save_as_mainfile(filepath=str(tmp_path / "face.blend"))
    head = bpy.data.objects["Head"]
    select(head)
    before = scene_state(tmp_path)
    assert bpy.ops.mpeg4.setup_face() == {"FINISHED"}
    assert bpy.ops.mpeg4.speak_text(text="Maybe Bob", start_frame=5, expression="JOY") == {"FINISHED"}
    cues = tmp_path / "cues.tsv"
    cues.write_text("0.0\tX\n0.2\tA\n0.5\tX\n")
    audio = tone(tmp_path / "user.wav")
    result = bpy.ops.mpeg4.import_cues(filepath=str(cues), start_frame=50, mode="ADD", audio_filepath=str(audio))
    assert result == {"FINISHED"}
    assert len(strips()) == len(before["strips"]) + 2 and len(list(tmp_path.glob("speech_*.wav"))) == 1
    assert bpy.ops.mpeg4.remove_face() == {"FINISHED"}
    after = scene_state(tmp_path)
    assert after == {**before, "files": sorted([*before["files"], "cues.tsv", "user.wav"])}
    assert not list(tmp_path.glob("speech_*.wav")) and audio.is_file()  # our WAV gone, the user's file kept


def test_remove_takes_away_a_sequence_editor_that_speech_made(tmp_path):
    head = set_up_sample()
    scene = bpy.context.scene
    scene.sequence_editor_clear()
    cues = tmp_path / "cues.tsv"
    cues.write_text("0.0\tX\n0.2\tA\n0.5\tX\n")
    assert bpy.ops.mpeg4.import_cues(filepath=str(cues), audio_filepath=str(tone(tmp_path / "a.wav"))) == {"FINISHED"}
    assert scene.sequence_editor is not None and speech_ops.EDITOR_PROP in scene
    select(head)
    assert bpy.ops.mpeg4.remove_face() == {"FINISHED"}
    assert scene.sequence_editor is None and speech_ops.EDITOR_PROP not in scene
