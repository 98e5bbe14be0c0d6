"""Writing mono 16-bit PCM audio as a WAV file (stdlib `wave`), for the speech that goes with FAP tracks."""

from __future__ import annotations

import contextlib
import os
import secrets
import wave
from pathlib import Path

import numpy as np

from . import SpeechError

MAX_SAMPLE_RATE = 384_000


def write_wav(path, samples: np.ndarray, sample_rate: int) -> Path:
    """Write (N,) int16 samples at `sample_rate` Hz to `path`, replacing it atomically; returns the path."""
    samples = np.asarray(samples)
    if samples.ndim != 1 or samples.dtype != np.int16:
        raise SpeechError(f"{path}: audio must be a 1-D array of int16 samples, got {samples.dtype} {samples.shape}")
    if isinstance(sample_rate, bool) or not isinstance(sample_rate, int | np.integer):
        raise SpeechError(f"{path}: sample rate {sample_rate!r} is not a whole number of Hz")
    if not 1 <= sample_rate <= MAX_SAMPLE_RATE:
        raise SpeechError(f"{path}: sample rate {sample_rate} Hz is outside 1..{MAX_SAMPLE_RATE}")
    path = Path(path)
    temporary = path.with_name(f".{path.name}.{secrets.token_hex(4)}.tmp")
    try:
        with open(temporary, "wb") as file, wave.open(file, "wb") as out:
            out.setnchannels(1)
            out.setsampwidth(2)
            out.setframerate(int(sample_rate))
            out.writeframes(samples.astype("<i2").tobytes())
        os.replace(temporary, path)
    except OSError as exc:
        with contextlib.suppress(OSError):  # a name too long to create is too long to remove
            temporary.unlink(missing_ok=True)
        raise SpeechError(f"{path}: cannot write the audio: {exc.strerror or exc}") from None
    return path
