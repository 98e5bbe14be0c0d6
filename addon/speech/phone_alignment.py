"""A voice recording (+ its transcript) -> phones with times, by PocketSphinx (no bpy).

With a transcript, forced alignment: `Decoder(samprate=16000, lm=None, bestpath=False)` (bestpath would truncate the
alignment), `set_align_text(words)`, one decoding pass for the words, `set_alignment()`, a second pass for the
phones, then `get_alignment().phones()`: each phone's start and length in 10 ms frames. Each word is pronounced as
espeak-ng says it in the transcript (`_espeak_words`: its phonemes mapped to the model's phones by
`data/espeak_to_cmu.json`), so the aligned phones carry espeak-ng's names and the text path's visemes; if that
fails, the CMU dictionary's pronunciations are aligned (a word missing from it pronounced by espeak-ng) and the
phones keep their CMU names. A transcript whose alignment scores too low is refused (`MIN_SCORE_PER_FRAME`). The
aligned boundaries next to an abrupt phone (`ABRUPT_PHONES`) are then moved, within one frame, to the strongest
spectral change (`boundaries.refine_boundaries`), sound the aligner gave to a silence goes to the phone next to
it (`boundaries.sound_into_silence`), and where the transcript has a pause (punctuation, its end) the word before
it ends with its sound (`boundaries.pauses_at`). Without a transcript, phone recognition; or, on request
(`words`), the words that PocketSphinx's general US-English language model hears are aligned as a transcript
would be, and the lip
closures of phone recognition laid over them (`recognition_steps`; where no word is heard, the words do not align or
the word language model is not installed, phone recognition alone). Phone recognition: the `allphone` search with
the phone language model that ships with the model, giving CMU phones, where a /w/, /uw/, /uh/ or /l/ that sounds
like a nasal murmur is taken for an /m/, a quiet murmur within any other sonorant split off as an /m/, a /k/, /t/ or
/th/ with a labial burst taken for a /p/, and an /f/ or /v/ without frication for a /p/ or /b/ closure
(`bilabials.bilabials_from_acoustics`). CMU phones are written in lower case (`data/phones_cmu.json` maps them to
visemes, and the timed-label reader knows them).

Recordings longer than `PIECE_SECONDS` are cut at pauses (PocketSphinx's voice-activity detector) into pieces
decoded one after the other, so memory stays bounded and time linear. With a transcript each piece gets the
words whose share of the transcript's phones matches the piece's share of the voiced time; a piece that then
fails to align is merged with the next one and tried again. Each piece is decoded with `PAD_SECONDS` of faint
noise on both sides: the alignment grammar starts and ends in silence, and a piece cut right at a word
would not match it.

Timing: with a frame shift of h samples (`FRAME_RATES`: 160 for alignment, 80 for recognition),
PocketSphinx's frame k analyses samples [h k, h k + 410) (25.6 ms window), so its centre lies 12.8 ms after
h k / 16 ms. A phone starting at frame k starts half-way between the centres of frames k - 1 and k, at
h k / 16 + 12.8 - h / 32 ms (10 k + 7.8 ms at 100 frames a second): `_boundary_offset`.

The work runs as a generator of progress fractions (0..1) that returns the phones: `run` drives it to the
end, and Blender's modal operator one step per timer tick so that Esc can stop it between steps.
"""

from __future__ import annotations

import bisect
import contextlib
import dataclasses
import functools
import os
import re
import tempfile
from collections.abc import Callable, Generator
from dataclasses import dataclass

import numpy as np

from ..progress import scaled
from . import SpeechError, adaptation, espeak
from .bilabials import bilabials_from_acoustics
from .boundaries import log_band_energies, pauses_at, refine_boundaries, sound_into_silence
from .recording import RATE, Recording, RecordingError
from .segments import Segment, TimedLabel, segments_from_labels
from .tables import DATA, READ, cmu_phones

