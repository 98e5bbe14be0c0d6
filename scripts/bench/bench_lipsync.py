"""Lip-sync from a recording against the text path (docs/voice.md's figures).

    .venv/bin/python -m scripts.bench.bench_lipsync [--json OUT.json] [--quick] [--words] [--accent-given]
                     [--no-adapt] [--adapt-recognition]

Test recordings are made with espeak-ng, whose synthesis reports each phoneme's time in the same output as its
audio: the text path's visemes of that synthesis (`espeak.speech_segments`, what Speak Text keys: each stop from the
onset of its closure, `espeak.stops_from_closure`) are the truth; the stops at espeak-ng's reported burst times
(`burst_truth`, as Speak Text keyed them before) are scored too, for the earlier figures.
The audio path gets only the samples (resampled to 16 kHz like a user's file) and, for the "with transcript"
rows, the sentence; its visemes are `phone_alignment.phone_segments` of the phones PocketSphinx finds. Each
recording is scored clean and with white noise at 20 dB SNR (against the speech's RMS, fixed seed).

Per set and condition:
  agreement    share of 10 ms frames (100 Hz, over the whole recording) where both paths hold the same viseme
               (a gap holds the previous segment's viseme, as `coarticulation.viseme_track` reads them);
               "speech" counts only frames where the truth is not silence
  closure      bilabial closures (runs of PP) of the truth found by the audio path within +-1 video frame (25
               fps): recall = found / truth closures, precision = audio-path closures that meet a truth one
  onset        |start of the audio path's run - start of the truth's run| for every truth viseme run that the
               audio path has within 150 ms (same viseme), median and 90th percentile in ms
  confusion    frames of each truth viseme (rows) found as each viseme (columns)
  boundary     of the frames that disagree, those whose truth viseme the audio path has within BOUNDARY_SLACK
               (a boundary placed off by up to that much; the others are a wrong viseme, inside a phone)
  speed        seconds of speech per second of wall time (reading the samples at 16 kHz and finding the phones),
               and per second of this process's CPU time (what one free core gives: the machine is shared)

Sets: "dev" (the first 12 sentences of speech_sentences.txt, voices en-us and en, 150 and 200 words a minute),
the sets this was developed on; "held-out" (the last 12 sentences, voices en-us+f3 and en-029, 130 and 240 words
a minute), looked at only to report. A long take (the held-out sentences in one recording, over PIECE_SECONDS)
checks the cutting at pauses. Last, real human recordings with transcripts from Debian's
pocketsphinx-testdata (LibriVox "Sense and Sensibility", and card names), where only a word-level check is
possible: every word with /p b m/ must get a closure (a PP segment) inside its aligned span; and, without
their transcripts, their recognised visemes scored against their aligned ones (the aligner, given the words,
is the nearest to a truth they have). After the tables, the viseme confusion matrices with and without a
transcript (frames of each truth viseme found as each viseme), each headed by how many frames disagree and how
many of those are a boundary's: what each path gets wrong.
"""

from __future__ import annotations

import argparse
import json
import re
import time
from pathlib import Path

import numpy as np

from addon.mpeg4.faps import Viseme
from addon.speech import espeak, phone_alignment, recording
from addon.speech.segments import TimedLabel, segments_from_labels

SENTENCES = Path(__file__).with_name("speech_sentences.txt")
TESTDATA = Path("/usr/share/pocketsphinx/test/data")
FPS = 25
STEP = 0.01  # s, 100 Hz
ONSET_WINDOW = 0.15  # s
BOUNDARY_SLACK = 0.04  # s: a disagreeing frame with the right viseme this near is a boundary's
SNR_DB = 20.0
DEV = {"voices": ("en-us", "en"), "rates": (150, 200)}
HELD_OUT = {"voices": ("en-us+f3", "en-029"), "rates": (130, 240)}
N_SENTENCES = 12
TRUTHS = ("espeak", "closure")


def read_sentences() -> list[str]:
    lines = (line.strip() for line in SENTENCES.read_text(encoding="utf-8").splitlines())
    return [line for line in lines if line and not line.startswith("#")]


