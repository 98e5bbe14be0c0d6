"""A voice recording (+ its transcript) -> phones with times, by PocketSphinx (no bpy).

With a transcript, forced alignment: `Decoder(samprate=16000, lm=None, bestpath=False)` (bestpath would
truncate the alignment), `set_align_text(words)`, one decoding pass for the words, `set_alignment()`, a second
pass for the phones, then `get_alignment().phones()`: each phone's start and length in 10 ms frames. A word
missing from the CMU dictionary gets its pronunciation from espeak-ng's phonemes, mapped to the dictionary's
phone set by `data/espeak_to_cmu.json`. Without a transcript, phone recognition: the `allphone` search with
the phone language model that ships with the model. Both give phones in the dictionary's set, written in
lower case (`data/phones_cmu.json` maps them to visemes).

Recordings longer than `PIECE_SECONDS` are cut at pauses (PocketSphinx's voice-activity detector) into pieces
decoded one after the other, so memory stays bounded and time linear. With a transcript each piece gets the
words whose share of the transcript's phones matches the piece's share of the voiced time; a piece that then
fails to align is merged with the next one and tried again. Each piece is decoded with `PAD_SECONDS` of faint
noise on both sides: the alignment grammar starts and ends in silence, and a piece cut right at a word
would not match it.

Timing: PocketSphinx's frame k analyses samples [160 k, 160 k + 410) (10 ms shift, 25.6 ms window), so its
centre lies 12.8 ms after 10 k ms. A phone starting at frame k starts half-way between the centres of frames
k - 1 and k, at 10 k + 7.8 ms: `BOUNDARY_OFFSET`.

The work runs as a generator of progress fractions (0..1) that returns the phones: `run` drives it to the
end, and Blender's modal operator one step per timer tick so that Esc can stop it between steps.
"""

from __future__ import annotations

import functools
import os
import re
from collections.abc import Callable, Generator

import numpy as np

from . import SpeechError
from .recording import RATE, Recording, RecordingError
from .segments import Segment, TimedLabel, segments_from_labels
from .tables import DATA, cmu_phones, read_json, read_text

FRAME_SECONDS = 0.01
BOUNDARY_OFFSET = (410 / 2 - 160 / 2) / RATE  # seconds, see the module docstring
PAD_SECONDS = 0.3
PIECE_SECONDS = 30.0  # longer recordings are cut at pauses into pieces of about this length
MIN_PAUSE_SECONDS = 0.25  # a pause where a long recording may be cut
FEED_SAMPLES = RATE  # samples per decoding step (one progress step)
MAX_WORDS_PER_SECOND = 10.0  # faster than any speaker: such a transcript does not belong to the recording
VAD_MODES = (0, 1, 2, 3)  # PocketSphinx's voice-activity aggressiveness, loose to strict
DEFAULT_VAD_MODE = 2
ACCURACY = ("STANDARD", "HIGH")
OOV_VOICE = "en-us"  # the espeak-ng voice that pronounces words missing from the (US English) dictionary
_NOISE_LEVEL = 2e-4  # the padding's faint noise (-74 dBFS): pure zeros give the front end log(0)

ProgressSteps = Generator[float, None, list[TimedLabel]]


class PocketSphinxMissingError(SpeechError):
    """The pocketsphinx package is not installed."""


class AlignmentError(SpeechError):
    """The transcript cannot be aligned with the recording."""


def _pocketsphinx():
    try:
        import pocketsphinx
    except ImportError:
        raise PocketSphinxMissingError(
            "PocketSphinx is not installed: install it with `python -m pip install pocketsphinx==5.1.1` into the "
            "Python that runs this (for Blender: its own python binary with `-m pip install`)"
        ) from None
    return pocketsphinx


# ----------------------------------------------------------------------------- tables


@functools.cache
def espeak_to_cmu() -> dict[str, tuple[str, ...]]:
    """espeak-ng English mnemonic -> CMU phones, from `data/espeak_to_cmu.json` (checked)."""
    source = str(DATA / "espeak_to_cmu.json")
    doc = read_json(DATA / "espeak_to_cmu.json", "espeak-ng to CMU table")
    known = cmu_phones().visemes
    table: dict[str, tuple[str, ...]] = {}
    for k, group in enumerate(doc["groups"]):
        if set(group) != {"cmu", "espeak", "why"} or not group["why"].strip():
            raise SpeechError(f"{source}: groups entry {k + 1}: expected cmu, espeak and why")
        for phone in group["cmu"]:
            if phone not in known:
                raise SpeechError(f"{source}: groups entry {k + 1}: {phone!r} is not a phone of phones_cmu.json")
        for name in group["espeak"]:
            if name in table:
                raise SpeechError(f"{source}: espeak-ng phoneme {name!r} is listed twice")
            table[name] = tuple(group["cmu"])
    return table


