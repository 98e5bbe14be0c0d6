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
_FFT = 256


def _band_matrix() -> np.ndarray:
    """(FFT bins, N_BANDS) 0/1: which mel-spaced band each bin above 0 Hz falls in."""
    mel = 2595.0 * np.log10(1.0 + np.fft.rfftfreq(_FFT, 1.0 / RATE) / 700.0)
    edges = np.linspace(mel[1], mel[-1], N_BANDS + 1)
    band = np.clip(np.searchsorted(edges, mel, side="right") - 1, 0, N_BANDS - 1)
    matrix = np.zeros((len(mel), N_BANDS))
    matrix[np.arange(1, len(mel)), band[1:]] = 1.0
    return matrix


def log_band_energies(samples: np.ndarray) -> np.ndarray:
    """(frames, N_BANDS) log energies of Hamming-windowed spectra every HOP_SECONDS; frame k covers samples
    [hop k, hop k + window)."""
    window, hop = int(WINDOW_SECONDS * RATE), int(HOP_SECONDS * RATE)
    frames = 1 + max(0, (len(samples) - window) // hop)
    x = np.zeros(max(len(samples), window), np.float64)
    x[: len(samples)] = samples
    index = np.arange(window)[None, :] + hop * np.arange(frames)[:, None]
    power = np.abs(np.fft.rfft(x[index] * np.hamming(window), _FFT)) ** 2
    return np.log(power @ _band_matrix() + 1e-10)


def spectral_change(samples: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(times s, change): at each instant between two spectrum frames, the RMS difference (nepers) between the
    mean log band energies of the SIDE_SECONDS after and before it; 0 where a side does not fit."""
    energies = log_band_energies(samples)
    side = int(round(SIDE_SECONDS / HOP_SECONDS))
    total = np.vstack([np.zeros((1, N_BANDS)), np.cumsum(energies, axis=0)])
    change = np.zeros(len(energies) + 1)
    if len(energies) >= 2 * side:
        t = np.arange(side, len(energies) - side + 1)
        before = (total[t] - total[t - side]) / side
        after = (total[t + side] - total[t]) / side
        change[t] = np.sqrt(np.mean((after - before) ** 2, axis=1))
    # instant t lies between frames t - 1 and t: half-way between their centres
    times = (np.arange(len(change)) * HOP_SECONDS * RATE + WINDOW_SECONDS * RATE / 2 - HOP_SECONDS * RATE / 2) / RATE
    return times, change


def refine_boundaries(
    phones: list[TimedLabel], samples: np.ndarray, radius: float, abrupt: Callable[[str], bool]
) -> list[TimedLabel]:
    """Each boundary between two touching phones, one of them `abrupt` (by label), moved to the strongest
    spectral change within `radius` s of it (one decoder frame), each phone kept at least MIN_PHONE_SECONDS
    long; times and order otherwise kept."""
    if len(phones) < 2:
        return list(phones)
    times, change = spectral_change(samples)
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