def viseme_frames(segments, duration: float) -> np.ndarray:
    """The viseme at each 10 ms frame centre (before the first segment: its viseme; in a gap: the previous)."""
    times = np.arange(0.0, duration, STEP) + STEP / 2
    starts = np.array([s.start for s in segments])
    index = np.clip(np.searchsorted(starts, times, side="right") - 1, 0, None)
    return np.array([int(s.viseme) for s in segments])[index]


def runs(frames: np.ndarray) -> list[tuple[int, float, float]]:
    """(viseme, start s, end s) of each run of equal frames."""
    edges = np.flatnonzero(np.diff(frames)) + 1
    starts = np.concatenate([[0], edges])
    ends = np.concatenate([edges, [len(frames)]])
    return [(int(frames[a]), a * STEP, b * STEP) for a, b in zip(starts, ends, strict=True)]


def score(truth, found, duration: float) -> dict:
    t, f = viseme_frames(truth, duration), viseme_frames(found, duration)
    speech = t != Viseme.NONE
    truth_runs, found_runs = runs(t), runs(f)
    slack = 1.0 / FPS
    closures = [(a, b) for v, a, b in truth_runs if v == Viseme.PP]
    found_closures = [(a, b) for v, a, b in found_runs if v == Viseme.PP]

    def meets(run, others):
        return any(a < run[1] + slack and b > run[0] - slack for a, b in others)

    onsets = []
    for v, a, _ in truth_runs:
        if v == Viseme.NONE:
            continue
        near = [abs(fa - a) for fv, fa, _ in found_runs if fv == v and abs(fa - a) <= ONSET_WINDOW]
        if near:
            onsets.append(min(near) * 1000)
    return {
        "frames": len(t),
        "agree": int(np.sum(t == f)),
        "speech_frames": int(speech.sum()),
        "speech_agree": int(np.sum((t == f) & speech)),
        "closures": len(closures),
        "closures_found": sum(meets(c, found_closures) for c in closures),
        "found_closures": len(found_closures),
        "found_closures_true": sum(meets(c, closures) for c in found_closures),
        "onsets_ms": onsets,
        "confusion": confusion(t, f).tolist(),
        "boundary_frames": boundary_frames(t, f),
    }


def boundary_frames(truth_frames: np.ndarray, found_frames: np.ndarray) -> int:
    """How many of the frames that disagree have their truth viseme among the found frames within
    BOUNDARY_SLACK: a boundary off by up to that much, rather than a wrong viseme."""
    reach = int(round(BOUNDARY_SLACK / STEP))
    return sum(
        bool(np.any(found_frames[max(0, i - reach) : i + reach + 1] == truth_frames[i]))
        for i in np.flatnonzero(truth_frames != found_frames)
    )


def confusion(truth_frames: np.ndarray, found_frames: np.ndarray) -> np.ndarray:
    """(15, 15) frame counts: row = the truth's viseme, column = the audio path's."""
    counts = np.zeros((len(Viseme), len(Viseme)), int)
    np.add.at(counts, (truth_frames, found_frames), 1)
    return counts


def confusion_table(counts) -> str:
    """A confusion matrix as text: one row per truth viseme, its frames, the share found as itself."""
    counts = np.asarray(counts)
    names = [v.name for v in Viseme]
    lines = ["truth \\ found " + " ".join(f"{n:>5}" for n in names) + " frames  found"]
    for i, name in enumerate(names):
        row = counts[i]
        share = f"{row[i] / row.sum():6.1%}" if row.sum() else "     -"
        lines.append(f"{name:>14} " + " ".join(f"{x:5d}" for x in row) + f" {row.sum():6d} {share}")
    return "\n".join(lines)


def disagreement_line(summary: dict) -> str:
    """How many frames disagree, and how many of them are a boundary's (`boundary_frames`)."""
    wrong = summary["frames"] - summary["agree"]
    return (
        f"{wrong} of {summary['frames']} frames disagree, {summary['boundary_frames']} of them within "
        f"{BOUNDARY_SLACK * 1000:.0f} ms of a boundary"
    )


def burst_truth(speech) -> list:
    """The text path's visemes as it keyed them before it moved stops to their closure: each stop at the time
    espeak-ng reports, its burst (`espeak.reported_labels`); kept for comparison with the earlier figures."""
    labels = espeak.reported_labels(speech)
    if labels and labels[0].start > 0:
        labels.insert(0, labels[0]._replace(start=0.0, end=labels[0].start, label="_"))
    return segments_from_labels(labels)