# Frames a second per task. Recognition analyses every 5 ms: its phones are three-state models that last at
# least three frames, 30 ms at the model's 100 frames a second, longer than many phones of fluent speech (a
# flap, a schwa, the release of a stop), so the search gave them away to their neighbours or dropped them
# (bilabial closures found in clean dev takes: 53 % at 10 ms, 72 % at 5 ms). Alignment keeps 10 ms: 5 ms gave
# it under 2 points of frame agreement for twice the time, and its score cut (`MIN_SCORE_PER_FRAME`) is
# measured at 10 ms (docs/voice.md).
FRAME_RATES = {"align": 100, "recognise": 200, "words": 100}
WINDOW_SAMPLES = 410  # PocketSphinx's analysis window at 16 kHz (0.025625 s)
PAD_SECONDS = 0.3
PIECE_SECONDS = 30.0  # longer recordings are cut at pauses into pieces of about this length
MIN_PAUSE_SECONDS = 0.25  # a pause where a long recording may be cut
FEED_SAMPLES = RATE  # samples per decoding step (one progress step)
MAX_WORDS_PER_SECOND = 10.0  # faster than any speaker: such a transcript does not belong to the recording
VAD_MODES = (0, 1, 2, 3)  # PocketSphinx's voice-activity aggressiveness, loose to strict
DEFAULT_VAD_MODE = 2
# The search's beams (beam, wbeam, pbeam: how far below the best a path may score and stay) per task and
# accuracy. Alignment follows one linear grammar, so even a nearly exhaustive beam costs little (13 s of
# speech: 1.72 s at 1e-80, 1.80 s at 1e-200), while PocketSphinx's default (1e-48) loses the only path on
# accented or synthetic voices ("plum jam", en-us, 150 words a minute) and the alignment fails.
BEAMS = {
    ("align", "STANDARD"): 1e-200,
    ("align", "HIGH"): 1e-300,
    ("recognise", "STANDARD"): 1e-20,
    ("recognise", "HIGH"): 1e-50,
    ("words", "STANDARD"): None,  # PocketSphinx's defaults (beam, pbeam 1e-48; wbeam 7e-29)
    ("words", "HIGH"): 1e-60,
}
ACCURACY = ("STANDARD", "HIGH")
# With beams this wide most transcripts "align"; whether it is what is said shows in the alignment's acoustic
# score per frame (PocketSphinx scores each frame against its best senone, so the level of the recording does
# not enter). Measured (docs/voice.md, "A transcript that is not what is said"): the right transcript -10.6 to
# -16.1 on the human recordings of pocketsphinx-testdata and down to -46.2 on espeak-ng voices (8 dev sentences,
# en-us and en, 120 and 300 words a minute, clean and at 20 dB SNR); the next sentence's transcript fails to
# align in 12 of those 64 takes and scores -40.1 to -71.3 in the others. The cut refuses 26 of those 52 and no
# right transcript; the other wrong ones pass.
MIN_SCORE_PER_FRAME = -50.0
OOV_VOICE = "en-us"  # the espeak-ng voice that pronounces words missing from the (US English) dictionary
# The speaker's accent, as one of espeak-ng's English voices: the transcript is aligned as that voice pronounces
# it, so the phones (and visemes) are the accent's. espeak-ng's own list of English voices, not a choice: which
# accent a recording has, the user knows and the acoustic score does not tell (docs/voice.md).
ACCENTS = {
    "en-us": "American",
    "en-us-nyc": "New York",
    "en": "British",
    "en-gb-x-rp": "Received Pronunciation",
    "en-gb-scotland": "Scottish",
    "en-gb-x-gbclan": "Lancastrian",
    "en-gb-x-gbcwmd": "West Midlands",
    "en-029": "Caribbean",
}
DEFAULT_ACCENT = OOV_VOICE
# Voices whose start, square, north and force vowels (A@ e@ O@ o@) and fire (aI3) are r-coloured: espeak-ng's US
# English; the British voices' are not, and the Scottish voice writes its r as a phoneme of its own
RHOTIC_VOWELS = frozenset({"en-us"})
# The model's phones whose sound starts or stops abruptly (stops, affricates, fricatives, nasals, silence):
# their boundaries are acoustic events that `boundaries.refine_boundaries` can place finer than a frame.
ABRUPT_PHONES = frozenset("p b t d k g ch jh f v th dh s z sh zh m n ng sil".split())
WORD_LANGUAGE_MODEL = "en-us.lm.bin"
_BILABIALS = frozenset("p b m".split())  # CMU names of the phone loop's lip closures
_MEAN_WORD = "a"  # in every recognition decoder's dictionary: the cheapest grammar to end a features-only utterance
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
    doc = READ.read_json(DATA / "espeak_to_cmu.json", "espeak-ng to CMU table")
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


def _abrupt(label: str) -> bool:
    """Whether a phone (espeak-ng's name or a CMU phone) starts or stops abruptly: `ABRUPT_PHONES`."""
    name = label.lstrip("',%=!")
    return name.startswith("_") or not ABRUPT_PHONES.isdisjoint(espeak_to_cmu().get(name, (name,)))


def phone_segments(phones: list[TimedLabel], source: str = "the recording") -> list[Segment]:
    """Timed phones (espeak-ng's names, or CMU phones in lower case) -> viseme segments, through the same
    tables as text."""
    return segments_from_labels(phones, source=source)


# ----------------------------------------------------------------------------- transcript


_WORD = re.compile(r"[\w']+")


def transcript_words(text: str) -> list[str]:
    """The words of a transcript, lower case, as the dictionary spells them ("Don't!" -> "don't")."""
    return [word for word, _ in _words_with_spans(text)]


_PAUSE = re.compile(r"[,.;:!?()\[\]\u2013\u2014\u2026]")  # punctuation that marks a pause (espeak-ng pauses there too)


def pauses_after_words(text: str) -> list[bool]:
    """For each word of a transcript, whether a pause may follow it: punctuation before the next word, or the end
    of the transcript (the end of the take)."""
    spans = [span for _, span in _words_with_spans(text)]
    ends = [start for start, _ in spans[1:]] + [len(text)]
    return [
        k == len(spans) - 1 or bool(_PAUSE.search(text, span[1], end))
        for k, (span, end) in enumerate(zip(spans, ends, strict=True))
    ]


