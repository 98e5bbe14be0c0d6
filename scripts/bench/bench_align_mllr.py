"""Alignment with a transcript, then again with the model adapted to the take by MLLR (docs/voice.md).

    .venv/bin/python -m scripts.bench.bench_align_mllr {dev,accents,fast,middle,middle-fast,held-out} [...]
                     [--sphinxtrain] [--means-only] [--limit N]

Each take is synthesised once and aligned as shipped (pass 1); the phones of that alignment (the model's
phones, SIL for a pause) are the supervision of one global MLLR mean transform (and, since session 14, the
variances' scales) estimated on the take alone; the take is aligned again with the model so adapted (pass 2).
Both are scored as scripts/bench/bench_lipsync.py scores the rows with a transcript (closure truth, clean), on
the same samples. `--sphinxtrain`: the transform
from Debian's sphinxtrain (bw, mllr_solve: `apt-get install sphinxtrain sphinxbase-utils pocketsphinx`, as row
(e) of bench_recognition_ceiling) instead of the shipped two-pass alignment. `--unsupervised`: without a
transcript, the same two passes for the phone loop: its recognised phones (each a word of one phone, pauses
left to the grammar's optional silences) aligned to give the state alignment, the transform estimated from it
(`adaptation.estimate`, as the shipped alignment does) and the take recognised again with the adapted model.
`--scores`: the refusal cut's measurement (`phone_alignment.MIN_SCORE_PER_FRAME`): the first 8 dev sentences in
the dev voices at 120 and 300 words a minute, clean and at 20 dB, each aligned (first alignment) with its own
transcript and with the next sentence's; the acoustic scores per frame of each.
`--means-only`: before is the take adapted with the means' transform alone (session 13), after as shipped
(the means' transform and the variances' scales), on the same samples.
`--front-end`: `adaptation.cepstra` against Debian's `sphinx_fe` (sphinxbase-utils; the model's feat.params) on
the padded PCM of the first take of each set: the largest difference per cepstral coefficient.
"""

from __future__ import annotations

import argparse
import subprocess
import tempfile
import time
from pathlib import Path

import numpy as np

from addon.speech import adaptation, espeak, phone_alignment, recording
from addon.speech.segments import TimedLabel
from scripts.bench import bench_align_sets as sets
from scripts.bench import bench_lipsync as bench
from scripts.bench import bench_recognition_ceiling as ceiling

SETS = {**sets.SETS, "held-out": ("held-out", bench.HELD_OUT["voices"], bench.HELD_OUT["rates"])}


def sentences_of(which: str) -> list[str]:
    return bench.read_sentences()[-bench.N_SENTENCES :] if which == "held-out" else sets.sentences_of(which)


class _Captured:
    """The model's phone names of the last alignment (`_aligned_entries` wrapped)."""

    def __init__(self):
        self.phones: list[str] = []
        self.original = phone_alignment._aligned_entries

    def __call__(self, alignment, words):
        self.phones += [p.name for p in alignment.phones()]
        return self.original(alignment, words)


def _means_only(pieces, model):
    """`adaptation.estimate` with the variances' scales left at 1 (the transform of session 13)."""
    found = ESTIMATE(pieces, model)
    return None if found is None else adaptation.Transform(found.means, np.ones_like(found.variances))


ESTIMATE = adaptation.estimate


def align(
    take, text: str, voice: str, mllr: str | None = None, adapt: bool = False, means_only: bool = False
) -> list[TimedLabel]:
    if means_only:
        adaptation.estimate = _means_only
    try:
        return _align(take, text, voice, mllr, adapt)
    finally:
        adaptation.estimate = ESTIMATE


def _align(take, text: str, voice: str, mllr: str | None, adapt: bool) -> list[TimedLabel]:
    options = {"mllr": mllr} if mllr else {}
    module = phone_alignment._pocketsphinx()
    saved = phone_alignment._pocketsphinx
    if mllr:
        phone_alignment._idle_decoders.pop(("align", "STANDARD"), None)
        phone_alignment._pocketsphinx = lambda: ceiling._Swapped(module, options, phone_loop_only=False)
    try:
        steps = phone_alignment.alignment_steps(take, text, accent=bench.accent_of(voice), adapt=adapt)
        return phone_alignment.run(steps)
    except phone_alignment.AlignmentError:  # refused: a mouth that never moves, as the benchmark
        return [TimedLabel(0.0, take.duration, "sil")]
    finally:
        phone_alignment._pocketsphinx = saved
        if mllr:
            phone_alignment._idle_decoders.pop(("align", "STANDARD"), None)


