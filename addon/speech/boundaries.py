"""Phone boundaries moved, within the decoder's own time step, to where the spectrum changes most (no bpy).

PocketSphinx times phones in whole frames (10 ms for alignment), so a boundary it reports can be off by up to a
frame from the acoustic event that ends one phone and starts the next: a closure's silence beginning, a
burst, a nasal's murmur starting, a fricative's noise. Those events are abrupt, so they show as a peak of
spectral change at a finer time step. `refine_boundaries` measures, every `HOP_SECONDS`, how far the mean log
band spectrum of the `SIDE_SECONDS` after each instant is from that of the `SIDE_SECONDS` before it, and moves
each boundary to the peak of that change no further than one decoder frame away, keeping every phone at least
`MIN_PHONE_SECONDS` long. Only boundaries with an abrupt sound on one side (a stop, fricative, nasal or
silence: the caller says which labels are) are moved: between vowels, glides and liquids the spectrum glides
and its largest change within a frame is no event ("please": /l/ into /i:/ moved 7 ms the wrong way).

The aligner also hears faint sound as silence: the murmur of an /m/ after a pause (espeak-ng's "..., Mum":
the first 80 ms of the /m/, 15-22 dB below the loudest frame, aligned as silence; a take that starts on
"Maybe": 100 ms). `sound_into_silence` gives the sound at the edge of a silence back to the phone next to it:
a frame is sound when it is `SOUND_MARGIN_DB` above the recording's noise floor (its quietest
`FLOOR_PERCENTILE` %: pauses and closures) and within `SOUND_RANGE_DB` of its loudest frame (so that the
floor of digital silence does not make a faint tail sound).

Where the transcript has a pause (punctuation, and its end), the aligner may not: a pause that is not silent (a
voiced tail fading out, room noise) scores better as the phone before it than as silence, and the word's last
phone runs through it. `pauses_at` ends that phone where its sound does: the run of frames at its end that are
`PAUSE_DB` or more under the take's vowels (the 90th percentile of its sound frames' levels: vowels are the
loudest sounds and most of the sounding time) is quieter than any phone, and goes to a silence.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from .recording import RATE
from .segments import TimedLabel

HOP_SECONDS = 0.0025  # the finer time step: a quarter of an alignment frame
WINDOW_SECONDS = 0.010  # short-time spectrum window (Hamming)
SIDE_SECONDS = 0.010  # spectra averaged on each side of an instant
N_BANDS = 24  # mel-spaced bands
MIN_PHONE_SECONDS = 0.010
FLOOR_PERCENTILE = 10.0
SOUND_MARGIN_DB = 10.0
SOUND_RANGE_DB = 50.0
# The weakest English phone, /th/, carries about 28 dB less power than the strongest vowel (Fletcher's phonetic
# powers: /th/ 1, /o/ as in "talk" 680), so a frame 30 dB or more under the take's vowels is no phone: a pause.
# Relative to the take's own level, so it holds for a recorded pause with room noise as for digital silence.
PAUSE_DB = 30.0
VOWEL_PERCENTILE = 90.0  # the take's vowel level: this percentile of its sound frames' levels
BLOCK_FRAMES = 4096  # spectra computed at a time (about 10 s of sound)
_FFT = 256


def _mel(hz):
    return 2595.0 * np.log10(1.0 + np.asarray(hz) / 700.0)


def _band_edges_mel() -> np.ndarray:
    return np.linspace(_mel(RATE / _FFT), _mel(RATE / 2), N_BANDS + 1)


def band_centres_hz() -> np.ndarray:
    """(N_BANDS,) the centre frequency of each band of `log_band_energies`."""
    edges = _band_edges_mel()
    return 700.0 * (10.0 ** ((edges[:-1] + edges[1:]) / 2 / 2595.0) - 1.0)


def _band_matrix() -> np.ndarray:
    """(FFT bins, N_BANDS) 0/1: which mel-spaced band each bin above 0 Hz falls in."""
    mel = _mel(np.fft.rfftfreq(_FFT, 1.0 / RATE))
    band = np.clip(np.searchsorted(_band_edges_mel(), mel, side="right") - 1, 0, N_BANDS - 1)
    matrix = np.zeros((len(mel), N_BANDS))
    matrix[np.arange(1, len(mel)), band[1:]] = 1.0
    return matrix


def log_band_energies(samples: np.ndarray) -> np.ndarray:
    """(frames, N_BANDS) log energies of Hamming-windowed spectra every HOP_SECONDS; frame k covers samples
    [hop k, hop k + window). Computed BLOCK_FRAMES at a time, so that a long take needs little memory beyond
    the result (N_BANDS floats a frame)."""
    window, hop = int(WINDOW_SECONDS * RATE), int(HOP_SECONDS * RATE)
    frames = 1 + max(0, (len(samples) - window) // hop)
    x = samples if len(samples) >= window else np.pad(samples, (0, window - len(samples)))
    taper, bands = np.hamming(window), _band_matrix()
    out = np.empty((frames, N_BANDS))
    for first in range(0, frames, BLOCK_FRAMES):
        count = min(BLOCK_FRAMES, frames - first)
        index = np.arange(window)[None, :] + hop * np.arange(first, first + count)[:, None]
        power = np.abs(np.fft.rfft(x[index] * taper, _FFT)) ** 2
        out[first : first + count] = np.log(power @ bands + 1e-10)
    return out


def _instants(frames: int) -> np.ndarray:
    """Times (s) of the instants 0..frames between spectrum frames: instant t lies half-way between the
    centres of frames t - 1 and t."""
    return np.arange(frames + 1) * HOP_SECONDS + (WINDOW_SECONDS - HOP_SECONDS) / 2


def spectral_change(energies: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(times s, change): at each instant between two frames of `log_band_energies`, the RMS difference
    (nepers) between the mean log band energies of the SIDE_SECONDS after and before it; 0 where a side does
    not fit."""
    side = int(round(SIDE_SECONDS / HOP_SECONDS))
    total = np.vstack([np.zeros((1, N_BANDS)), np.cumsum(energies, axis=0)])
    change = np.zeros(len(energies) + 1)
    if len(energies) >= 2 * side:
        t = np.arange(side, len(energies) - side + 1)
        before = (total[t] - total[t - side]) / side
        after = (total[t + side] - total[t]) / side
        change[t] = np.sqrt(np.mean((after - before) ** 2, axis=1))
    return _instants(len(energies)), change


