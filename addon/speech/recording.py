"""A voice recording -> 16 kHz mono samples for PocketSphinx, checked (no bpy).

WAV files are read here (RIFF chunks: integer PCM of 8, 16, 24 or 32 bits, 32/64-bit float, plain or
WAVE_FORMAT_EXTENSIBLE, any rate, any number of channels). Other formats (FLAC, OGG, MP3, ...) are decoded by
Blender's audio library `aud` where it is there (inside Blender, or with the `bpy` module); elsewhere they get
a message saying to convert them to WAV. The channels are averaged and the rate changed to 16 kHz, the rate
of the acoustic model, by a windowed-sinc filter (`resample`).

Refused with `RecordingError`, before anything else runs: a file that is not audio, holds no samples, is
silent (peak below -60 dBFS), is clipped (more than `MAX_CLIPPED` of its samples in runs stuck at full
scale) or lasts longer than the cap.
"""

from __future__ import annotations

import math
import struct
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..user_files import read_regular_file
from . import SpeechError

RATE = 16_000  # Hz, the acoustic model's
DEFAULT_MAX_SECONDS = 1800.0
MAX_FILE_BYTES = 2**31  # a 30-minute stereo 96 kHz 32-bit WAV is 1.4 GB
SILENT_PEAK = 10 ** (-60 / 20)  # -60 dBFS
CLIP_LEVEL = 0.999
MAX_CLIPPED = 0.01  # share of samples in clipped runs (3 or more full-scale samples in a row)
WAV_NAMES = (".wav", ".wave")

_PCM, _FLOAT, _EXTENSIBLE = 1, 3, 0xFFFE


class RecordingError(SpeechError):
    """A recording that cannot be used: not audio, empty, silent, clipped or too long."""


@dataclass(frozen=True, eq=False)
class Recording:
    samples: np.ndarray  # (N,) float32 at RATE, full scale = 1
    source: str  # the file, for messages

    @property
    def duration(self) -> float:
        return len(self.samples) / RATE


# ----------------------------------------------------------------------------- WAV


def _chunks(data: bytes, source: str) -> dict[bytes, tuple[int, int]]:
    """RIFF chunk id -> (offset, size) of its payload (the first of each id); a truncated data chunk keeps
    what is there, as players do."""
    if len(data) < 12 or data[:4] not in (b"RIFF", b"RF64") or data[8:12] != b"WAVE":
        raise RecordingError(f"{source}: not a WAV file (no RIFF/WAVE header)")
    out = {}
    i = 12
    while i + 8 <= len(data):
        kind, size = struct.unpack_from("<4sI", data, i)
        size = min(size, len(data) - i - 8)
        out.setdefault(kind, (i + 8, size))
        i += 8 + size + (size & 1)
    return out


def decode_wav(data: bytes, source: str) -> tuple[np.ndarray, int]:
    """(frames, channels) float64 samples in -1..1 and the rate of a WAV file's bytes."""
    chunks = _chunks(data, source)
    if b"fmt " not in chunks or b"data" not in chunks:
        raise RecordingError(f"{source}: a WAV file without its {'fmt' if b'fmt ' not in chunks else 'data'} chunk")
    offset, size = chunks[b"fmt "]
    if size < 16:
        raise RecordingError(f"{source}: the WAV format chunk is {size} bytes, too short")
    tag, channels, rate, _, align, bits = struct.unpack_from("<HHIIHH", data, offset)
    if tag == _EXTENSIBLE and size >= 40:
        tag = struct.unpack_from("<H", data, offset + 24)[0]  # the sub-format GUID's first two bytes
    width = bits // 8
    if tag not in (_PCM, _FLOAT) or bits % 8 or (tag == _PCM and width not in (1, 2, 3, 4)):
        raise RecordingError(
            f"{source}: WAV encoding {tag} with {bits}-bit samples is not read here (8-32 bit PCM or float): "
            "convert it to 16-bit PCM WAV"
        )
    if tag == _FLOAT and width not in (4, 8):
        raise RecordingError(f"{source}: {bits}-bit float samples are not read here (32 or 64 bit)")
    if not 1 <= channels <= 32 or align != channels * width:
        raise RecordingError(f"{source}: the WAV header is broken ({channels} channels, block size {align})")
    if not 1000 <= rate <= 384_000:
        raise RecordingError(f"{source}: sample rate {rate} Hz is outside 1000..384000")
    offset, size = chunks[b"data"]
    frames = size // align
    raw = np.frombuffer(data, dtype=np.uint8, count=frames * align, offset=offset)
    if tag == _FLOAT:
        samples = raw.view("<f4" if width == 4 else "<f8").astype(np.float64)
        if not np.all(np.isfinite(samples)):
            raise RecordingError(f"{source}: the WAV file holds samples that are not finite numbers")
    elif width == 1:
        samples = (raw.astype(np.float64) - 128.0) / 128.0  # 8-bit WAV is unsigned
    elif width == 3:
        triples = raw.reshape(-1, 3).astype(np.int32)
        value = triples[:, 0] | (triples[:, 1] << 8) | (triples[:, 2] << 16)
        samples = (value - ((value & 0x800000) << 1)) / float(2**23)
    else:
        samples = raw.view("<i2" if width == 2 else "<i4") / float(2 ** (bits - 1))
    return samples.reshape(frames, channels), rate