def sphinxtrain_transform(take, phones: list[str], folder: Path) -> str | None:
    wheel = Path(phone_alignment._pocketsphinx().get_model_path()) / "en-us" / "en-us"
    case = {"take": take}
    path = ceiling.mllr_transform([case], [ceiling.spoken(phones)], folder, wheel)
    return None if path is None else str(path)


def front_end(take) -> str:
    """adaptation.cepstra against sphinx_fe on the take's padded PCM, as the decoder is fed it."""
    model = phone_alignment._model()
    pcm = np.frombuffer(phone_alignment._pcm(take.samples), "<i2")
    wheel = Path(phone_alignment._pocketsphinx().get_model_path()) / "en-us" / "en-us"
    with tempfile.TemporaryDirectory() as folder:
        raw, mfc = Path(folder) / "take.raw", Path(folder) / "take.mfc"
        pcm.tofile(raw)
        fe = [str(ceiling.SPHINX_FE), "-argfile", str(wheel / "feat.params"), "-samprate", "16000"]
        fe += ["-i", str(raw), "-o", str(mfc), "-raw", "yes", "-input_endian", "little"]
        subprocess.run(fe, capture_output=True, check=True)
        data = mfc.read_bytes()
    order = "<" if int.from_bytes(data[:4], "little") == (len(data) - 4) // 4 else ">"
    theirs = np.frombuffer(data, order + "f4", offset=4).reshape(-1, adaptation.N_CEPSTRA)
    ours = adaptation.cepstra(pcm, model.params, warm_up=False)
    n = min(len(theirs), len(ours))
    worst = np.abs(theirs[:n] - ours[:n]).max(axis=0)
    return f"{len(ours)} / {len(theirs)} frames (ours / sphinx_fe), largest difference per coefficient " + " ".join(
        f"{v:.1e}" for v in worst
    )


def scores() -> str:
    """Per-frame scores of right and wrong transcripts (the next sentence's): (lowest right, wrong ones that
    fail to align, wrong scores' range, wrong ones at or above the cut)."""
    seen: list[float] = []
    original = phone_alignment._score_per_frame
    phone_alignment._score_per_frame = lambda alignment: seen.append(original(alignment)) or seen[-1]
    right, wrong, failed = [], [], 0
    sentences = sets.sentences_of("dev")[:9]
    try:
        for k, text in enumerate(sentences[:8]):
            for voice in bench.DEV["voices"]:
                for rate in (120, 300):
                    speech = espeak.synthesize(text, voice, rate=rate)
                    for noisy in (False, True):
                        samples = bench.with_noise(speech.samples, bench.SNR_DB, k) if noisy else speech.samples
                        take = recording.from_samples(samples, speech.sample_rate, f"{voice} {rate}")
                        for transcript, out in ((text, right), (sentences[k + 1], wrong)):
                            seen.clear()
                            try:
                                phone_alignment.run(phone_alignment.alignment_steps(take, transcript, adapt=False))
                            except phone_alignment.AlignmentError:
                                pass
                            if seen:
                                out.append(max(seen))  # the espeak-ng pronunciation's, or the dictionary's
                            elif out is wrong:
                                failed += 1
    finally:
        phone_alignment._score_per_frame = original
    cut = phone_alignment.MIN_SCORE_PER_FRAME
    passed = sum(score >= cut for score in wrong)
    return (
        f"right transcripts {min(right):.1f} to {max(right):.1f} ({len(right)}, {sum(r < cut for r in right)} under "
        f"the cut {cut}); wrong: {failed} of {failed + len(wrong)} fail to align, the others {min(wrong):.1f} to "
        f"{max(wrong):.1f}, {passed} of them at or above the cut"
    )


