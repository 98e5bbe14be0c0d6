"""Lip-Sync from Audio and from a sound strip on the sample head, end to end: one action, the recording as a
sound strip at the start frame, the lips closing on b/p/m; bad recordings refused with the scene unchanged;
Remove taking it all away."""

import bpy
import numpy as np
import pytest

from addon.blender import face_data, fap_io, speech_ops, voice_ops
from addon.blender.speech_ops import strip_span
from addon.speech import espeak, recording, wav
from tests.markers import needs_espeak

from .helpers import ModalWindow, event, select
from .test_hardening import unset_sample
from .test_speech_blender import gap, saved_sample, scene_state, strips

pytest.importorskip("pocketsphinx")

SENTENCE = "Maybe Bob bought a map."


def voice(folder, text=SENTENCE, transcript=True):
    """A recording of `text` by espeak-ng (with a same-name .txt transcript beside it) and its phonemes."""
    speech = espeak.synthesize(text, "en-us")
    path = wav.write_wav(folder / "take.wav", speech.samples, speech.sample_rate)
    if transcript:
        (folder / "take.txt").write_text(text + "\n")
    return path, speech


@needs_espeak
def test_lipsync_from_audio_keys_one_action_adds_the_recording_and_closes_the_lips(tmp_path):
    head = saved_sample(tmp_path)
    scene = bpy.context.scene
    scene.render.fps = 25
    path, speech = voice(tmp_path)
    actions, before = set(bpy.data.actions), strips()
    assert bpy.ops.mpeg4.lipsync_audio(filepath=str(path), start_frame=5) == {"FINISHED"}

    (action,) = set(bpy.data.actions) - actions
    assert action.name == "Lip-Sync: take"
    assert {ob.animation_data.action for ob in face_data.fp_empties(head).values()} == {action}
    (strip,) = [s for s in strips() if s not in before]
    assert strip.type == "SOUND" and strip_span(strip)[0] == 5
    assert bpy.path.abspath(strip.sound.filepath) == str(path)
    rest = gap(head, 4)
    gaps = {f: gap(head, f) for f in range(*strip_span(strip))}
    assert max(gaps.values()) - rest > 0.002  # the mouth opens by millimetres
    bilabials = [p for p in speech.phonemes if p.label in ("b", "p", "m")]
    assert len(bilabials) == 7  # maybe, bob, bought, map
    for phoneme in bilabials:  # closed (no wider than at rest) within two frames of espeak-ng's time
        frame = 5 + round(phoneme.start * 25)
        closest = min(gaps[f] for f in range(frame - 2, frame + 3) if f in gaps)
        assert closest <= rest + 1e-4, (phoneme, closest, rest)


@needs_espeak
def test_lipsync_from_a_sound_strip_without_transcript_keeps_the_strip(tmp_path):
    head = saved_sample(tmp_path)
    path, _ = voice(tmp_path, transcript=False)
    scene = bpy.context.scene
    editor = scene.sequence_editor_create()
    strip = editor.strips.new_sound("line", str(path), 3, 12)
    editor.active_strip = strip
    select(head)
    actions, before = set(bpy.data.actions), strips()
    assert bpy.ops.mpeg4.lipsync_strip() == {"FINISHED"}
    (action,) = set(bpy.data.actions) - actions
    assert action.name == "Lip-Sync: line" and strips() == before
    frames = [f for f in range(*strip_span(strip))]
    gaps = [gap(head, f) for f in frames]
    assert max(gaps) - gap(head, 11) > 0.002  # recognised phones open the mouth from the strip's frame on


def _bad_wav(folder, samples, rate=16000):
    return wav.write_wav(folder / "bad.wav", np.asarray(samples, dtype=np.int16), rate)


BAD = {
    "not audio": (lambda d: (d / "notes.wav").write_text("hello") and d / "notes.wav", "not a WAV file"),
    "not audio, other name": (lambda d: (d / "notes.ogg").write_text("hello") and d / "notes.ogg", "not a sound"),
    "missing": (lambda d: d / "none.wav", "cannot read the file"),
    "empty": (lambda d: _bad_wav(d, []), "holds no samples"),
    "silent": (lambda d: _bad_wav(d, np.zeros(16000)), "is silent"),
    "clipped": (lambda d: _bad_wav(d, np.where(np.arange(16000) % 40 < 20, 32767, -32768)), "is clipped"),
}


@pytest.mark.parametrize("case", BAD)
def test_a_bad_recording_is_refused_and_changes_nothing(tmp_path, case):
    make, message = BAD[case]
    saved_sample(tmp_path)
    path = make(tmp_path)
    before = scene_state(tmp_path)
    with pytest.raises(RuntimeError, match=message):
        bpy.ops.mpeg4.lipsync_audio(filepath=str(path))
    assert scene_state(tmp_path) == before


@needs_espeak
@pytest.mark.parametrize(
    ("options", "message"),
    [
        ({"transcript": "Completely different words spoken here by nobody at all today"}, "could not be aligned"),
        ({"set_frame_range": False, "start_frame": 240}, "frames allowed|longer than"),
    ],
)
def test_a_take_that_cannot_be_used_is_refused_and_changes_nothing(tmp_path, options, message):
    saved_sample(tmp_path)
    path, _ = voice(tmp_path)
    before = scene_state(tmp_path)
    with pytest.raises(RuntimeError, match=message):
        bpy.ops.mpeg4.lipsync_audio(filepath=str(path), **options)
    assert scene_state(tmp_path) == before


