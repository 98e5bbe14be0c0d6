"""Recognised phones whose sound shows closed lips: an /m/'s murmur, a /p/'s burst, a closure's silence (no bpy).

Without a transcript the phone recogniser, trained on human speech, hears espeak-ng's /m/ as /w/, /uw/, /uh/
or /l/, its /p/ as /k/, /t/ or /th/ and, in noise, its /p/ and /b/ as /f/ and /v/ (docs/voice.md), and the
lips of the face stay open. Four acoustic cues of a bilabial, from how the sound is made, correct such
phones (`bilabials_from_acoustics`):

- **Murmur.** /w/, /uw/, /uh/ and /l/ are sonorants with a low first and second formant, as a nasal murmur
  has. In a murmur the mouth is closed: the sound leaves through the nose, whose long, damped tract passes
  the voice's lowest harmonics (the nasal formant, about 250 Hz) and little above 2.5 kHz, where a vowel, a w
  or an l keeps its third and higher formants. A phone of `MURMUR_HEARD_AS` whose energy in `HIGH_HZ` is
  `MAX_HIGH_TO_LOW_DB` or more below its energy in `LOW_HZ` is taken for an /m/. Both band energies are
  measured above the recording's noise floor (the quietest `FLOOR_PERCENTILE` % of each band), so that
  noise filling the high band does not hide a murmur. Measured on the clean dev takes (espeak-ng's en-us and
  en voices; 10th-90th percentile of each phoneme's ratio): /m/ -23 to -18 dB (median -21), /n/ -24 to -16,
  /u:/ -18 to -13, /l/ -11 to -2. An /n/ heard as one of these phones also becomes an /m/: the price of
  finding the /m/ the recogniser misses.
- **Murmur within a sonorant.** The recogniser often gives a murmur, or the voiced closure of a /b/, to the
  vowel, glide or liquid next to it ("Bob" heard as l aa g, "the map" as uh l ae p), and the whole phone's
  spectrum is then the vowel's. Within any recognised sonorant (`SONORANTS`), a run of at least
  `MIN_MURMUR_SECONDS` of frames that each have a murmur's spectrum (the test above, frame by frame) and are
  together `MURMUR_BELOW_VOWEL_DB` or more quieter than the loudest frame within `VOWEL_REACH_SECONDS` (with the
  mouth closed the sound is weaker than in the open vowel beside it: a nasal murmur by about 10 dB, a voice
  bar by more) becomes an /m/; the rest of the phone keeps its name. The voice bar of a /b/ has the same
  spectrum (only the voice's lowest harmonics pass the closed tract's walls), and the same viseme. /n/ and
  /ng/ murmurs pass this test too, so only phones heard as sonorants are split: a recognised nasal keeps its
  viseme. Measured (docs/voice.md, phones decoded once): closure recall without a transcript 85 -> 90 % on
  clean dev takes and 74 -> 82 % on held-out ones, frame agreement up 1 point on both; on the real
  recordings of pocketsphinx-testdata agreement is unchanged, and none of the 4 closures it adds there is true.
- **Burst.** The release of a stop made at the lips excites no cavity in front of the closure, so its burst
  spectrum falls with frequency ("diffuse-falling"), while an alveolar's rises and a velar's has a compact
  mid-frequency peak (Blumstein and Stevens 1979, the place templates of the burst onset spectrum). A phone of
  `BURST_HEARD_AS` whose burst (the 10 ms after the largest 10 ms rise in level within it) has a falling
  spectrum (least-squares slope of its band levels from `BURST_HZ`, in dB per octave, below zero) is taken
  for a /p/. Measured on the clean dev takes (10th-90th percentile, espeak-ng's reported burst times):
  /p/ -4.4 to -1.5 dB per octave, /t/ 0.1 to 2.1, /k/ -1.2 to 2.7.
- **Silence.** In noise the silence of a closure is filled with the noise, which the recogniser hears as
  frication at the place it hears: at the lips, /f/ or /v/. A real /f/ or /v/ is frication, noise above
  2.5 kHz (`FRICATION_HZ`) however weak; a recognised /f/ or /v/ most of whose frames hold nothing in that
  band above the recording's own noise there (within `SOUND_MARGIN_DB` of the band's floor) is the closure
  of a /p/ or /b/. The floor is the band's own: a recording's noise is mostly low (hum, rumble, a room), and
  judged by the level of all bands a weak /f/ was "silent" (on the real recordings of pocketsphinx-testdata
  106 of 258 /f/ frames closed the lips; frame agreement 50.5 -> 53.4 % with the band's floor, espeak-ng takes
  unchanged).
"""