# ----------------------------------------------------------------------------- other formats


def open_with_aud(path: Path):
    """An `aud.Sound` of a file, through Blender's audio library; RecordingError where there is none or it
    cannot read the file."""
    try:
        import aud
    except ImportError:
        raise RecordingError(
            f"{path}: only WAV files are read outside Blender; convert it to WAV (e.g. `ffmpeg -i "
            f"{path.name} {path.stem}.wav`) or run this inside Blender"
        ) from None
    try:
        sound = aud.Sound(str(path))
    except Exception as exc:  # aud.error, and whatever its decoders raise on a broken file
        raise RecordingError(f"{path}: not a sound file Blender can read ({exc})") from None
    return sound


def decode_aud_sound(sound, source: str, max_seconds: float = DEFAULT_MAX_SECONDS) -> np.ndarray:
    """(N,) float samples at RATE of an `aud.Sound` (a file, or a sound strip's `sound.factory`)."""
    try:
        rate, channels = sound.specs
        length = sound.length
    except Exception as exc:
        raise RecordingError(f"{source}: not a sound Blender can read ({exc})") from None
    if rate <= 0 or channels <= 0 or length < 0:
        raise RecordingError(f"{source}: not a sound Blender can read")
    if length / rate > max_seconds:
        raise RecordingError(_too_long(source, length / rate, max_seconds))
    try:
        data = sound.rechannel(1).resample(RATE, 2).data()
    except Exception as exc:
        raise RecordingError(f"{source}: Blender could not decode the sound ({exc})") from None
    return np.asarray(data, dtype=np.float64).ravel()


# ----------------------------------------------------------------------------- resampling


def _kernel(up: int, down: int, zero_crossings: int = 16) -> tuple[np.ndarray, int]:
    """Polyphase windowed-sinc taps (up, 2*half) for rate * up / down, and `half`: a low-pass at 0.9 of the
    lower Nyquist frequency, Kaiser window (beta 8.6, about 90 dB stop band)."""
    cutoff = 0.9 * min(1.0, up / down)  # in units of the input's Nyquist frequency
    half = math.ceil(zero_crossings / cutoff)
    phases = (np.arange(up) * down % up) / up  # fractional input position of output n, by n % up
    offsets = np.arange(-half + 1, half + 1)
    x = offsets[None, :] - phases[:, None]
    window = np.kaiser(2 * half + 1, 8.6)
    window = np.interp(x, np.arange(-half, half + 1), window)
    taps = cutoff * np.sinc(cutoff * x) * window
    return taps / taps.sum(axis=1, keepdims=True), half


def resample(samples: np.ndarray, rate: int, new_rate: int = RATE) -> np.ndarray:
    """(N,) samples at `rate` -> at `new_rate`, by a polyphase windowed-sinc filter (outside the signal the
    input counts as silence). The outputs of one phase (n % up) read the input at a fixed stride, so each
    phase is one product of a strided view of the input's windows with its taps: no index arrays, and
    memory stays the input's and the output's."""
    samples = np.asarray(samples, dtype=np.float64)
    if rate == new_rate:
        return samples.astype(np.float32)
    g = math.gcd(rate, new_rate)
    up, down = new_rate // g, rate // g
    taps, half = _kernel(up, down)
    n_out = (len(samples) * up) // down
    padded = np.concatenate([np.zeros(half), samples, np.zeros(half + 1)])
    windows = np.lib.stride_tricks.sliding_window_view(padded, 2 * half)  # window j: input j - half + 1 ...
    out = np.empty(n_out, dtype=np.float32)
    for phase in range(min(up, n_out)):
        first = (phase * down) // up + 1  # output n reads from input n * down // up - half + 1 on
        count = len(range(phase, n_out, up))
        out[phase::up] = windows[first : first + down * count : down] @ taps[phase]
    return out