def _with_pauses(words: list[_Word], text: str) -> list[_Word]:
    """`words` (one per transcript word, in order) marked with `pauses_after_words`."""
    return [dataclasses.replace(w, pause_after=p) for w, p in zip(words, pauses_after_words(text), strict=True)]


def _words_with_spans(text: str) -> list[tuple[str, tuple[int, int]]]:
    if not isinstance(text, str):
        raise AlignmentError(f"the transcript must be text, not {type(text).__name__}")
    out = []
    for match in _WORD.finditer(text):
        word = match[0].lower().strip("'_")
        if word:
            out.append((word, match.span()))
    return out


def cmu_of_phonemes(labels: list[str], rhotic: bool = True) -> list[tuple[str, ...]]:
    """The model's phones of each of espeak-ng's phonemes (`labels`, stress marks allowed; a pause, `_...`, has
    none), by `espeak_to_cmu`. An r-coloured vowel of espeak-ng's US English brings its r ("star": s t A@ ->
    s t aa r, as the dictionary has it), except where the next phoneme, with no pause between, is an r of its
    own ("story": s t o@ r i -> s t ao r iy, not ao r r). Not `rhotic` (a voice whose vowels are not
    r-coloured, `RHOTIC_VOWELS`): no vowel brings an r. KeyError names a phoneme the table lacks."""
    table = espeak_to_cmu()
    names = [label.lstrip("',%=!") for label in labels]
    out = []
    for k, name in enumerate(names):
        if name.startswith("_"):
            out.append(())
            continue
        if name not in table:
            raise KeyError(name)
        cmu = table[name]
        after = table.get(names[k + 1], ()) if k + 1 < len(names) else ()
        if len(cmu) > 1 and cmu[-1] == "r" and (after[:1] == ("r",) or not rhotic):
            cmu = cmu[:-1]
        out.append(cmu)
    return out


def _pronunciation(word: str) -> str:
    """The model's phones for a word missing from the dictionary, from espeak-ng's phonemes of it."""
    labels = [phoneme.label for phoneme in espeak.synthesize(word, OOV_VOICE).phonemes]
    try:
        phones = [phone for cmu in cmu_of_phonemes(labels) for phone in cmu]
    except KeyError as exc:
        raise AlignmentError(
            f"the word {word!r} is not in the dictionary and espeak-ng's phoneme {exc.args[0]!r} has no CMU phone: "
            "spell it as it sounds in the transcript"
        ) from None
    if not phones:
        raise AlignmentError(f"the word {word!r} has no pronunciation: spell it as it sounds in the transcript")
    return " ".join(phones).upper()  # the model's phone names are upper case


@dataclass(frozen=True)
class _Word:
    """A transcript word as the decoder aligns it: its dictionary entry, the model's phones of that entry and,
    for each phone, the espeak-ng phoneme it stands for (index in the word, name), or None to label the phones
    with their own CMU names."""

    text: str
    key: str
    phones: tuple[str, ...]
    labels: tuple[tuple[int, str], ...] | None = None
    pause_after: bool = False


def _espeak_words(decoder, text: str, accent: str = DEFAULT_ACCENT) -> list[_Word]:
    """Each word pronounced as espeak-ng's voice `accent` says it in this sentence (its phonemes mapped to the
    model's phones), so the aligned phones carry the text path's phoneme names and visemes; a word without
    phonemes of its own keeps the dictionary's pronunciation."""
    text = text.strip()
    words = _words_with_spans(text)
    speech = espeak.synthesize(text, accent)
    starts = [span[0] for _, span in words]
    try:
        cmu_phones = cmu_of_phonemes([phoneme.label for phoneme in speech.phonemes], accent in RHOTIC_VOWELS)
    except KeyError as exc:
        raise AlignmentError(f"espeak-ng's phoneme {exc.args[0]!r} in {text!r} has no CMU phone") from None
    parts: list[list[tuple[str, tuple[str, ...]]]] = [[] for _ in words]
    for phoneme, cmu in zip(speech.phonemes, cmu_phones, strict=True):
        position = phoneme.text_position - 1  # espeak-ng's is 1-based
        k = bisect.bisect_right(starts, position) - 1
        if not cmu or k < 0 or position >= words[k][1][1]:
            continue
        parts[k].append((phoneme.label, cmu))
    out = []
    for (word, _), phonemes in zip(words, parts, strict=True):
        phones = tuple(p.upper() for _, cmu in phonemes for p in cmu)
        if not phones:
            out.extend(_dictionary_words(decoder, [word]))
            continue
        labels = tuple((i, label) for i, (label, cmu) in enumerate(phonemes) for _ in cmu)
        out.append(_Word(word, f"{word}__{'_'.join(phones).lower()}", phones, labels))
    _add_words(decoder, out)
    return out


def _dictionary_words(decoder, texts: list[str]) -> list[_Word]:
    """Words as the CMU dictionary pronounces them (a missing one from espeak-ng's phonemes)."""
    missing = [_Word(w, w, tuple(_pronunciation(w).split())) for w in sorted(set(texts)) if not _known(decoder, w)]
    _add_words(decoder, missing)
    return [_Word(w, w, tuple(decoder.lookup_word(w).split())) for w in texts]