def test_lipsync_needs_a_set_up_face_and_a_sound_strip():
    unset_sample()
    assert not bpy.ops.mpeg4.lipsync_audio.poll()
    assert not bpy.ops.mpeg4.lipsync_strip.poll()


@needs_espeak
def test_remove_after_lipsync_leaves_the_file_as_before_set_up(tmp_path):
    head = unset_sample()
    bpy.ops.wm.save_as_mainfile(filepath=str(tmp_path / "face.blend"))
    select(bpy.data.objects["Head"])
    path, _ = voice(tmp_path)
    before = scene_state(tmp_path)
    assert bpy.ops.mpeg4.setup_face() == {"FINISHED"}
    assert bpy.ops.mpeg4.lipsync_audio(filepath=str(path), start_frame=3) == {"FINISHED"}
    assert len(strips()) == len(before["strips"]) + 1
    assert head.name == "Head" and bpy.ops.mpeg4.remove_face() == {"FINISHED"}
    assert scene_state(tmp_path) == before and path.is_file()  # the user's recording is kept


def _window(path, transcript=SENTENCE):
    take = recording.read_recording(path)
    options = fap_io.ImportOptions(start_frame=1)
    job = voice_ops.LipSyncJob(
        bpy.context,
        bpy.data.objects["Head"],
        take,
        transcript,
        options,
        speech_ops.Layer(),
        2,
        "STANDARD",
        path,
        "Lip-Sync: take",
    )
    return ModalWindow(voice_ops.MPEG4_OT_lipsync_audio, job)


@needs_espeak
def test_the_timer_decodes_in_steps_with_progress_and_then_keys_the_take(tmp_path):
    saved_sample(tmp_path)
    text = "Maybe Bob bought a map, and Pam made a bumpy plum pie by the lamp."
    path, _ = voice(tmp_path, text)
    actions = set(bpy.data.actions)
    window = _window(path, text)
    results = []
    while {"FINISHED"} not in results and len(results) < 60:
        results.append(window.modal(bpy.context, event("TIMER")))
    assert {"FINISHED"} in results and results.index({"FINISHED"}) >= 4  # several ticks, then the result
    assert results[: results.index({"FINISHED"})] == [{"RUNNING_MODAL"}] * results.index({"FINISHED"})
    assert window.progress == sorted(window.progress) and window.progress[-1] == 100
    assert window.texts[0].startswith("Lip-Sync: take: ") and window.texts[-1] is None
    assert len(set(bpy.data.actions) - actions) == 1 and window.reports[0][0] == "INFO"


@needs_espeak
def test_esc_cancels_the_lipsync_and_changes_nothing(tmp_path):
    saved_sample(tmp_path)
    path, _ = voice(tmp_path)
    before = scene_state(tmp_path)
    window = _window(path)
    assert window.modal(bpy.context, event("TIMER")) == {"RUNNING_MODAL"}
    assert window.modal(bpy.context, event("ESC")) == {"CANCELLED"}
    assert window.reports == [("WARNING", "Lip-sync cancelled: nothing changed")] and window.texts[-1] is None
    assert scene_state(tmp_path) == before


@needs_espeak
def test_lipsync_again_from_the_strip_a_take_added_keeps_that_strip(tmp_path):
    saved_sample(tmp_path)
    path, _ = voice(tmp_path)
    assert bpy.ops.mpeg4.lipsync_audio(filepath=str(path), start_frame=4) == {"FINISHED"}
    (strip,) = strips()
    bpy.context.scene.sequence_editor.active_strip = strip
    actions = set(bpy.data.actions)
    assert bpy.ops.mpeg4.lipsync_strip(transcript=SENTENCE) == {"FINISHED"}
    assert strips() == [strip] and strip.sound is not None and len(set(bpy.data.actions) - actions) == 1
    assert strip[speech_ops.FACE_PROP] == "Head"  # still the face's: Remove takes it away


@needs_espeak
@pytest.mark.parametrize("container", ["FLAC", "OGG"])
def test_flac_and_ogg_are_read_through_blenders_audio_library(tmp_path, container):
    import aud

    saved_sample(tmp_path)
    path, speech = voice(tmp_path)
    encoded = tmp_path / f"take.{container.lower()}"
    codec = {"FLAC": aud.CODEC_FLAC, "OGG": aud.CODEC_VORBIS}[container]
    aud.Sound(str(path)).write(str(encoded), 22050, 1, aud.FORMAT_S16, getattr(aud, f"CONTAINER_{container}"), codec)
    before = strips()
    assert bpy.ops.mpeg4.lipsync_audio(filepath=str(encoded), start_frame=2) == {"FINISHED"}
    (strip,) = [s for s in strips() if s not in before]
    assert bpy.path.abspath(strip.sound.filepath) == str(encoded)
    take = recording.read_recording(encoded)
    assert abs(take.duration - speech.duration) < 0.01


@needs_espeak
def test_the_accent_chosen_is_the_one_the_transcript_is_aligned_in(tmp_path, monkeypatch):
    from addon.speech import phone_alignment

    saved_sample(tmp_path)
    path, _ = voice(tmp_path)
    accents = []
    align = phone_alignment.alignment_steps

    def spy(*args, **kwargs):
        accents.append(kwargs.get("accent"))
        return align(*args, **kwargs)

    monkeypatch.setattr(phone_alignment, "alignment_steps", spy)
    assert bpy.ops.mpeg4.lipsync_audio(filepath=str(path), accent="en") == {"FINISHED"}
    assert accents == ["en"]
    with pytest.raises(TypeError):  # only espeak-ng's English voices
        bpy.ops.mpeg4.lipsync_audio(filepath=str(path), accent="fr")