def phone_segments(phones: list[TimedLabel], source: str = "the recording") -> list[Segment]:
    """Timed CMU phones -> viseme segments, as text's phonemes become them."""
    return segments_from_labels(phones, cmu_phones(), source=source)


# ----------------------------------------------------------------------------- transcript


def transcript_words(text: str) -> list[str]:
    """The words of a transcript, lower case, as the dictionary spells them ("Don't!" -> "don't")."""
    if not isinstance(text, str):
        raise AlignmentError(f"the transcript must be text, not {type(text).__name__}")
    words = [w.strip("'_") for w in re.findall(r"[\w']+", text.lower())]
    return [w for w in words if w]


def _pronunciation(word: str) -> str:
    """The model's phones for a word missing from the dictionary, from espeak-ng's phonemes of it."""
    from . import espeak

    table = espeak_to_cmu()
    phones: list[str] = []
    for phoneme in espeak.synthesize(word, OOV_VOICE).phonemes:
        name = phoneme.label.lstrip("',%=!")
        if name.startswith("_"):
            continue
        if name not in table:
            raise AlignmentError(
                f"the word {word!r} is not in the dictionary and espeak-ng's phoneme {name!r} has no CMU phone: "
                "spell it as it sounds in the transcript"
            )
        phones.extend(table[name])
    if not phones:
        raise AlignmentError(f"the word {word!r} has no pronunciation: spell it as it sounds in the transcript")
    return " ".join(phones).upper()  # the model's phone names are upper case


def _add_missing_words(decoder, words: list[str]) -> list[str]:
    """Give the decoder a pronunciation of every word it lacks; returns the words added."""
    missing = sorted({w for w in words if decoder.lookup_word(w) is None})
    for k, word in enumerate(missing):
        decoder.add_word(word, _pronunciation(word), k == len(missing) - 1)  # one update, after the last
    return missing


def _phone_count(decoder, word: str) -> int:
    return len((decoder.lookup_word(word) or "x").split())


# ----------------------------------------------------------------------------- decoding


def _decoder(accuracy: str, **options):
    if accuracy not in ACCURACY:
        raise SpeechError(f"accuracy {accuracy!r} is not one of {', '.join(ACCURACY)}")
    if accuracy == "HIGH":  # wider beams: fewer search errors on noisy or unusual speech, slower
        options.update(beam=1e-80, wbeam=1e-60, pbeam=1e-80)
    try:
        return _pocketsphinx().Decoder(samprate=RATE, bestpath=False, loglevel="FATAL", **options)
    except (RuntimeError, ValueError) as exc:
        raise SpeechError(f"PocketSphinx could not start: {exc}") from None


def _pcm(samples: np.ndarray) -> bytes:
    """int16 PCM of a piece with PAD_SECONDS of faint noise on both sides (fixed seed: the same result each
    run)."""
    pad = int(PAD_SECONDS * RATE)
    noise = np.random.default_rng(0).normal(0.0, _NOISE_LEVEL, len(samples) + 2 * pad)
    noise[pad : pad + len(samples)] += samples
    return np.clip(np.round(noise * 32767), -32768, 32767).astype("<i2").tobytes()


def _decode_pass(decoder, pcm: bytes, done: float, total: float) -> Generator[float, None, None]:
    """One decoding pass over a piece, FEED_SAMPLES at a time; yields (done + samples fed) / total."""
    decoder.start_utt()
    step = 2 * FEED_SAMPLES  # bytes
    for first in range(0, len(pcm), step):
        decoder.process_raw(pcm[first : first + step], full_utt=False)
        yield min(1.0, (done + min(first + step, len(pcm)) / 2) / total)
    decoder.end_utt()