def with_noise(samples: np.ndarray, snr_db: float, seed: int) -> np.ndarray:
    x = samples.astype(np.float64) / 32768.0
    voiced = np.abs(x) > 0.01
    rms = np.sqrt(np.mean(x[voiced] ** 2)) if voiced.any() else 0.0
    noise = np.random.default_rng(seed).normal(0.0, rms / 10 ** (snr_db / 20), len(x))
    return np.clip(x + noise, -1.0, 1.0)


WORDS = {"on": False}  # --words: without a transcript, the recognised words aligned (phone_alignment.recognition_steps)
ACCENT = {"given": False}  # --accent-given: with a transcript, aligned in the take's accent (its voice)
ADAPT = {"on": True}  # --no-adapt: with a transcript, one alignment with the unadapted model (before session 13)
ADAPT_RECOGNITION = {"on": False}  # --adapt-recognition: without a transcript, the phone loop adapted (unsupervised)


def accent_of(voice: str) -> str:
    """The accent a take is aligned in: with --accent-given its espeak-ng voice without the variant ("en-us+f3":
    "en-us"), as a user who knows the speaker's accent would pick it; else the default (US English)."""
    return voice.split("+")[0] if ACCENT["given"] else phone_alignment.DEFAULT_ACCENT


def run_case(text: str, voice: str, rate: int, noisy: bool, seed: int, transcript: bool) -> dict:
    speech = espeak.synthesize(text, voice, rate=rate)
    samples = with_noise(speech.samples, SNR_DB, seed) if noisy else speech.samples
    began, cpu = time.perf_counter(), time.process_time()
    take = recording.from_samples(samples, speech.sample_rate, f"{voice} {rate}")
    refused = False
    try:
        phones = phone_alignment.phones_from_recording(
            take,
            text if transcript else None,
            words=WORDS["on"],
            accent=accent_of(voice),
            adapt=ADAPT["on"],
            adapt_recognition=ADAPT_RECOGNITION["on"],
        )
    except phone_alignment.AlignmentError:  # refused: scored as a mouth that never moves
        phones, refused = [TimedLabel(0.0, speech.duration, "sil")], True
    seconds, cpu = time.perf_counter() - began, time.process_time() - cpu
    found = phone_alignment.phone_segments(phones)
    return {
        "cpu_seconds": cpu,
        "refused": refused,
        "espeak": score(burst_truth(speech), found, speech.duration),
        "closure": score(espeak.speech_segments(speech), found, speech.duration),
        "duration": speech.duration,
        "seconds": seconds,
    }


def summary(cases: list[dict]) -> dict:
    out = {truth: summary_of([c[truth] for c in cases]) for truth in TRUTHS}
    for truth in TRUTHS:
        out[truth]["speed"] = sum(c["duration"] for c in cases) / max(sum(c["seconds"] for c in cases), 1e-9)
        out[truth]["refused"] = sum(c["refused"] for c in cases)
        out[truth]["speed_cpu"] = sum(c["duration"] for c in cases) / max(sum(c["cpu_seconds"] for c in cases), 1e-9)
    return out


def summary_of(results: list[dict]) -> dict:
    onsets = np.concatenate([r["onsets_ms"] for r in results]) if results else np.zeros(0)
    total = lambda key: sum(r[key] for r in results)  # noqa: E731
    return {
        "recordings": len(results),
        "frames": total("frames"),
        "agree": total("agree"),
        "agreement": total("agree") / max(total("frames"), 1),
        "speech_agreement": total("speech_agree") / max(total("speech_frames"), 1),
        "closure_recall": total("closures_found") / max(total("closures"), 1),
        "closure_precision": total("found_closures_true") / max(total("found_closures"), 1),
        "closures": total("closures"),
        "onset_median_ms": float(np.median(onsets)) if len(onsets) else float("nan"),
        "onset_p90_ms": float(np.percentile(onsets, 90)) if len(onsets) else float("nan"),
        "confusion": sum((np.asarray(r["confusion"]) for r in results), np.zeros((len(Viseme),) * 2, int)).tolist(),
        "boundary_frames": total("boundary_frames"),
    }


