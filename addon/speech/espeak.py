"""Text -> phonemes with times and the audio, both from ONE libespeak-ng synthesis (ctypes, no bpy).

The route (research/deformation-lipsync.md section 5): `espeak_Initialize(AUDIO_OUTPUT_SYNCHRONOUS, 0,
data path, espeakINITIALIZE_PHONEME_EVENTS)`, `espeak_SetSynthCallback`, `espeak_SetVoiceByName`, then
`espeak_Synth`. The callback receives the 16-bit mono samples and the events. PHONEME events carry the
phoneme's ASCII name (espeak-ng's own mnemonics, with stress marks) and its `audio_position` in ms within the
same output. A phoneme lasts until the next one starts, and the last one until the end of the audio. The
mouth and the sound therefore come from the same timeline. `audio_position` is a whole number of ms, so a
phoneme boundary may be up to 1 ms early. We use it rather than the event's `sample` field, which the
header marks "internal use".

The library is looked up in this order: the PyPI wheel `espeakng-loader` (it bundles libespeak-ng and its
data; the project's requirements.txt pins it), then the system's libespeak-ng (Debian: `libespeak-ng1`, found
by `ctypes.util.find_library` or as `libespeak-ng.so.1`, with its built-in data path). If neither is there,
`EspeakMissingError` says how to install it.

libespeak-ng keeps global state, so the library is initialised once per process and synthesis is serialised
by a lock.
"""

from __future__ import annotations

import ctypes
import ctypes.util
import math
import threading
from dataclasses import dataclass

import numpy as np

from . import SpeechError
from .segments import Segment, TimedLabel, segments_from_labels
from .tables import PhonemeTable

INSTALL_HINT = (
    "install it with `python -m pip install espeakng-loader==0.2.4` into the Python that runs this "
    "(for Blender: its own python binary with `-m pip install`), or on Debian/Ubuntu with "
    "`apt-get install libespeak-ng1`"
)
DEFAULT_VOICE = "en"
MAX_TEXT_CHARACTERS = 20_000
DEFAULT_MAX_SECONDS = 3600.0
RATE_RANGE = (80, 450)  # words per minute, espeakRATE_MINIMUM..espeakRATE_MAXIMUM
DEFAULT_RATE = 175  # espeakRATE_NORMAL

# speak_lib.h
_AUDIO_OUTPUT_SYNCHRONOUS = 2
_INITIALIZE_PHONEME_EVENTS = 0x0001
_INITIALIZE_DONT_EXIT = 0x8000
_EVENT_LIST_TERMINATED = 0
_EVENT_PHONEME = 7
_CHARS_UTF8 = 1
_POS_CHARACTER = 1
_PARAMETER_RATE = 1


class EspeakMissingError(SpeechError):
    """libespeak-ng cannot be found or loaded."""


class _EventId(ctypes.Union):
    _fields_ = (("number", ctypes.c_int), ("name", ctypes.c_char_p), ("string", ctypes.c_char * 8))


class _Event(ctypes.Structure):
    _fields_ = (
        ("type", ctypes.c_int),
        ("unique_identifier", ctypes.c_uint),
        ("text_position", ctypes.c_int),
        ("length", ctypes.c_int),
        ("audio_position", ctypes.c_int),  # ms
        ("sample", ctypes.c_int),
        ("user_data", ctypes.c_void_p),
        ("id", _EventId),
    )


_CALLBACK = ctypes.CFUNCTYPE(ctypes.c_int, ctypes.POINTER(ctypes.c_short), ctypes.c_int, ctypes.POINTER(_Event))


@dataclass(frozen=True)
class Phoneme:
    label: str  # espeak-ng's name, stress marks included ("'oU"); '_' names are pauses
    start: float  # seconds
    end: float
    text_position: int  # 1-based character of the text it belongs to