def _known(decoder, key: str) -> bool:
    return decoder.lookup_word(key) is not None


def _add_words(decoder, words: list[_Word]) -> None:
    new = {w.key: w.phones for w in words if not _known(decoder, w.key)}
    for k, (key, phones) in enumerate(new.items()):
        decoder.add_word(key, " ".join(phones), k == len(new) - 1)  # one update, after the last


# ----------------------------------------------------------------------------- decoding


def _new_decoder(task: str, accuracy: str, **files: str):
    if accuracy not in ACCURACY:
        raise SpeechError(f"accuracy {accuracy!r} is not one of {', '.join(ACCURACY)}")
    beam = BEAMS[task, accuracy]
    options = {"frate": FRAME_RATES[task], "bestpath": task == "words"}
    if beam is not None:
        options.update(beam=beam, wbeam=beam, pbeam=beam)
    options["lm"] = word_language_model() if task == "words" else None
    options.update(files)  # an adapted model's transform (`mllr`) and the take's own dictionary (`dict`)
    if task == "recognise":
        # lw/pip: the phone LM's weight and the phone insertion penalty; with the defaults (lw 6.5, pip 1) the
        # search keeps only a few long phones
        model = _pocketsphinx().get_model_path()
        options.update(allphone=os.path.join(model, "en-us", "en-us-phone.lm.bin"), lw=2.0, pip=0.3)
    try:
        return _pocketsphinx().Decoder(samprate=RATE, loglevel="FATAL", **options)
    except (RuntimeError, ValueError) as exc:
        raise SpeechError(f"PocketSphinx could not start: {exc}") from None


def word_language_model() -> str:
    """The general US-English word language model of PocketSphinx's wheel (with its CMU dictionary, the
    decoder's default). The extension's zip leaves it out (27 MB, scripts/slim_wheels.py): there recognition
    without a transcript is the phone loop's alone."""
    return os.path.join(_pocketsphinx().get_model_path(), "en-us", WORD_LANGUAGE_MODEL)


_idle_decoders: dict[tuple[str, str], list] = {}


@contextlib.contextmanager
def _decoder(task: str, accuracy: str):
    """A decoder for `task` ("align", "recognise") from a pool: loading the model takes about as long as
    aligning two seconds of speech. Its front end, which adapts from utterance to utterance (the noise
    estimate; the cepstral mean is set per piece, `_piece_mean`), starts each take afresh, so a take gives the
    same phones whatever was decoded before. One left by an error or by closing the steps midway (Esc) is dropped."""
    idle = _idle_decoders.setdefault((task, accuracy), [])
    if idle:
        decoder = idle.pop()
        decoder.reinit_feat()
    else:
        decoder = _new_decoder(task, accuracy)
    yield decoder
    idle.append(decoder)


def _pcm(samples: np.ndarray) -> bytes:
    """int16 PCM of a piece with PAD_SECONDS of faint noise on both sides (fixed seed: the same result each
    run)."""
    pad = int(PAD_SECONDS * RATE)
    noise = np.random.default_rng(0).normal(0.0, _NOISE_LEVEL, len(samples) + 2 * pad)
    noise[pad : pad + len(samples)] += samples
    return np.clip(np.round(noise * 32767), -32768, 32767).astype("<i2").tobytes()


def _piece_mean(decoder, pcm: bytes) -> str:
    """The piece's own cepstral mean, from its features alone: the model's feat.params ask for batch
    normalisation (`-cmn batch`), which decoding a second at a time cannot do by itself, and a mean carried
    over from other takes, or the model's initial one, misleads the first seconds. Ending an utterance
    searches every frame it holds, even frames fed with `no_search`, so the features are fed under a one-word
    alignment grammar (`_MEAN_WORD`) without the silence and filler loops every grammar gets by default: its
    search costs a fifth of an alignment pass. The caller sets its own search afterwards."""
    fillers = decoder.config["fsgusefiller"]  # read when a grammar is set
    decoder.config["fsgusefiller"] = False
    try:
        decoder.set_align_text(_MEAN_WORD)
    finally:
        decoder.config["fsgusefiller"] = fillers
    decoder.start_utt()
    decoder.process_raw(pcm, no_search=True, full_utt=False)
    decoder.end_utt()
    return decoder.get_cmn(True)


def _piece_cepstra(pcm: bytes) -> np.ndarray:
    """The piece's cepstra as the decoder computes them once its front end has run over the piece
    (`adaptation.cepstra`, within 3.3e-5 of sphinx_fe)."""
    return adaptation.cepstra(np.frombuffer(pcm, "<i2"), _model().params)


def _batch_mean(cepstra: np.ndarray) -> str:
    """The alignment's cepstral mean: the piece's own, over all its frames, as the model's feat.params ask
    (`-cmn batch`), for PocketSphinx's `set_cmn`. The decoder's live estimate (`_piece_mean`) starts from the
    model's initial mean as if from 500 frames of it, so for a take of a few seconds it stays near that prior
    (c0 43.5 where the take's own is 51.4, "Blame the ambitious mayor...", en-029, 240 wpm): measured on 24 dev
    takes, the take's own mean aligns 83.5 -> 85.3 % (docs/voice.md, *Session 13*)."""
    return ",".join(f"{value:.6g}" for value in cepstra.mean(axis=0))


