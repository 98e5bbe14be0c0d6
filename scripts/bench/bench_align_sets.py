"""Alignment with a transcript on development takes beyond the benchmark's dev set: other accents and rates.

    .venv/bin/python -m scripts.bench.bench_align_sets {dev,accents,fast,middle,middle-fast} [...] [--accent-given]

The benchmark's held-out voices (en-us+f3, en-029) and sentences (the last 12) lose 6 points of frame agreement
with a transcript against dev; to work on that without looking at them, these sets use voices and sentences the
held-out set does not: the benchmark's dev sentences (the first 12) or the 30 sentences between dev and
held-out that the benchmark leaves unused, spoken by espeak-ng's other English accents (Scottish, New York,
Received Pronunciation) and by a female US voice other than the held-out one, at the held-out set's rates.
Scored as scripts/bench/bench_lipsync.py scores the rows with a transcript (closure truth, clean), per voice
and per rate, with the speed in CPU time.
"""

from __future__ import annotations

import argparse
import time

from addon.speech import espeak, phone_alignment, recording
from addon.speech.segments import TimedLabel
from scripts.bench import bench_lipsync as bench

SETS = {  # (sentences: "dev" the first 12, "middle" the 30 that neither dev nor held-out uses), voices, rates
    "dev": ("dev", ("en-us", "en"), (150, 200)),
    "accents": ("dev", ("en-gb-scotland", "en-us-nyc", "en-gb-x-rp"), (150, 200)),
    "fast": ("dev", ("en-us+f2", "en-gb-scotland"), (130, 240)),
    "middle": ("middle", ("en-us", "en"), (175,)),
    "middle-fast": ("middle", ("en-us+f2", "en-gb-scotland", "en-us-nyc"), (240,)),
}


def sentences_of(which: str) -> list[str]:
    sentences = bench.read_sentences()
    n = bench.N_SENTENCES
    return sentences[:n] if which == "dev" else sentences[n:-n]


def run_set(name: str) -> str:
    which, voices, rates = SETS[name]
    groups: dict[str, list[dict]] = {}
    duration = cpu = 0.0
    for text in sentences_of(which):
        for voice in voices:
            for rate in rates:
                speech = espeak.synthesize(text, voice, rate=rate)
                take = recording.from_samples(speech.samples, speech.sample_rate, f"{voice} {rate}")
                began = time.process_time()
                try:
                    phones = phone_alignment.phones_from_recording(take, text, accent=bench.accent_of(voice))
                except phone_alignment.AlignmentError:  # refused: a mouth that never moves, as the benchmark
                    phones = [TimedLabel(0.0, speech.duration, "sil")]
                cpu += time.process_time() - began
                duration += speech.duration
                found = phone_alignment.phone_segments(phones)
                result = bench.score(espeak.speech_segments(speech), found, speech.duration)
                for key in ("all", voice, f"{rate} wpm"):
                    groups.setdefault(key, []).append(result)
    parts = [f"{key} {bench.summary_of(results)['agreement']:.1%}" for key, results in groups.items()]
    recall = bench.summary_of(groups["all"])["closure_recall"]
    speed = duration / max(cpu, 1e-9)
    return f"{name}: " + ", ".join(parts) + f"; closure recall {recall:.1%}; {speed:.1f}x real time (CPU)"


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("sets", nargs="+", choices=tuple(SETS))
    parser.add_argument("--accent-given", action="store_true", help="align each take in its voice's accent")
    args = parser.parse_args(argv)
    bench.ACCENT["given"] = args.accent_given
    for name in args.sets:
        print(run_set(name), flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