@dataclass(frozen=True, eq=False)
class Speech:
    text: str
    voice: str
    phonemes: tuple[Phoneme, ...]
    samples: np.ndarray  # (N,) int16 mono PCM
    sample_rate: int  # Hz

    @property
    def duration(self) -> float:
        return len(self.samples) / self.sample_rate


def find_library() -> tuple[str, str | None]:
    """(library path or name, data path or None for the library's default) of an installed libespeak-ng."""
    try:
        import espeakng_loader
    except ImportError:
        pass
    else:
        return espeakng_loader.get_library_path(), espeakng_loader.get_data_path()
    name = ctypes.util.find_library("espeak-ng")
    if name:
        return name, None
    return "libespeak-ng.so.1", None


class _Engine:
    """The initialised library and the state of the synthesis in progress."""

    def __init__(self, library: str, data: str | None):
        try:
            lib = ctypes.CDLL(library)
        except OSError as exc:
            raise EspeakMissingError(f"espeak-ng is not installed ({library}: {exc}); {INSTALL_HINT}") from None
        lib.espeak_Initialize.argtypes = (ctypes.c_int, ctypes.c_int, ctypes.c_char_p, ctypes.c_int)
        lib.espeak_Initialize.restype = ctypes.c_int
        lib.espeak_SetSynthCallback.argtypes = (_CALLBACK,)
        lib.espeak_SetSynthCallback.restype = None
        lib.espeak_SetVoiceByName.argtypes = (ctypes.c_char_p,)
        lib.espeak_SetVoiceByName.restype = ctypes.c_int
        lib.espeak_SetParameter.argtypes = (ctypes.c_int, ctypes.c_int, ctypes.c_int)
        lib.espeak_SetParameter.restype = ctypes.c_int
        lib.espeak_Synth.argtypes = (
            ctypes.c_void_p, ctypes.c_size_t, ctypes.c_uint, ctypes.c_int, ctypes.c_uint, ctypes.c_uint,
            ctypes.POINTER(ctypes.c_uint), ctypes.c_void_p,
        )  # fmt: skip
        lib.espeak_Synth.restype = ctypes.c_int
        lib.espeak_Synchronize.restype = ctypes.c_int
        options = _INITIALIZE_PHONEME_EVENTS | _INITIALIZE_DONT_EXIT
        rate = lib.espeak_Initialize(_AUDIO_OUTPUT_SYNCHRONOUS, 0, data.encode() if data else None, options)
        if rate <= 0:
            where = data or "its default data folder"
            raise EspeakMissingError(f"espeak-ng could not start (no voice data in {where}); {INSTALL_HINT}")
        self.lib = lib
        self.sample_rate = rate
        self.callback = _CALLBACK(self._receive)  # kept alive as long as the library may call it
        lib.espeak_SetSynthCallback(self.callback)
        self.lock = threading.Lock()
        self._reset(0)

    def _reset(self, max_samples: int) -> None:
        self.chunks: list[bytes] = []
        self.n_samples = 0
        self.events: list[tuple[str, int, int]] = []  # (name, audio_position ms, text_position)
        self.max_samples = max_samples
        self.aborted = False

    def _receive(self, wav, n_samples, events) -> int:
        if n_samples > 0 and wav:
            self.chunks.append(ctypes.string_at(wav, 2 * n_samples))
            self.n_samples += n_samples
        i = 0
        while events and events[i].type != _EVENT_LIST_TERMINATED:
            event = events[i]
            if event.type == _EVENT_PHONEME:
                name = bytes(event.id.string).split(b"\0", 1)[0].decode("utf-8", "replace")
                self.events.append((name, event.audio_position, event.text_position))
            i += 1
        if self.n_samples > self.max_samples:
            self.aborted = True
            return 1  # abort: the speech is already longer than allowed
        return 0

    def synthesize(self, text: str, voice: str, rate: int, max_seconds: float) -> tuple:
        with self.lock:
            if self.lib.espeak_SetVoiceByName(voice.encode("utf-8")) != 0:
                raise SpeechError(f"espeak-ng has no voice {voice!r} (try 'en', 'en-us' or 'en-gb-x-rp')")
            self.lib.espeak_SetParameter(_PARAMETER_RATE, rate, 0)
            self._reset(int(max_seconds * self.sample_rate))
            data = text.encode("utf-8") + b"\0"
            status = self.lib.espeak_Synth(data, len(data), 0, _POS_CHARACTER, 0, _CHARS_UTF8, None, None)
            self.lib.espeak_Synchronize()
            if self.aborted:
                raise SpeechError(
                    f"text too long: its speech runs past {max_seconds:g} s, the length allowed (the frame range)"
                )
            if status != 0:
                raise SpeechError(f"espeak-ng could not synthesise the text (error {status})")
            samples = np.frombuffer(b"".join(self.chunks), dtype="<i2").astype(np.int16)
            return samples, list(self.events)