def speech_frames(samples: np.ndarray, vad_mode: int = DEFAULT_VAD_MODE) -> tuple[np.ndarray, float]:
    """(frames,) True where PocketSphinx's voice-activity detector hears speech, and the frame length (s)."""
    if vad_mode not in VAD_MODES:
        raise SpeechError(f"voice-activity mode {vad_mode!r} is not one of 0..3")
    vad = _pocketsphinx().Vad(vad_mode, RATE)
    n = vad.frame_bytes // 2
    pcm = np.clip(np.round(samples * 32767), -32768, 32767).astype("<i2")
    frames = len(pcm) // n
    return np.array([vad.is_speech(pcm[k * n : (k + 1) * n].tobytes()) for k in range(frames)], bool), vad.frame_length


def pieces(samples: np.ndarray, vad_mode: int = DEFAULT_VAD_MODE) -> tuple[list[tuple[int, int]], list[float]]:
    """A recording cut at pauses into (first, end) sample ranges of about PIECE_SECONDS (one range if it is
    shorter), and each range's seconds of voiced frames."""
    speech, frame_seconds = speech_frames(samples, vad_mode)
    if not speech.any():
        raise RecordingError("no speech found in the recording (the voice-activity detector heard none)")
    total = len(samples)
    if total <= PIECE_SECONDS * RATE:
        return [(0, total)], [float(speech.sum() * frame_seconds)]
    # the middle of every pause long enough, as a sample index
    padded = np.concatenate([[True], speech, [True]])
    edges = np.flatnonzero(np.diff(padded.astype(np.int8)))
    starts, ends = edges[::2], edges[1::2]  # runs of non-speech
    long_enough = (ends - starts) * frame_seconds >= MIN_PAUSE_SECONDS
    cuts = ((starts + ends)[long_enough] * frame_seconds / 2 * RATE).astype(int)
    bounds = [0]
    candidate = 0
    for cut in [*cuts.tolist(), total]:  # cut at the last pause before a piece would pass PIECE_SECONDS
        if cut - bounds[-1] > PIECE_SECONDS * RATE and candidate > bounds[-1]:
            bounds.append(candidate)
        candidate = cut
    ranges = list(zip(bounds, [*bounds[1:], total], strict=True))
    frame = int(round(frame_seconds * RATE))
    voiced = [float(speech[a // frame : b // frame].sum() * frame_seconds) for a, b in ranges]
    return ranges, voiced


def _share_words(words: list[str], weights: list[int], voiced: list[float]) -> list[list[str]]:
    """Words for each piece: the piece's share of the voiced time picks the same share of the phones."""
    cumulative = np.cumsum(weights) / sum(weights)
    shares = np.cumsum(voiced) / max(sum(voiced), 1e-9)
    out, first = [], 0
    for k, share in enumerate(shares):
        last = len(words) if k == len(shares) - 1 else int(np.argmin(np.abs(cumulative - share))) + 1
        out.append(words[first:last])
        first = max(first, last)
    return out


def _phones_of(entries, offset: float) -> list[TimedLabel]:
    out = []
    for name, first, frames in entries:
        start = max(0.0, offset + first * FRAME_SECONDS + BOUNDARY_OFFSET - PAD_SECONDS)
        end = max(start, offset + (first + frames) * FRAME_SECONDS + BOUNDARY_OFFSET - PAD_SECONDS)
        out.append(TimedLabel(start, end, name.lower(), f"PocketSphinx phone at {start:.2f} s"))
    return out


def _join(pieces_phones: list[list[TimedLabel]], duration: float) -> list[TimedLabel]:
    """One sorted, non-overlapping list: each piece's phones clipped to the gap the previous one left, and to
    the recording; a silence before the first phone."""
    out: list[TimedLabel] = []
    for phones in pieces_phones:
        for phone in phones:
            start = min(max(phone.start, out[-1].end if out else 0.0), duration)
            end = min(max(phone.end, start), duration)
            out.append(phone._replace(start=start, end=end))
    if out and out[0].start > 0:
        out.insert(0, TimedLabel(0.0, out[0].start, "sil", "before the first phone"))
    return out


def alignment_steps(
    recording: Recording, transcript: str, *, vad_mode: int = DEFAULT_VAD_MODE, accuracy: str = "STANDARD"
) -> ProgressSteps:
    """Forced alignment of `transcript` with `recording`: yields progress, returns the timed phones."""
    words = transcript_words(transcript)
    if not words:
        raise AlignmentError("the transcript has no words")
    if len(words) > MAX_WORDS_PER_SECOND * max(recording.duration, 1.0):
        raise AlignmentError(
            f"the transcript has {len(words)} words, more than anyone says in {recording.duration:.1f} s: is it the "
            "transcript of this recording?"
        )
    decoder = _decoder(accuracy, lm=None)
    _add_missing_words(decoder, words)
    ranges, voiced = pieces(recording.samples, vad_mode)
    shares = _share_words(words, [_phone_count(decoder, w) for w in words], voiced)
    total = 2.0 * (len(recording.samples) + 2 * PAD_SECONDS * RATE * len(ranges))  # two passes
    done = 0.0
    results = []
    pending_range, pending_words = None, []
    for (first, end), piece_words in zip(ranges, shares, strict=True):
        if pending_range is not None:
            first, piece_words = pending_range[0], pending_words + piece_words
        if not piece_words:
            pending_range, pending_words = (first, end), []
            continue
        pcm = _pcm(recording.samples[first:end])
        entries = None
        try:
            decoder.set_align_text(" ".join(piece_words))
            yield from _decode_pass(decoder, pcm, done, total)
            if decoder.hyp() is not None:
                decoder.set_alignment()
                yield from _decode_pass(decoder, pcm, done + len(pcm) / 2, total)
                alignment = decoder.get_alignment()
                entries = [(p.name, p.start, p.duration) for p in alignment.phones()] if alignment else None
        except RuntimeError:
            entries = None
        done += len(pcm)  # two passes of len(pcm) / 2 samples
        if not entries:
            if end < len(recording.samples):  # try again together with the next piece
                pending_range, pending_words = (first, end), piece_words
                continue
            raise AlignmentError(
                f"{recording.source}: the transcript could not be aligned with the recording"
                + (f" after {first / RATE:.1f} s" if first else "")
                + ": check that it is what is said (every word, in order), or lip-sync without it"
            )
        results.append(_phones_of(entries, first / RATE))
        pending_range, pending_words = None, []
    return _join(results, recording.duration)


def recognition_steps(
    recording: Recording, *, vad_mode: int = DEFAULT_VAD_MODE, accuracy: str = "STANDARD"
) -> ProgressSteps:
    """Phone recognition without a transcript (less accurate): yields progress, returns the timed phones."""
    model = _pocketsphinx().get_model_path()
    phone_lm = os.path.join(model, "en-us", "en-us-phone.lm.bin")
    # lw/pip: the phone LM's weight and the phone insertion penalty; with the defaults (lw 6.5, pip 1) the
    # search keeps only a few long phones
    decoder = _decoder(accuracy, lm=None, allphone=phone_lm, lw=2.0, pip=0.3, beam=1e-20, pbeam=1e-20)
    ranges, _ = pieces(recording.samples, vad_mode)
    total = float(len(recording.samples) + 2 * PAD_SECONDS * RATE * len(ranges))
    done = 0.0
    results = []
    for first, end in ranges:
        pcm = _pcm(recording.samples[first:end])
        yield from _decode_pass(decoder, pcm, done, total)
        done += len(pcm) / 2
        entries = [(s.word, s.start_frame, s.end_frame - s.start_frame + 1) for s in decoder.seg()]
        results.append(_phones_of(entries, first / RATE))
    return _join(results, recording.duration)


def run(steps: ProgressSteps, progress: Callable[[float], None] | None = None) -> list[TimedLabel]:
    """Drive a step generator to its end; `progress(fraction)` after each step."""
    while True:
        try:
            fraction = next(steps)
        except StopIteration as stop:
            return stop.value
        if progress is not None:
            progress(fraction)


def phones_from_recording(
    recording: Recording,
    transcript: str | None = None,
    *,
    vad_mode: int = DEFAULT_VAD_MODE,
    accuracy: str = "STANDARD",
    progress: Callable[[float], None] | None = None,
) -> list[TimedLabel]:
    """The recording's timed phones: aligned with `transcript` when given (not blank), else recognised."""
    if transcript is not None and transcript.strip():
        return run(alignment_steps(recording, transcript, vad_mode=vad_mode, accuracy=accuracy), progress)
    return run(recognition_steps(recording, vad_mode=vad_mode, accuracy=accuracy), progress)


def read_transcript_file(path) -> str:
    """A transcript .txt file (UTF-8)."""
    return read_text(path, "transcript")