def _decode_pass(decoder, pcm: bytes, mean: str, done: float, total: float) -> Generator[float, None, None]:
    """One decoding pass over a piece from its cepstral mean, FEED_SAMPLES at a time; yields
    (done + samples fed) / total."""
    decoder.set_cmn(mean)
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


def _share_words(words: list[_Word], voiced: list[float]) -> list[list[_Word]]:
    """Words for each piece: the piece's share of the voiced time picks the same share of the phones."""
    cumulative = np.cumsum([len(w.phones) for w in words]) / sum(len(w.phones) for w in words)
    shares = np.cumsum(voiced) / max(sum(voiced), 1e-9)
    out, first = [], 0
    for k, share in enumerate(shares):
        last = len(words) if k == len(shares) - 1 else int(np.argmin(np.abs(cumulative - share))) + 1
        out.append(words[first:last])
        first = max(first, last)
    return out


def _boundary_offset(frame_rate: int) -> float:
    """Seconds from the start of frame k (k / frame_rate) to a phone boundary before it: half-way between the
    centres of frames k - 1 and k (see the module docstring)."""
    return WINDOW_SAMPLES / 2 / RATE - 0.5 / frame_rate


def _seconds(frame: int, offset: float, frame_rate: int) -> float:
    """The time of the boundary before `frame` of a padded piece starting at `offset` s."""
    return offset + _boundary_offset(frame_rate) - PAD_SECONDS + frame / frame_rate


def _phones_of(entries, offset: float, frame_rate: int) -> list[TimedLabel]:
    """(label, first frame, frames, word: "" between words, None when recognised) of a padded piece starting
    at `offset` s, in frames of 1 / `frame_rate` s -> timed labels whose `where` names the word."""
    out = []
    for label, first, frames, word in entries:
        start = max(0.0, _seconds(first, offset, frame_rate))
        end = max(start, _seconds(first + frames, offset, frame_rate))
        where = "recognised phone" if word is None else f"word {word!r}" if word else "between words"
        out.append(TimedLabel(start, end, label, f"{where} at {start:.2f} s"))
    return out


def _score_per_frame(alignment) -> float:
    phones = list(alignment.phones())
    return sum(p.score for p in phones) / max(sum(p.duration for p in phones), 1)


def _word_spans(alignment, words: list[_Word]) -> list[tuple[int, int, _Word]]:
    """(first frame, end frame, word) of the transcript's words in the alignment, in order."""
    queue = iter(words)
    return [
        (entry.start, entry.start + entry.duration, next(queue))
        for entry in alignment.words()
        if not entry.name.startswith("<") and not entry.name.startswith("+")
    ]


def _aligned_entries(alignment, spans: list[tuple[int, int, _Word]]) -> list[tuple[str, int, int, str]]:
    """The alignment's phones as (label, first frame, frames, word), given its words' `_word_spans`: an
    espeak-ng-pronounced word's phones named after its phonemes (the phones of one phoneme joined), others by their
    CMU names."""
    out: list[tuple[str, int, int, str]] = []
    seen: dict[int, int] = {}  # span index -> phones of it so far
    last_key = None
    for phone in alignment.phones():
        k = next((i for i, (a, b, _) in enumerate(spans) if a <= phone.start < b), None)
        if k is None or phone.name == "SIL":
            out.append(("sil", phone.start, phone.duration, ""))
            last_key = None
            continue
        word = spans[k][2]
        n = seen[k] = seen.get(k, -1) + 1
        if word.labels is None or n >= len(word.labels):
            out.append((phone.name.lower(), phone.start, phone.duration, word.text))
            last_key = None
            continue
        index, label = word.labels[n]
        if last_key == (k, index):  # a second phone of the same phoneme (a diphthong with r, syllabic l)
            previous = out[-1]
            out[-1] = (label, previous[1], phone.start + phone.duration - previous[1], word.text)
        else:
            out.append((label, phone.start, phone.duration, word.text))
        last_key = (k, index)
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
    recording: Recording,
    transcript: str,
    *,
    vad_mode: int = DEFAULT_VAD_MODE,
    accuracy: str = "STANDARD",
    accent: str = DEFAULT_ACCENT,
    adapt: bool = True,
) -> ProgressSteps:
    """Forced alignment of `transcript` with `recording`: yields progress, returns the timed phones.

    The words are pronounced as espeak-ng's voice `accent` (one of `ACCENTS`) says them in the sentence
    (`_espeak_words`), so that the phones and visemes match what Speak Text gives for the same text in that
    voice; if that alignment fails (a speaker whose accent differs), or espeak-ng is missing, with the
    dictionary's pronunciations. With `adapt`, the model is then adapted to the take by MLLR from that
    alignment and the take aligned again (`_adapted`)."""
    if accent not in ACCENTS:
        raise AlignmentError(f"accent {accent!r} is not one of {', '.join(ACCENTS)}")
    words = transcript_words(transcript)
    if not words:
        raise AlignmentError("the transcript has no words")
    if len(words) > MAX_WORDS_PER_SECOND * max(recording.duration, 1.0):
        raise AlignmentError(
            f"the transcript has {len(words)} words, more than anyone says in {recording.duration:.1f} s: is it the "
            "transcript of this recording?"
        )
    ranges, voiced = pieces(recording.samples, vad_mode)
    cepstra_of: dict = {}  # by sample range: the same for every alignment of the take
    with _decoder("align", accuracy) as decoder:
        try:
            said = _with_pauses(_espeak_words(decoder, transcript, accent), transcript)
            shares = _share_words(said, voiced)
            results = yield from scaled(_align_pieces(decoder, recording, ranges, shares, cepstra_of), 0, 0.5)
        except (AlignmentError, espeak.EspeakMissingError):
            said = _with_pauses(_dictionary_words(decoder, words), transcript)
            shares = _share_words(said, voiced)
            results = yield from scaled(_align_pieces(decoder, recording, ranges, shares, cepstra_of), 0, 0.5)
    if adapt:
        results = yield from scaled(_adapted(recording, ranges, shares, results, accuracy, cepstra_of), 0.5, 1)
    # whole 10 ms frames: abrupt boundaries move to the acoustic event within one; silences give up their sound;
    # where the transcript pauses, the word before ends with its sound
    energies = log_band_energies(recording.samples)
    joined = _join([phones for phones, _, _ in results], recording.duration)
    phones = refine_boundaries(joined, energies, 1.0 / FRAME_RATES["align"], _abrupt)
    phones = sound_into_silence(phones, energies, _silent)
    return pauses_at(phones, energies, [moment for _, breaks, _ in results for moment in breaks], _silent)