def run_set(
    name: str,
    limit: int | None,
    folder: Path,
    sphinxtrain: bool,
    unsupervised: bool = False,
    check_front_end: bool = False,
    means_only: bool = False,
) -> str:
    which, voices, rates = SETS[name]
    groups: dict[str, list[list[dict]]] = {}
    duration = cpu = cpu_first = 0.0
    for text in sentences_of(which)[:limit]:
        for voice in voices:
            for rate in rates:
                speech = espeak.synthesize(text, voice, rate=rate)
                take = recording.from_samples(speech.samples, speech.sample_rate, f"{voice} {rate}")
                truth = espeak.speech_segments(speech)
                if check_front_end:
                    return f"{name}: {front_end(take)}"
                if unsupervised:
                    began = time.process_time()
                    first = phone_alignment.run(phone_alignment.recognition_steps(take))
                    between = time.process_time()
                    second = phone_alignment.run(phone_alignment.recognition_steps(take, adapt=True))
                    cpu_first, cpu = cpu_first + between - began, cpu + time.process_time() - between
                    duration += speech.duration
                    results = [
                        bench.score(truth, phone_alignment.phone_segments(p), speech.duration) for p in (first, second)
                    ]
                    for key in ("all", voice, f"{rate} wpm"):
                        groups.setdefault(key, []).append(results)
                    continue
                captured = _Captured()
                phone_alignment._aligned_entries = captured
                began = time.process_time()
                try:
                    first = align(take, text, voice, adapt=means_only, means_only=means_only)
                finally:
                    phone_alignment._aligned_entries = captured.original
                if sphinxtrain:
                    mllr = sphinxtrain_transform(take, captured.phones, Path(tempfile.mkdtemp(dir=folder)))
                    second = align(take, text, voice, mllr) if mllr else first
                else:
                    between = time.process_time()
                    second = align(take, text, voice, adapt=True)
                    cpu += time.process_time() - between
                cpu_first += between - began if not sphinxtrain else 0.0
                duration += speech.duration
                results = [
                    bench.score(truth, phone_alignment.phone_segments(p), speech.duration) for p in (first, second)
                ]
                for key in ("all", voice, f"{rate} wpm"):
                    groups.setdefault(key, []).append(results)
    parts = []
    for key, pairs in groups.items():
        a, b = (bench.summary_of([p[k] for p in pairs])["agreement"] for k in (0, 1))
        parts.append(f"{key} {a:.1%} -> {b:.1%}")
    pooled = [bench.summary_of([p[k] for p in groups["all"]]) for k in (0, 1)]
    recall = f"closure recall {pooled[0]['closure_recall']:.1%} -> {pooled[1]['closure_recall']:.1%}"
    recall += f", precision {pooled[0]['closure_precision']:.1%} -> {pooled[1]['closure_precision']:.1%}"
    speeds = f"{duration / max(cpu_first, 1e-9):.1f}x -> {duration / max(cpu, 1e-9):.1f}x real time (CPU)"
    return f"{name}: " + ", ".join(parts) + f"; {recall}" + ("" if sphinxtrain else f"; {speeds}")


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("sets", nargs="*", help=f"of {', '.join(SETS)}")
    parser.add_argument("--limit", type=int, default=None, help="the first N sentences of each set")
    parser.add_argument("--sphinxtrain", action="store_true", help="the transform from sphinxtrain (bw, mllr_solve)")
    parser.add_argument("--unsupervised", action="store_true", help="without a transcript: the phone loop, adapted")
    parser.add_argument("--front-end", action="store_true", help="adaptation.cepstra against sphinx_fe")
    parser.add_argument("--means-only", action="store_true", help="before: the means adapted alone (session 13)")
    parser.add_argument("--scores", action="store_true", help="per-frame scores of right and wrong transcripts")
    args = parser.parse_args(argv)
    if args.scores:
        print(scores(), flush=True)
        return 0
    unknown = [name for name in args.sets if name not in SETS]
    if unknown or not args.sets:
        parser.error(f"sets: {', '.join(unknown) or 'none given'} (choose from {', '.join(SETS)})")
    with tempfile.TemporaryDirectory() as folder:
        for name in args.sets:
            found = run_set(
                name, args.limit, Path(folder), args.sphinxtrain, args.unsupervised, args.front_end, args.means_only
            )
            print(found, flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