from __future__ import annotations

import numpy as np

from .boundaries import (
    FLOOR_PERCENTILE,
    HOP_SECONDS,
    MIN_PHONE_SECONDS,
    SOUND_MARGIN_DB,
    WINDOW_SECONDS,
    band_centres_hz,
    log_band_energies,
    sound_frames,
)
from .segments import TimedLabel

MURMUR_HEARD_AS = frozenset({"w", "uw", "uh", "l"})  # CMU phones, as the recogniser writes them
# every vowel, glide and liquid of the model: the phones a murmur or a voiced closure may hide in
SONORANTS = frozenset("aa ae ah ao aw ay eh er ey ih iy ow oy uh uw w y l r".split())
MIN_MURMUR_SECONDS = 0.030  # two of the recogniser's 15 ms shortest phones: a closure, not a dip in a vowel
MURMUR_BELOW_VOWEL_DB = 10.0
VOWEL_REACH_SECONDS = 0.100  # about a syllable's half: the vowel next to the closure
LOW_HZ = (80.0, 400.0)  # the nasal formant and the voice's lowest harmonics
HIGH_HZ = (2500.0, 5000.0)  # third formant and above
MAX_HIGH_TO_LOW_DB = -18.0
BURST_HEARD_AS = frozenset({"k", "t", "th"})
BURST_HZ = (500.0, 7000.0)
BURST_SECONDS = 0.010
SILENT_LABIAL = {"f": "p", "v": "b"}  # a labiodental heard in a closure's silence -> the bilabial stop
FRICATION_HZ = (2500.0, 8000.0)
_DB = 10.0 / np.log(10.0)  # log_band_energies' nepers of power -> dB


def bilabials_from_acoustics(phones: list[TimedLabel], samples: np.ndarray) -> list[TimedLabel]:
    """`phones` with each murmur heard as a sonorant renamed "m", each labial burst heard as another
    voiceless stop renamed "p", each silent /f/ or /v/ renamed "p" or "b", and each quiet murmur within a
    sonorant split off as an "m" (see the module docstring); times kept."""
    if not any(p.label in SONORANTS | BURST_HEARD_AS | SILENT_LABIAL.keys() for p in phones):
        return list(phones)
    energies = log_band_energies(samples)
    levels, sound = energies * _DB, sound_frames(energies)  # (frames, bands) dB; (frames,)
    centres = band_centres_hz()
    frame_centres = np.arange(len(levels)) * HOP_SECONDS + WINDOW_SECONDS / 2
    low, high = (_above_floor(levels, centres, hz) for hz in (LOW_HZ, HIGH_HZ))
    murmur_frames = sound & _murmur(low, high)
    frication = _above_floor(levels, centres, FRICATION_HZ, SOUND_MARGIN_DB) > 0
    level = 10.0 * np.log10((10.0 ** (levels / 10.0)).sum(axis=1))  # dB, all bands
    out = []
    for phone in phones:
        inside = (frame_centres >= phone.start) & (frame_centres < phone.end)
        if phone.label in MURMUR_HEARD_AS and _murmur(low[inside].sum(), high[inside].sum()):
            phone = phone._replace(label="m")
        elif phone.label in BURST_HEARD_AS and _labial_burst(levels, centres, frame_centres, phone):
            phone = phone._replace(label="p")
        elif phone.label in SILENT_LABIAL and inside.any() and frication[inside].mean() < 0.5:
            phone = phone._replace(label=SILENT_LABIAL[phone.label])
        elif phone.label in SONORANTS:
            out.extend(_split_quiet_murmurs(phone, np.flatnonzero(inside), murmur_frames, level))
            continue
        out.append(phone)
    return out