def synthetic(sentences: list[str], voices, rates, transcript: bool) -> dict:
    out = {}
    for noisy in (False, True):
        cases = [(t, v, r) for t in sentences for v in voices for r in rates]
        results = [run_case(t, v, r, noisy, seed, transcript) for seed, (t, v, r) in enumerate(cases)]
        out["20 dB" if noisy else "clean"] = summary(results)
    return out


def long_take(sentences: list[str], transcript: bool) -> dict:
    text = " ".join(sentences)
    result = run_case(text, HELD_OUT["voices"][0], HELD_OUT["rates"][0], False, 0, transcript)
    return summary([result])


# ----------------------------------------------------------------------------- real recordings


def real_recordings() -> list[tuple[Path, str]]:
    """(WAV, transcript) of pocketsphinx-testdata's LibriVox and cards recordings, where installed."""
    out = []
    for folder, listing in (("librivox", "transcription"), ("cards", "cards.transcription")):
        path = TESTDATA / folder / listing
        if not path.is_file():
            continue
        for line in path.read_text().splitlines():
            match = re.fullmatch(r"\s*<s>(.*)</s>\s*\((\S+)\)\s*", line)
            if match and (TESTDATA / folder / f"{match[2]}.wav").is_file():
                out.append((TESTDATA / folder / f"{match[2]}.wav", match[1].strip()))
    return out


def word_closures(wav: Path, text: str) -> dict:
    """Words of the transcript with /p b m/ and whether a PP segment falls inside each one's aligned span."""
    began, cpu = time.perf_counter(), time.process_time()
    take = recording.read_recording(wav)
    phones = phone_alignment.phones_from_recording(take, text, adapt=ADAPT["on"])
    seconds, cpu = time.perf_counter() - began, time.process_time() - cpu
    segments = phone_alignment.phone_segments(phones)
    spans: list[tuple[str, list]] = []  # (word, its phones), in order; a repeated word starts a new span
    for phone in phones:
        word = phone.where.rsplit(" at ", 1)[0]
        if not word.startswith("word "):
            continue
        if spans and spans[-1][0] == word and spans[-1][1][-1].end >= phone.start - 1e-6:
            spans[-1][1].append(phone)
        else:
            spans.append((word, [phone]))
    bilabial = [(name, g) for name, g in spans if any(p.label in ("p", "b", "m") for p in g)]
    closed = 0
    for _, group in bilabial:
        a, b = group[0].start, group[-1].end
        closed += any(s.viseme == Viseme.PP and s.start < b and s.end > a for s in segments)
    return {"words": len(bilabial), "closed": closed, "duration": take.duration, "seconds": seconds, "cpu": cpu}


def recognised_against_aligned(wav: Path, text: str) -> dict:
    """A real recording's recognised visemes (no transcript) scored against its aligned ones, the nearest to a
    truth a human recording without phone labels has (the aligner, given the words, is far more exact)."""
    take = recording.read_recording(wav)
    aligned = phone_alignment.phone_segments(phone_alignment.phones_from_recording(take, text, adapt=ADAPT["on"]))
    began, cpu = time.perf_counter(), time.process_time()
    phones = phone_alignment.phones_from_recording(
        take, None, words=WORDS["on"], adapt_recognition=ADAPT_RECOGNITION["on"]
    )
    seconds, cpu = time.perf_counter() - began, time.process_time() - cpu
    result = score(aligned, phone_alignment.phone_segments(phones), take.duration)
    return {**result, "duration": take.duration, "seconds": seconds, "cpu": cpu}


def real(transcript: bool) -> dict | None:
    recordings = real_recordings()
    if not recordings:
        return None
    if not transcript:
        results = [recognised_against_aligned(wav, text) for wav, text in recordings]
        return {
            **summary_of(results),
            "speed": sum(r["duration"] for r in results) / sum(r["seconds"] for r in results),
            "speed_cpu": sum(r["duration"] for r in results) / sum(r["cpu"] for r in results),
        }
    results = [word_closures(wav, text) for wav, text in recordings]
    return {
        "recordings": len(results),
        "bilabial_words": sum(r["words"] for r in results),
        "closed_inside_word": sum(r["closed"] for r in results),
        "speed": sum(r["duration"] for r in results) / sum(r["seconds"] for r in results),
        "speed_cpu": sum(r["duration"] for r in results) / sum(r["cpu"] for r in results),
    }