def _state_frames(alignment) -> tuple[np.ndarray, np.ndarray]:
    """The aligned senone of each frame, and the base phone's index in the model's definition (the codebook of
    a phonetically-tied model), from the alignment's states and the phones they belong to."""
    phones = list(alignment.phones())
    starts = [p.start for p in phones]
    index = {name: k for k, name in enumerate(_model().phones)}
    frames = phones[-1].start + phones[-1].duration
    senones, codebooks = np.zeros(frames, np.int64), np.zeros(frames, np.int64)
    for state in alignment.states():
        phone = phones[bisect.bisect_right(starts, state.start) - 1]
        senones[state.start : state.start + state.duration] = int(state.name)
        codebooks[state.start : state.start + state.duration] = index[phone.name]
    return senones, codebooks


@functools.cache
def _model() -> adaptation.Model:
    """The wheel's acoustic model as `adaptation` reads it (means, variances, mixture weights, phones)."""
    return adaptation.read_model(os.path.join(_pocketsphinx().get_model_path(), "en-us", "en-us"))


def _transform(results: list) -> adaptation.Transform | None:
    """One MLLR transform per feature stream, of the means and the variances (`adaptation.estimate`), from
    aligned pieces' states and their features, or None (a take too short for one)."""
    aligned = []
    for cepstra, senones, codebooks in (piece for _, _, piece in results):
        feats = adaptation.features(cepstra)
        n = min(len(feats), len(senones))
        aligned.append((feats[:n], senones[:n], codebooks[:n]))
    return adaptation.estimate(aligned, _model())


def _adapted_decoder(task: str, accuracy: str, transform: adaptation.Transform, words: dict[str, tuple[str, ...]]):
    """A decoder for `task` whose model PocketSphinx loads with `transform` (`mllr`), its dictionary the words
    given alone: loading PocketSphinx's whole dictionary is nine tenths of loading a decoder (0.20 s against
    0.02 s). Recognition measures each piece's cepstral mean under a grammar of `_MEAN_WORD` (`_piece_mean`),
    so its dictionary holds that word too; alignment takes the mean from the piece's own cepstra
    (`_batch_mean`) and needs no other word (the same phones with it or without: docs/voice.md, session 14)."""
    mean_word = {_MEAN_WORD: ("AH",)} if task != "align" else {}
    entries = {**mean_word, **words}  # a transcript's own "a" keeps its pronunciation
    with tempfile.TemporaryDirectory() as folder:
        paths = {"mllr": os.path.join(folder, "mllr_matrix"), "dict": os.path.join(folder, "dictionary")}
        adaptation.write_mllr(paths["mllr"], transform)
        with open(paths["dict"], "w", encoding="utf-8") as out:
            out.writelines(f"{key} {' '.join(phones)}\n" for key, phones in entries.items())
        return _new_decoder(task, accuracy, **paths)


def _adapted(
    recording: Recording, ranges, shares, results: list, accuracy: str, cepstra_of: dict
) -> Generator[float, None, list]:
    """The take aligned again with the model adapted to it (`_transform` of the first alignment), the same
    words. The first alignment is kept when the take is too short for a transform, or the adapted model does
    not align it."""
    transform = _transform(results)
    if transform is None:
        return results
    decoder = _adapted_decoder("align", accuracy, transform, {w.key: w.phones for piece in shares for w in piece})
    try:
        return (yield from _align_pieces(decoder, recording, ranges, shares, cepstra_of))
    except AlignmentError:
        return results