_engine: _Engine | None = None
_engine_lock = threading.Lock()


def _get_engine() -> _Engine:
    global _engine
    with _engine_lock:
        if _engine is None:
            _engine = _Engine(*find_library())
        return _engine


def check_text(text: str, max_characters: int = MAX_TEXT_CHARACTERS) -> str:
    """The text to speak, stripped; SpeechError if it is empty, too long or not plain text."""
    if not isinstance(text, str):
        raise SpeechError(f"the text to speak must be a string, not {type(text).__name__}")
    stripped = text.strip()
    if not stripped:
        raise SpeechError("the text to speak is empty")
    if "\0" in stripped:
        raise SpeechError(f"the text to speak holds a NUL character at position {stripped.index(chr(0)) + 1}")
    try:
        stripped.encode("utf-8")
    except UnicodeEncodeError as exc:
        raise SpeechError(f"the text to speak holds a character that is not text at position {exc.start + 1}") from None
    if len(stripped) > max_characters:
        raise SpeechError(f"text too long: {len(stripped)} characters, more than the {max_characters} allowed")
    return stripped


def synthesize(
    text: str,
    voice: str = DEFAULT_VOICE,
    *,
    rate: int = DEFAULT_RATE,
    max_seconds: float = DEFAULT_MAX_SECONDS,
) -> Speech:
    """Speak `text` with an espeak-ng voice: its phonemes with times and the audio, from one synthesis.

    `rate` is in words per minute (80..450). Synthesis stops, and SpeechError says the text is too long, as
    soon as the audio passes `max_seconds` (pass the frame range's length). Everything is checked first.
    """
    text = check_text(text)
    if not isinstance(voice, str) or not voice.strip() or len(voice) > 64 or not voice.isprintable():
        raise SpeechError(f"voice {voice!r} is not an espeak-ng voice name such as 'en' or 'en-us'")
    if isinstance(rate, bool) or not isinstance(rate, int) or not RATE_RANGE[0] <= rate <= RATE_RANGE[1]:
        raise SpeechError(f"speaking rate {rate!r} is not a whole number of words per minute in 80..450")
    if (
        isinstance(max_seconds, bool)
        or not isinstance(max_seconds, int | float)
        or not (math.isfinite(max_seconds) and max_seconds > 0)
    ):
        raise SpeechError(f"the length cap {max_seconds!r} is not a positive number of seconds")
    engine = _get_engine()
    samples, events = engine.synthesize(text, voice.strip(), rate, float(max_seconds))
    total = len(samples) / engine.sample_rate
    starts = [position / 1000.0 for _, position, _ in events]
    for k in range(1, len(starts)):
        if starts[k] < starts[k - 1]:
            raise SpeechError(f"espeak-ng reported phoneme {k + 1} ({events[k][0]!r}) before the one ahead of it")
    ends = [*starts[1:], max(total, starts[-1])] if starts else []
    phonemes = tuple(
        Phoneme(name, start, end, position)
        for (name, _, position), start, end in zip(events, starts, ends, strict=True)
    )
    return Speech(text, voice.strip(), phonemes, samples, engine.sample_rate)