def _split_quiet_murmurs(phone: TimedLabel, index: np.ndarray, murmur_frames, level) -> list[TimedLabel]:
    """The sonorant `phone` (frames `index`) with each quiet murmur in it an "m" of its own."""
    reach = int(round(VOWEL_REACH_SECONDS / HOP_SECONDS))
    edges = np.diff(np.concatenate([[0], murmur_frames[index].astype(np.int8), [0]]))
    out, start = [], phone.start
    for first, end in zip(np.flatnonzero(edges == 1), np.flatnonzero(edges == -1), strict=True):
        a, b = index[first], index[end - 1] + 1  # frames [a, b)
        loudest = level[max(a - reach, 0) : b + reach].max()
        if (b - a) * HOP_SECONDS < MIN_MURMUR_SECONDS or level[a:b].mean() > loudest - MURMUR_BELOW_VOWEL_DB:
            continue
        # frame k's centre is k hop + window / 2: the run covers the hops around its frames' centres
        run_start = max(start, a * HOP_SECONDS + (WINDOW_SECONDS - HOP_SECONDS) / 2)
        run_end = min(phone.end, b * HOP_SECONDS + (WINDOW_SECONDS - HOP_SECONDS) / 2)
        # a remnant shorter than any phone is no sound of its own: the murmur takes it
        run_start = start if run_start - start < MIN_PHONE_SECONDS else run_start
        run_end = phone.end if phone.end - run_end < MIN_PHONE_SECONDS else run_end
        if run_start > start:
            out.append(phone._replace(start=start, end=run_start))
        out.append(phone._replace(start=run_start, end=run_end, label="m"))
        start = run_end
    if start < phone.end:
        out.append(phone._replace(start=start))
    return out


def _above_floor(levels: np.ndarray, centres: np.ndarray, hz: tuple[float, float], margin_db: float = 0.0):
    """(frames,) each frame's power in the band `hz` above the band's noise floor (its quietest
    FLOOR_PERCENTILE %) raised by `margin_db`; 0 where not above."""
    power = (10.0 ** (levels[:, (centres >= hz[0]) & (centres < hz[1])] / 10.0)).sum(axis=1)
    return np.maximum(power - np.percentile(power, FLOOR_PERCENTILE) * 10.0 ** (margin_db / 10.0), 0.0)


def _murmur(low, high):
    """Whether energies above the noise floor in LOW_HZ and HIGH_HZ (a phone's, or each frame's) are a
    murmur's."""
    return (low > 0) & (high <= low * 10 ** (MAX_HIGH_TO_LOW_DB / 10))


def _labial_burst(levels, centres, frame_centres, phone: TimedLabel) -> bool:
    # the burst may come just before the recognised start (the phone's start is a frame boundary)
    span = int(round(BURST_SECONDS / HOP_SECONDS))
    index = np.flatnonzero((frame_centres >= phone.start - BURST_SECONDS) & (frame_centres < phone.end))
    if len(index) <= span:
        return False
    level = 10.0 * np.log10((10.0 ** (levels[index] / 10.0)).sum(axis=1))
    burst = index[span + int(np.argmax(level[span:] - level[:-span]))]
    spectrum = levels[burst : burst + span].mean(axis=0)
    band = (centres > BURST_HZ[0]) & (centres < BURST_HZ[1])
    slope = np.polyfit(np.log2(centres[band]), spectrum[band], 1)[0]
    return bool(slope < 0.0)