def _silent(label: str) -> bool:
    return label == "sil"


def _align_pieces(
    decoder, recording: Recording, ranges, shares, cepstra_of: dict | None = None
) -> Generator[float, None, list]:
    """Align each piece with its words (a piece that fails is tried again together with the next one): for each
    piece, its timed phones, the ends (s) of its words that the transcript follows with a pause, and its
    cepstra with the senone and base phone of each of its frames (`_state_frames`). Each piece is decoded from
    its own batch cepstral mean (`_batch_mean`); `cepstra_of` keeps the cepstra by sample range for the next
    alignment of the same take."""
    cepstra_of = {} if cepstra_of is None else cepstra_of
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
        entries, breaks, states = None, [], None
        try:
            if (first, end) not in cepstra_of:
                cepstra_of[first, end] = _piece_cepstra(pcm)
            cepstra = cepstra_of[first, end]
            mean = _batch_mean(cepstra)
            decoder.set_align_text(" ".join(w.key for w in piece_words))
            yield from _decode_pass(decoder, pcm, mean, done, total)
            if decoder.hyp() is not None:
                decoder.set_alignment()
                yield from _decode_pass(decoder, pcm, mean, done + len(pcm) / 2, total)
                alignment = decoder.get_alignment()
                if alignment is not None and _score_per_frame(alignment) >= MIN_SCORE_PER_FRAME:
                    spans = _word_spans(alignment, piece_words)
                    entries = _aligned_entries(alignment, spans)
                    breaks = [b for _, b, w in spans if w.pause_after]
                    states = _state_frames(alignment)
        except RuntimeError:
            entries = None
        done += len(pcm)  # two passes of len(pcm) / 2 samples
        if not entries:
            if end < len(recording.samples):
                pending_range, pending_words = (first, end), piece_words
                continue
            raise AlignmentError(
                f"{recording.source}: the transcript could not be aligned with the recording"
                + (f" after {first / RATE:.1f} s" if first else "")
                + ": check that it is what is said (every word, in order), or lip-sync without it"
            )
        rate = FRAME_RATES["align"]
        moments = [_seconds(b, first / RATE, rate) for b in breaks]
        results.append((_phones_of(entries, first / RATE, rate), moments, (cepstra, *states)))
        pending_range, pending_words = None, []
    return results


def recognition_steps(
    recording: Recording,
    *,
    vad_mode: int = DEFAULT_VAD_MODE,
    accuracy: str = "STANDARD",
    words: bool = False,
    adapt: bool = False,
) -> ProgressSteps:
    """Recognition without a transcript (less accurate): yields progress, returns the timed phones.

    The phone loop (`phone_loop_steps`) by default. With `words`: PocketSphinx's general US-English language model
    and dictionary decode the words, which are then force-aligned like a transcript (`alignment_steps`), so the
    phones keep a lexicon's constraints (a word's phones in order, its bilabials where the word has them). The
    phone loop (`phone_loop_steps`) runs too; its lip closures, found by the recogniser and the acoustic cues of
    `bilabials`, are laid over the aligned phones (`with_closures`): a word the recogniser got wrong does not
    open lips that the acoustics heard close. Where no word is recognised, the words cannot be aligned, or the
    word language model is not installed (`word_language_model`), the phone loop's phones are used as they are.
    With `adapt` (and not `words`): the phone loop twice, the second time with the model adapted to the take
    from the first's phones (`_phone_loop_adapted`): slower, and better on the takes measured (docs/voice.md)."""
    ranges, voiced = pieces(recording.samples, vad_mode)
    if adapt and not words:
        return (yield from _phone_loop_adapted(recording, ranges, voiced, accuracy))
    if not words or not os.path.isfile(word_language_model()):
        return (yield from _phone_loop(recording, ranges, accuracy))
    heard = yield from scaled(_phone_loop(recording, ranges, accuracy), 0.0, 0.3)
    said = yield from scaled(_word_steps(recording, ranges, accuracy), 0.3, 0.6)
    if not said:
        return heard
    try:
        aligned = yield from scaled(
            # not adapted: recognised words are no transcript, and a wrong word would adapt the model to it
            alignment_steps(recording, " ".join(said), vad_mode=vad_mode, accuracy=accuracy, adapt=False),
            0.6,
            1.0,
        )
    except AlignmentError:
        return heard
    aligned = [p._replace(where="recognised " + p.where) for p in aligned]
    return with_closures(aligned, [p for p in heard if p.label in _BILABIALS])


def phone_loop_steps(
    recording: Recording, *, vad_mode: int = DEFAULT_VAD_MODE, accuracy: str = "STANDARD"
) -> ProgressSteps:
    """Phone recognition alone (the `allphone` search), with the bilabial cues: yields progress, returns the
    timed phones (CMU names)."""
    ranges, _ = pieces(recording.samples, vad_mode)
    return (yield from _phone_loop(recording, ranges, accuracy))