def reported_labels(speech: Speech) -> list[TimedLabel]:
    """The synthesis's phonemes as timed labels, at the times espeak-ng reports (a stop at its burst)."""
    return [TimedLabel(p.start, p.end, p.label, f"espeak-ng phoneme {k + 1}") for k, p in enumerate(speech.phonemes)]


def phoneme_labels(speech: Speech) -> list[TimedLabel]:
    """The synthesis's phonemes as timed labels, each stop from the onset of its closure (`stops_from_closure`):
    what Speak Text keys (save them with `cue_files.write_timed_labels`)."""
    return stops_from_closure(reported_labels(speech), speech.samples, speech.sample_rate)


# espeak-ng's stops (its mnemonics, stress marks stripped): plosives and affricates, each made of a closure (the
# articulators shut, silence) and a release (the burst)
STOPS = frozenset({"p", "b", "t", "d", "k", "g", "t#", "t2", "d#", "t[", "d[", "tS", "dZ"})
MAX_CLOSURE = 0.12  # s: the longest closure taken; a stop's closure lasts about 50-100 ms in running speech
QUIET_DB = 40.0  # a closure's silence: this far below the take's loudest 5 ms
ENVELOPE_SECONDS = 0.005


def stops_from_closure(labels: list[TimedLabel], samples: np.ndarray, sample_rate: int) -> list[TimedLabel]:
    """`labels` (in order, each ending where the next starts) with each stop starting at the onset of its closure.

    espeak-ng reports a stop at its burst and counts the silent closure before it to the phoneme ahead, so a face
    keyed from the reported times closes its lips only as the synthesised voice opens them (20-60 ms late). The
    articulation of a stop begins with its closure (closure, hold, release); the lips are shut during the silence.
    Reading chosen: a stop starts at the onset of the quiet run (`QUIET_DB` below the loudest 5 ms of the take)
    that ends at its reported start, at most `MAX_CLOSURE` earlier and leaving the phoneme ahead at least 5 ms.
    The first phoneme is left as reported (a take's opening silence says nothing of when the lips shut)."""
    labels = list(labels)
    x = np.asarray(samples, dtype=np.float64)
    n = max(int(ENVELOPE_SECONDS * sample_rate), 1)
    if len(x) < n or len(labels) < 2:
        return labels
    envelope = np.sqrt(np.mean(x[: len(x) // n * n].reshape(-1, n) ** 2, axis=1))
    quiet = envelope < envelope.max() * 10 ** (-QUIET_DB / 20)
    for i in range(1, len(labels)):
        if labels[i].label.lstrip("',%=!") not in STOPS:
            continue
        k = min(int(round(labels[i].start / ENVELOPE_SECONDS)), len(quiet))
        floor = max(
            int(np.ceil(labels[i - 1].start / ENVELOPE_SECONDS)) + 1, k - int(round(MAX_CLOSURE / ENVELOPE_SECONDS))
        )
        j = k
        while j - 1 >= floor and quiet[j - 1]:
            j -= 1
        if j < k:
            labels[i - 1] = labels[i - 1]._replace(end=j * ENVELOPE_SECONDS)
            labels[i] = labels[i]._replace(start=j * ENVELOPE_SECONDS)
    return labels


def speech_segments(speech: Speech, phonemes: PhonemeTable | None = None) -> list[Segment]:
    """The viseme segments of a synthesis: a silence up to the first phoneme, then its phonemes."""
    labels = phoneme_labels(speech)
    if not labels:
        raise SpeechError(f"espeak-ng produced no phonemes for {speech.text[:40]!r}")
    if labels[0].start > 0:
        labels.insert(0, TimedLabel(0.0, labels[0].start, "_", "silence before the first phoneme"))
    return segments_from_labels(labels, phonemes, source=f"espeak-ng voice {speech.voice!r}")
