"""Recognised phones that are an /m/'s murmur, heard as a rounded vowel, a w or an l (no bpy).

Without a transcript the phone recogniser, trained on human speech, hears espeak-ng's /m/ as /w/, /uw/, /uh/ or
/l/ (docs/voice.md): all sonorants with a low first and second formant, as a nasal murmur has. What tells a
murmur apart is that the mouth is closed: the sound leaves through the nose, whose long, damped tract passes
the voice's lowest harmonics (the nasal formant, about 250 Hz) and little above 2.5 kHz, where an open vowel,
a w or an l keeps its third and higher formants. So a recognised phone of `MURMUR_HEARD_AS` whose energy
from `HIGH_HZ` is `MAX_HIGH_TO_LOW_DB` or more below its energy in `LOW_HZ` is taken for an /m/, and the lips
close. Both band energies are measured above the recording's noise floor (the quietest `FLOOR_PERCENTILE` %
of each band), so that noise filling the high band does not hide a murmur.

Measured on the clean dev takes (espeak-ng's en-us and en voices; 10th-90th percentile of each phoneme's
high-to-low ratio): /m/ -23 to -18 dB (median -21), /n/ -24 to -16, /u:/ -18 to -13, /l/ -11 to -2. An /n/
the recogniser hears as one of these phones also becomes an /m/: the price of finding the /m/ it misses.
"""

from __future__ import annotations

import numpy as np

from .boundaries import FLOOR_PERCENTILE, HOP_SECONDS, WINDOW_SECONDS, band_centres_hz, log_band_energies
from .segments import TimedLabel

MURMUR_HEARD_AS = frozenset({"w", "uw", "uh", "l"})  # CMU phones, as the recogniser writes them
LOW_HZ = (80.0, 400.0)  # the nasal formant and the voice's lowest harmonics
HIGH_HZ = (2500.0, 5000.0)  # third formant and above
MAX_HIGH_TO_LOW_DB = -18.0


def murmurs_as_m(phones: list[TimedLabel], samples: np.ndarray) -> list[TimedLabel]:
    """`phones` with each one of MURMUR_HEARD_AS that sounds like a nasal murmur renamed "m"."""
    if not any(p.label in MURMUR_HEARD_AS for p in phones):
        return list(phones)
    power = np.exp(log_band_energies(samples))
    centres = band_centres_hz()
    levels = []
    for low, high in (LOW_HZ, HIGH_HZ):
        band = power[:, (centres >= low) & (centres < high)].sum(axis=1)
        levels.append(np.maximum(band - np.percentile(band, FLOOR_PERCENTILE), 0.0))
    low_band, high_band = levels
    centre = np.arange(len(power)) * HOP_SECONDS + WINDOW_SECONDS / 2
    out = []
    for phone in phones:
        inside = (centre >= phone.start) & (centre < phone.end)
        if phone.label in MURMUR_HEARD_AS and inside.any():
            low, high = low_band[inside].sum(), high_band[inside].sum()
            if high <= low * 10 ** (MAX_HIGH_TO_LOW_DB / 10) and low > 0:
                phone = phone._replace(label="m")
        out.append(phone)
    return out