def _levels_db(energies: np.ndarray) -> np.ndarray:
    return 10.0 * np.log10(np.exp(energies).sum(axis=1))


def sound_frames(energies: np.ndarray) -> np.ndarray:
    """(frames,) True where a frame of `log_band_energies` holds sound (see the module docstring)."""
    level = _levels_db(energies)
    floor = np.percentile(level, FLOOR_PERCENTILE)
    return level > max(floor + SOUND_MARGIN_DB, level.max() - SOUND_RANGE_DB)


def refine_boundaries(
    phones: list[TimedLabel], energies: np.ndarray, radius: float, abrupt: Callable[[str], bool]
) -> list[TimedLabel]:
    """Each boundary between two touching phones, one of them `abrupt` (by label), moved to the strongest
    spectral change within `radius` s of it (one decoder frame), each phone kept at least MIN_PHONE_SECONDS
    long; times and order otherwise kept. `energies`: the recording's `log_band_energies`."""
    if len(phones) < 2:
        return list(phones)
    times, change = spectral_change(energies)
    out = list(phones)
    for i in range(1, len(out)):
        boundary = out[i].start
        if abs(out[i - 1].end - boundary) > 1e-9 or not (abrupt(out[i - 1].label) or abrupt(out[i].label)):
            continue  # a gap (nothing to share), or a gliding change
        low = max(boundary - radius, out[i - 1].start + MIN_PHONE_SECONDS)
        high = min(boundary + radius, out[i].end - MIN_PHONE_SECONDS)
        first, last = np.searchsorted(times, low, "left"), np.searchsorted(times, high, "right")
        if last <= first:
            continue
        moved = float(times[first + int(np.argmax(change[first:last]))])
        out[i - 1] = out[i - 1]._replace(end=moved)
        out[i] = out[i]._replace(start=moved)
    return out