def table(report: dict, truth: str) -> str:
    head = (
        "| set | transcript | noise | recordings | frame agreement (speech) | closure recall | closure precision "
        "| onset median / p90 ms | × real time (CPU time) | refused |"
    )
    lines = [head, "|" + "---|" * 10]
    for name in ("dev", "held-out", "long take"):
        for mode, conditions in report[name].items():
            items = conditions.items() if "espeak" not in conditions else [("clean", conditions)]
            for noise, both in items:
                s = both[truth]
                lines.append(
                    f"| {name} | {mode} | {noise} | {s['recordings']} | {s['agreement']:.1%} "
                    f"({s['speech_agreement']:.1%}) | {s['closure_recall']:.1%} of {s['closures']} | "
                    f"{s['closure_precision']:.1%} | {s['onset_median_ms']:.0f} / {s['onset_p90_ms']:.0f} | "
                    f"{s['speed']:.1f} ({s['speed_cpu']:.1f}) | {s['refused']} |"
                )
    real_ = report.get("real")
    if real_ and truth == TRUTHS[-1]:
        lines.append("")
        lines.append(
            f"Real recordings (pocketsphinx-testdata, {real_['recordings']} with transcripts): "
            f"{real_['closed_inside_word']} of {real_['bilabial_words']} words with /p b m/ close inside the word; "
            f"{real_['speed']:.1f}× real time ({real_['speed_cpu']:.1f}× in CPU time)."
        )
    recognised = report.get("real recognised")
    if recognised and truth == TRUTHS[-1]:
        lines.append(
            f"Without their transcripts, against their aligned visemes: frame agreement {recognised['agreement']:.1%} "
            f"({recognised['speech_agreement']:.1%}), closure recall {recognised['closure_recall']:.1%} of "
            f"{recognised['closures']}, precision {recognised['closure_precision']:.1%}; "
            f"{recognised['speed']:.1f}× real time ({recognised['speed_cpu']:.1f}× in CPU time)."
        )
    return "\n".join(lines)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--json", type=Path, help="write the figures here")
    parser.add_argument("--quick", action="store_true", help="3 sentences a set (a smoke run)")
    parser.add_argument("--words", action="store_true", help="without a transcript: recognised words, aligned")
    parser.add_argument("--accent-given", action="store_true", help="with a transcript: in each take's accent")
    parser.add_argument("--no-adapt", action="store_true", help="with a transcript: no MLLR adaptation to the take")
    parser.add_argument(
        "--adapt-recognition", action="store_true", help="without a transcript: the phone loop, adapted to the take"
    )
    args = parser.parse_args(argv)
    ADAPT["on"] = not args.no_adapt
    ADAPT_RECOGNITION["on"] = args.adapt_recognition
    WORDS["on"] = args.words
    ACCENT["given"] = args.accent_given
    sentences = read_sentences()
    count = 3 if args.quick else N_SENTENCES
    dev, held_out = sentences[:count], sentences[-count:]
    report = {"dev": {}, "held-out": {}, "long take": {}}
    for mode, transcript in (("with", True), ("without", False)):
        report["dev"][mode] = synthetic(dev, DEV["voices"], DEV["rates"], transcript)
        report["held-out"][mode] = synthetic(held_out, HELD_OUT["voices"], HELD_OUT["rates"], transcript)
        report["long take"][mode] = long_take(held_out, transcript)
    report["real"] = real(True)
    report["real recognised"] = real(False)
    print("Truth: espeak-ng's reported times, each stop at its burst (the text path before session 10)")
    print(table(report, "espeak"))
    print("\nTruth: the text path's visemes, each stop from the onset of its closure (the silence before its burst)")
    print(table(report, "closure"))
    for mode in ("with", "without"):
        print(f"\nViseme confusion {mode} a transcript, closure truth, clean (frames; rows: truth, columns: found)")
        for name in ("dev", "held-out"):
            pooled = report[name][mode]["clean"]["closure"]
            print(f"\n{name}: {disagreement_line(pooled)}\n" + confusion_table(pooled["confusion"]))
    if report["real recognised"]:
        counts = report["real recognised"]["confusion"]
        print("\nreal recordings, against their aligned visemes:\n" + confusion_table(counts))
    if args.json:
        args.json.write_text(json.dumps(report, indent=1))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
