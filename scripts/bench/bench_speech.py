"""Speech on the sample head: bilabial closure, audio-visual sync and throughput (the figures of docs/speech.md).

    .venv/bin/python -m scripts.bench.bench_speech [--sentences scripts/bench/speech_sentences.txt] [--fps 25]
                                                   [--video-sentences 10] [--json OUT.json]

Every sentence is spoken onto the sample head (`sample_blends/makehuman_head.blend`, object "Head") by Speak
Text's service (`speech_ops.speak`: espeak-ng voice en, 175 words a minute, start frame 0), and the keyed
F-curves of FP 2.2 (inner upper lip) and FP 2.3 (inner lower lip) are read back at every frame. The inner-lip
gap is FP 2.2's height above FP 2.3 along the head's vertical axis (its local Z): pressed lips give a gap of 0 or
below. (The points' straight distance cannot go below 1.3 mm on this head: 2.2 sits 1.3 mm in front of 2.3 when
the lips touch.)

(a) Lip closure: a bilabial segment (/p b m/, viseme PP) is closed when the gap is <= 1 mm on one of its frames
    (those from its start to its end, and the one nearest its centre).
(b) Sync: per sentence, the mouth opening (the gap at each frame) against the RMS envelope of the WAV that Speak
    Text wrote (a window of one frame centred on each frame's time), both z-scored; the lag in frames within
    +-5 that maximises their correlation (positive: the mouth follows the sound), per sentence and pooled.
(c) Throughput: seconds of speech per second of wall time, (1) text -> .fap + .wav -> keyed face, the way
    `scripts/say.py` does it (espeak-ng, co-articulation, write both files, Import FAP Stream); (2) the same plus
    a 640x480 Workbench MP4 with the sound (the preview `scripts/convert.py` renders) for the first
    --video-sentences sentences.
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
import time
import wave
from pathlib import Path

import bpy
import numpy as np

from addon.blender import animation, face_data, fap_io, speech_ops
from addon.mpeg4.faps import Viseme
from addon.speech import espeak
from scripts import convert, say

ROOT = Path(__file__).resolve().parents[2]
SENTENCES = Path(__file__).with_name("speech_sentences.txt")
FACE = ROOT / "sample_blends" / "makehuman_head.blend"
CLOSED = 0.001  # m
MAX_LAG = 5  # frames
VIDEO_SIZE = (640, 480)


def read_sentences(path: Path) -> list[str]:
    lines = (line.strip() for line in path.read_text(encoding="utf-8").splitlines())
    return [line for line in lines if line and not line.startswith("#")]


def open_face(fps: int):
    bpy.ops.wm.open_mainfile(filepath=str(FACE))
    scene, face = bpy.context.scene, bpy.data.objects["Head"]
    convert.select_only(face)
    scene.render.fps, scene.render.fps_base = fps, 1.0
    return scene, face


def lip_gap(face, frames: np.ndarray) -> np.ndarray:
    """FP 2.2's height above FP 2.3 (m, head-local Z) at `frames`, from their keyed F-curves."""
    empties = face_data.fp_empties(face)
    upper, lower = empties["2.2"], empties["2.3"]
    return animation.sample(upper, "location", 2, frames, upper.location.z) - animation.sample(
        lower, "location", 2, frames, lower.location.z
    )


def read_wav(path: Path) -> tuple[np.ndarray, int]:
    with wave.open(str(path), "rb") as file:
        return np.frombuffer(file.readframes(file.getnframes()), dtype="<i2"), file.getframerate()


def rms_envelope(samples: np.ndarray, rate: int, fps: float, n_frames: int) -> np.ndarray:
    """RMS of a one-frame window centred on each frame's time."""
    x = samples.astype(np.float64)
    out = np.zeros(n_frames)
    for k in range(n_frames):
        a = max(0, round((k - 0.5) * rate / fps))
        b = min(len(x), round((k + 0.5) * rate / fps))
        if b > a:
            out[k] = np.sqrt(np.mean(x[a:b] ** 2))
    return out


def _z(x: np.ndarray) -> np.ndarray:
    return (x - x.mean()) / (x.std() or 1.0)


def correlations(mouth: np.ndarray, sound: np.ndarray) -> dict[int, tuple[float, int]]:
    """lag -> (sum of products of the z-scored series, pairs), mouth[k] against sound[k - lag]."""
    m, s = _z(mouth), _z(sound)
    out = {}
    for lag in range(-MAX_LAG, MAX_LAG + 1):
        if lag >= 0:
            a, b = m[lag:], s[: len(s) - lag]
        else:
            a, b = m[:lag], s[-lag:]
        out[lag] = (float(np.dot(a, b)), len(a))
    return out


def measure_sentence(scene, face, text: str, fps: int, folder: Path) -> dict:
    """Speak one sentence with Speak Text and measure closure and sync on it."""
    wav = folder / "sentence.wav"
    speech = espeak.synthesize(text)
    speech_ops.speak(bpy.context, face, speech, fap_io.ImportOptions(start_frame=0), audio_file=str(wav))
    samples, rate = read_wav(wav)
    segments = espeak.speech_segments(speech)
    n_frames = int(np.ceil(speech.duration * fps - 1e-9))
    frames = np.arange(n_frames, dtype=np.float64)
    gap = lip_gap(face, frames)
    closures = []
    for segment in segments:
        if segment.viseme != Viseme.PP:
            continue
        inside = (frames / fps >= segment.start) & (frames / fps <= segment.end)
        inside[min(n_frames - 1, round(segment.centre * fps))] = True
        closures.append((segment.label, float(gap[inside].min())))
    sync = correlations(gap, rms_envelope(samples, rate, fps, n_frames))
    return {"text": text, "seconds": speech.duration, "closures": closures, "sync": sync}