# ----------------------------------------------------------------------------- checks


def _too_long(source: str, seconds: float, max_seconds: float) -> str:
    return (
        f"{source}: the recording lasts {seconds:.1f} s, longer than the {max_seconds:g} s allowed: cut it into "
        "shorter takes"
    )


def check_samples(samples: np.ndarray, source: str) -> None:
    """RecordingError if (N,) samples in -1..1 are empty, silent or clipped."""
    if len(samples) == 0:
        raise RecordingError(f"{source}: the recording holds no samples")
    peak = float(np.max(np.abs(samples)))
    if peak < SILENT_PEAK:
        raise RecordingError(f"{source}: the recording is silent (its loudest sample is {_dbfs(peak)})")
    at_full = np.abs(samples) >= CLIP_LEVEL
    # a sample is in a clipped run when it and its two neighbours on one side are all at full scale
    run = at_full[2:] & at_full[1:-1] & at_full[:-2]
    clipped = np.zeros(len(samples), dtype=bool)
    for shift in range(3):
        clipped[shift : shift + len(run)] |= run
    share = clipped.mean()
    if share > MAX_CLIPPED:
        raise RecordingError(
            f"{source}: the recording is clipped ({share:.1%} of its samples are stuck at full scale): record "
            "it again at a lower level"
        )


def _dbfs(value: float) -> str:
    return "-inf dBFS" if value <= 0 else f"{20 * math.log10(value):.0f} dBFS"


def read_recording(path, max_seconds: float = DEFAULT_MAX_SECONDS) -> Recording:
    """A recording file -> checked 16 kHz mono samples (see the module docstring)."""
    if not (isinstance(max_seconds, int | float) and math.isfinite(max_seconds) and max_seconds > 0):
        raise RecordingError(f"the length cap {max_seconds!r} is not a positive number of seconds")
    path = Path(path)
    source = str(path)
    if path.suffix.lower() not in WAV_NAMES and not _looks_like_wav(path):
        if not path.is_file():
            raise RecordingError(f"{source}: no such file (or not a regular file)")
        return from_aud_sound(open_with_aud(path), source, max_seconds)
    data = read_regular_file(path, MAX_FILE_BYTES, RecordingError, source, "larger than 2 GiB")
    frames, rate = decode_wav(data, source)
    if len(frames) / rate > max_seconds:
        raise RecordingError(_too_long(source, len(frames) / rate, max_seconds))
    check_samples(frames.ravel(), source)  # clipping shows in a channel, before channels average
    mono = resample(frames.mean(axis=1), rate)
    return Recording(np.clip(mono, -1.0, 1.0).astype(np.float32), source)


def from_aud_sound(sound, source: str, max_seconds: float = DEFAULT_MAX_SECONDS) -> Recording:
    """A recording from an `aud.Sound` (e.g. a sound strip's `sound.factory`, packed or not), checked."""
    mono = decode_aud_sound(sound, source, max_seconds)
    check_samples(mono, source)
    return Recording(np.clip(mono, -1.0, 1.0).astype(np.float32), source)


def _looks_like_wav(path: Path) -> bool:
    try:
        with open(path, "rb") as file:
            head = file.read(12)
    except OSError:
        return False
    return head[:4] in (b"RIFF", b"RF64") and head[8:12] == b"WAVE"


def from_samples(samples: np.ndarray, rate: int, source: str = "the audio") -> Recording:
    """A recording from (N,) int16 or float samples at `rate` (e.g. espeak-ng's synthesis), checked."""
    samples = np.asarray(samples)
    if samples.dtype == np.int16:
        samples = samples / 32768.0
    samples = samples.astype(np.float64)
    check_samples(samples, source)
    return Recording(np.clip(resample(samples, int(rate)), -1.0, 1.0), source)