def _phone_loop(recording: Recording, ranges, accuracy: str, decoder=None) -> ProgressSteps:
    def phones(decoder, first: int) -> list[TimedLabel]:
        entries = [(s.word.lower(), s.start_frame, s.end_frame - s.start_frame + 1, None) for s in decoder.seg()]
        return _phones_of(entries, first / RATE, FRAME_RATES["recognise"])

    results = yield from _search_pieces(recording, ranges, "recognise", accuracy, phones, decoder)
    return bilabials_from_acoustics(_join(results, recording.duration), recording.samples)


def _phone_loop_adapted(recording: Recording, ranges, voiced, accuracy: str) -> ProgressSteps:
    """The phone loop twice, the second time with the model adapted to the take from the first's phones
    (unsupervised MLLR): those phones, each a word of one phone, aligned as a transcript is give the states the
    transform is estimated from (`_transform`). The first phones are kept when they do not align or the take is
    too short for a transform."""
    heard = yield from scaled(_phone_loop(recording, ranges, accuracy), 0.0, 0.35)
    known = {name.lower() for name in _model().phones}
    words = [_Word(p.label, f"phone_{p.label}", (p.label.upper(),)) for p in heard if p.label in known - {"sil"}]
    if not words:
        return heard
    with _decoder("align", accuracy) as decoder:
        _add_words(decoder, words)
        try:
            results = yield from scaled(
                _align_pieces(decoder, recording, ranges, _share_words(words, voiced)), 0.35, 0.65
            )
        except AlignmentError:
            return heard
    transform = _transform(results)
    if transform is None:
        return heard
    # the means alone, as measured (docs/voice.md, session 13): the variances' scales were measured with a
    # transcript only
    transform = dataclasses.replace(transform, variances=np.ones_like(transform.variances))
    decoder = _adapted_decoder("recognise", accuracy, transform, {})
    return (yield from scaled(_phone_loop(recording, ranges, accuracy, decoder), 0.65, 1.0))


def _word_steps(recording: Recording, ranges, accuracy: str) -> Generator[float, None, list[str]]:
    """The words the general language model hears in each piece, in order (fillers and silences left out)."""

    def words(decoder, first: int) -> list[str]:
        hypothesis = decoder.hyp()
        heard = hypothesis.hypstr.split() if hypothesis is not None else []
        return [w for w in heard if not w.startswith(("<", "[", "+"))]

    results = yield from _search_pieces(recording, ranges, "words", accuracy, words)
    return [word for piece in results for word in piece]


def _search_pieces(recording: Recording, ranges, task: str, accuracy: str, read: Callable, decoder=None) -> Generator:
    """One pass of the search `task` was made with over each piece, from the piece's own cepstral mean: yields
    progress, returns `read(decoder, first sample)` of each piece. On a pooled decoder unless one is given."""
    total = float(len(recording.samples) + 2 * PAD_SECONDS * RATE * len(ranges))
    done = 0.0
    results = []
    given = contextlib.nullcontext(decoder) if decoder is not None else None
    with given or _decoder(task, accuracy) as decoder:
        for first, end in ranges:
            pcm = _pcm(recording.samples[first:end])
            mean = _piece_mean(decoder, pcm)
            decoder.activate_search()  # the phone loop or language model the decoder was made with
            yield from _decode_pass(decoder, pcm, mean, done, total)
            done += len(pcm) / 2
            results.append(read(decoder, first))
    return results


def with_closures(phones: list[TimedLabel], closures: list[TimedLabel]) -> list[TimedLabel]:
    """`phones` (sorted, not overlapping) with each of `closures` laid over them: the parts of phones that a
    closure covers give way to it."""
    out: list[TimedLabel] = []
    closure_ends = [c.end for c in closures]
    for phone in phones:
        parts = [(phone.start, phone.end)]
        for closure in closures[bisect.bisect_left(closure_ends, phone.start) :]:
            if closure.start >= phone.end:
                break
            parts = [
                span
                for a, b in parts
                for span in ((a, min(b, closure.start)), (max(a, closure.end), b))
                if span[1] > span[0]
            ]
        out += [phone._replace(start=a, end=b) for a, b in parts]
    return sorted([*out, *closures], key=lambda p: p.start)


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
    words: bool = False,
    accent: str = DEFAULT_ACCENT,
    adapt: bool = True,
    adapt_recognition: bool = False,
) -> list[TimedLabel]:
    """The recording's timed phones: aligned with `transcript` when given (not blank), pronounced in `accent`,
    with the model adapted to the take unless not `adapt`; else recognised (with `words`: the recognised words
    aligned; with `adapt_recognition`: recognised twice, the model adapted from the first; see
    `recognition_steps`)."""
    if transcript is not None and transcript.strip():
        steps = alignment_steps(recording, transcript, vad_mode=vad_mode, accuracy=accuracy, accent=accent, adapt=adapt)
        return run(steps, progress)
    steps = recognition_steps(recording, vad_mode=vad_mode, accuracy=accuracy, words=words, adapt=adapt_recognition)
    return run(steps, progress)


def read_transcript_file(path) -> str:
    """A transcript .txt file (UTF-8)."""
    return READ.read_text(path, "transcript")
