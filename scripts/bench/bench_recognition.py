"""Recognition without a transcript: the phone loop alone against recognised words + the loop's closures.

    .venv/bin/python -m scripts.bench.bench_recognition {dev,held-out} [--noisy]

Both decode the same samples (espeak-ng's synthesis differs a little from call to call, docs/voice.md), the
benchmark's recordings of one set (scripts/bench/bench_lipsync.py: sentences, voices, rates, 20 dB noise and its
seeds), scored as the benchmark scores them: frame agreement against the issue's truth and the closure truth,
closure recall and precision, and speed in CPU time.
"""

from __future__ import annotations

import argparse
import time

from addon.speech import espeak, phone_alignment, recording
from scripts.bench import bench_lipsync as bench

SETS = {"dev": bench.DEV, "held-out": bench.HELD_OUT}


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("set", choices=tuple(SETS))
    parser.add_argument("--noisy", action="store_true", help=f"white noise at {bench.SNR_DB:g} dB SNR")
    args = parser.parse_args(argv)
    sentences = bench.read_sentences()
    chosen = sentences[: bench.N_SENTENCES] if args.set == "dev" else sentences[-bench.N_SENTENCES :]
    ways = {
        "phone loop": lambda take: phone_alignment.run(phone_alignment.phone_loop_steps(take)),
        "words + closures": lambda take: phone_alignment.phones_from_recording(take, None, words=True),
    }
    scores = {name: [] for name in ways}
    cpu = dict.fromkeys(ways, 0.0)
    duration = 0.0
    cases = [(t, v, r) for t in chosen for v in SETS[args.set]["voices"] for r in SETS[args.set]["rates"]]
    for seed, (text, voice, rate) in enumerate(cases):
        speech = espeak.synthesize(text, voice, rate=rate)
        samples = bench.with_noise(speech.samples, bench.SNR_DB, seed) if args.noisy else speech.samples
        take = recording.from_samples(samples, speech.sample_rate, f"{voice} {rate}")
        duration += speech.duration
        truths = espeak.speech_segments(speech), bench.burst_truth(speech)
        for name, decode in ways.items():
            began = time.process_time()
            found = phone_alignment.phone_segments(decode(take))
            cpu[name] += time.process_time() - began
            scores[name].append([bench.score(truth, found, speech.duration) for truth in truths])
    for name in ways:
        text_path, burst = (bench.summary_of([s[k] for s in scores[name]]) for k in (0, 1))
        print(
            f"{args.set} {'20 dB' if args.noisy else 'clean'} {name}: agreement {text_path['agreement']:.1%} / "
            f"{burst['agreement']:.1%} (text path's / burst-timed truth), "
            f"closure recall {text_path['closure_recall']:.1%}, "
            f"precision {text_path['closure_precision']:.1%}, {duration / max(cpu[name], 1e-9):.1f}x real time "
            "in CPU time"
        )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