def sound_into_silence(
    phones: list[TimedLabel], energies: np.ndarray, silent: Callable[[str], bool]
) -> list[TimedLabel]:
    """Each run of sound frames at the edge of a `silent` phone (by label) that touches a phone of speech
    given to that phone, the silence kept at least MIN_PHONE_SECONDS long. `energies`: the recording's
    `log_band_energies`."""
    if len(phones) < 2:
        return list(phones)
    sound, times = sound_frames(energies), _instants(len(energies))
    out = list(phones)
    for i in range(1, len(out)):
        before, after = out[i - 1], out[i]
        if abs(before.end - after.start) > 1e-9 or silent(before.label) == silent(after.label):
            continue
        first = t = int(np.clip(np.searchsorted(times, after.start), 0, len(sound)))
        if silent(before.label):  # speech after a silence starts where its sound does
            while t > 0 and sound[t - 1] and times[t - 1] >= before.start + MIN_PHONE_SECONDS:
                t -= 1
        else:  # speech before a silence lasts while its sound does
            while t < len(sound) and sound[t] and times[t + 1] <= after.end - MIN_PHONE_SECONDS:
                t += 1
        if t != first:
            moved = float(times[t])
            out[i - 1], out[i] = before._replace(end=moved), after._replace(start=moved)
    return out


def pauses_at(
    phones: list[TimedLabel],
    energies: np.ndarray,
    breaks: list[float],
    silent: Callable[[str], bool],
    silence: str = "sil",
) -> list[TimedLabel]:
    """At each of `breaks` (times, s, where a word the transcript follows with a pause ends: the aligner's word
    ends), the phone of speech that ends that word ends where its sound does: the run of frames at its end that
    are PAUSE_DB or more under the take's vowel level goes to the silence after the phone (one named `silence`
    is put in where the phone touches the next word), the phone kept at least MIN_PHONE_SECONDS long. The run is
    read from the phone's last frame whose window it holds. `energies`: the recording's `log_band_energies`."""
    if not phones or not len(energies):
        return list(phones)
    level = _levels_db(energies)
    sound = sound_frames(energies)
    quiet = level < np.percentile(level[sound] if sound.any() else level, VOWEL_PERCENTILE) - PAUSE_DB
    instants = _instants(len(energies))
    centres = instants[:-1] + HOP_SECONDS / 2
    out = list(phones)
    starts = [p.start for p in out]
    for moment in sorted(breaks):
        # the word's last phone: aligned phones last 30 ms or more, and each boundary moved by at most a frame
        # (10 ms), so it starts over 15 ms before the word's end, and the next word's first phone after that
        i = int(np.searchsorted(starts, moment - 0.015)) - 1
        if i < 0 or silent(out[i].label):
            continue
        phone = out[i]
        # the phone's last frame whose window it holds (the next word's onset shows in the windows over the boundary)
        last = int(np.searchsorted(centres, phone.end - WINDOW_SECONDS / 2, "right")) - 1
        first = last
        while first >= 0 and quiet[first] and centres[first] > phone.start + MIN_PHONE_SECONDS:
            first -= 1
        if first == last:
            continue
        cut = float(instants[first + 1])
        out[i] = phone._replace(end=cut)
        if i + 1 < len(out) and silent(out[i + 1].label):
            out[i + 1] = out[i + 1]._replace(start=cut)
        else:
            out.insert(i + 1, TimedLabel(cut, phone.end, silence, f"pause at {cut:.2f} s"))
            starts.insert(i + 1, cut)
    return out