def throughput(scene, face, sentences: list[str], fps: int, folder: Path, video: int) -> dict:
    """Seconds of speech per wall-clock second: text -> .fap + .wav -> keyed, and that plus the MP4."""
    keyed_speech = keyed_time = video_speech = video_time = 0.0
    for i, text in enumerate(sentences):
        args = say.parse_args([text, "--face", str(FACE), "-o", str(folder), "--fps", str(fps)])
        start = time.perf_counter()
        stream, spoken, audio = say.synthesize(args, "bench")
        fap, wav = say.write_speech(folder, "bench", stream, spoken, audio)
        assert bpy.ops.mpeg4.import_fap(filepath=str(fap), timing="SCENE", start_frame=0) == {"FINISHED"}
        keyed = time.perf_counter() - start
        keyed_speech += spoken.duration
        keyed_time += keyed
        if i < video:
            start = time.perf_counter()
            render(scene, face, wav, len(stream.frame_numbers), folder / "bench.mp4")
            video_speech += spoken.duration
            video_time += keyed + time.perf_counter() - start
    return {
        "keyed": {"speech_s": keyed_speech, "wall_s": keyed_time, "sentences": len(sentences)},
        "video": {"speech_s": video_speech, "wall_s": video_time, "sentences": min(video, len(sentences))},
    }


def render(scene, face, wav: Path, n_frames: int, path: Path) -> None:
    editor = scene.sequence_editor
    if editor is not None:  # the previous sentence's sound
        for strip in list(editor.strips):
            editor.strips.remove(strip)
    convert.frame_face(scene, face, VIDEO_SIZE[1])
    scene.render.resolution_x, scene.render.resolution_y = VIDEO_SIZE
    convert.set_engine(scene, "WORKBENCH")
    convert.add_audio(scene, wav)
    scene.frame_start, scene.frame_end = 0, n_frames - 1
    convert.render_video(scene, path)


def summary(results: list[dict], speed: dict, fps: int) -> dict:
    gaps = np.array([gap for r in results for _, gap in r["closures"]])
    pooled = {lag: sum(r["sync"][lag][0] for r in results) / sum(r["sync"][lag][1] for r in results) for lag in
              range(-MAX_LAG, MAX_LAG + 1)}  # fmt: skip
    lags = [max(r["sync"], key=lambda lag, r=r: r["sync"][lag][0] / r["sync"][lag][1]) for r in results]
    return {
        "sentences": len(results),
        "speech_seconds": sum(r["seconds"] for r in results),
        "bilabials": len(gaps),
        "closed": int((gaps <= CLOSED).sum()),
        "worst_gap_mm": float(gaps.max() * 1000),
        "median_gap_mm": float(np.median(gaps) * 1000),
        "pooled_lag_frames": max(pooled, key=pooled.get),
        "pooled_correlation": {str(lag): round(c, 4) for lag, c in pooled.items()},
        "sentence_lags": {str(lag): lags.count(lag) for lag in sorted(set(lags))},
        "lags": lags,
        "throughput": {
            name: {**part, "speech_per_wall": part["speech_s"] / part["wall_s"] if part["wall_s"] else None}
            for name, part in speed.items()
        },
        "fps": fps,
    }


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sentences", type=Path, default=SENTENCES)
    parser.add_argument("--fps", type=int, default=25)
    parser.add_argument("--video-sentences", type=int, default=10, help="sentences also rendered to MP4 (c2)")
    parser.add_argument("--json", type=Path, help="also write the figures here")
    args = parser.parse_args(argv)
    sentences = read_sentences(args.sentences)
    convert.addon_package()
    with tempfile.TemporaryDirectory() as tmp:
        scene, face = open_face(args.fps)
        results = [measure_sentence(scene, face, text, args.fps, Path(tmp)) for text in sentences]
        scene, face = open_face(args.fps)
        speed = throughput(scene, face, sentences, args.fps, Path(tmp), args.video_sentences)
    figures = summary(results, speed, args.fps)
    for r, lag in zip(results, figures["lags"], strict=True):
        for label, gap in r["closures"]:
            if gap > CLOSED:
                print(f"open bilabial {label!r} ({gap * 1000:.2f} mm) in {r['text']!r}")
        if abs(lag) > 1:
            best = {k: round(total / pairs, 3) for k, (total, pairs) in r["sync"].items()}
            print(f"lag {lag} frames in {r['text']!r} ({r['seconds']:.2f} s), correlation by lag {best}")
    print(
        f"(a) lip closure: {figures['closed']} of {figures['bilabials']} bilabial segments closed "
        f"({100 * figures['closed'] / figures['bilabials']:.1f} %) in {figures['sentences']} sentences "
        f"({figures['speech_seconds']:.1f} s); gap at the most closed frame: median {figures['median_gap_mm']:.2f} mm, "
        f"largest {figures['worst_gap_mm']:.2f} mm"
    )
    print(
        f"(b) sync at {args.fps} fps: pooled lag {figures['pooled_lag_frames']} frames; sentences by their own lag "
        f"{figures['sentence_lags']}; pooled correlation by lag {figures['pooled_correlation']}"
    )
    for name, part in figures["throughput"].items():
        print(
            f"(c) {name}: {part['speech_s']:.1f} s of speech in {part['wall_s']:.1f} s "
            f"({part['sentences']} sentences): {part['speech_per_wall']:.2f} s of speech per second"
        )
    if args.json:
        args.json.write_text(json.dumps(figures, indent=1) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
