"""A talking face from text or from a voice recording -> a FAP stream -> Alembic and an MP4 with sound.

    python -m scripts.say "TEXT" --face FACE.blend -o OUTDIR [--name NAME] [--voice en] [--rate 175]
                          [--expression joy:0.6] [--fps 25] [--resolution 480] [--visemes] [--no-video]
    python -m scripts.say --audio VOICE.wav [--text "TRANSCRIPT" | --transcript FILE.txt] --face FACE.blend
                          -o OUTDIR [--accuracy standard|high] [--accent en-us] [--words] [--no-adapt]
                          [--adapt-recognition]
                          [the options above but --voice and --rate]

From text, writes, named after the text (or --name):
    NAME.fap            the co-articulated low-level FAPs at --fps (with --visemes, FAP 1 in every frame too)
    NAME.wav            the voice, from the same espeak-ng synthesis as the phoneme times, padded with silence
                        to a whole number of frames so that the stream, the audio and the video end together
    NAME_phonemes.tsv   espeak-ng's phonemes with their times (re-import them with Import Lip-Sync Cues)
    NAME_visemes.tsv    the visemes the mouth is keyed from, `start end VISEME` (the 15 MPEG-4 viseme names)
From a recording (WAV; FLAC, OGG, MP3 through Blender's audio library), named after the file (or --name): the
same without NAME.wav, the phones aligned with the transcript (or recognised without one: less exact) by
PocketSphinx in NAME_phonemes.tsv (lower-case CMU phones, which Import Lip-Sync Cues reads too), and the
recording itself as the video's sound.

Then, through `scripts/convert.py` with the sound as its `--audio`: NAME.abc, NAME.pc2, NAME.mp4 (H.264 with
the voice as AAC), NAME_sheet.png and NAME.log. Last, the MP4's boxes are read (no FFmpeg needed) to say how
long its video and audio last.

Every argument and the speech itself (text, voice, expression, a missing espeak-ng; the recording, the
transcript, a missing PocketSphinx) are checked before any file is written; a problem stops the run with one
line `say.py: error: ...` and exit status 2. The conversion then reports like convert.py (exit status 1 if it
failed, 130 after Ctrl+C); an MP4 without its audio is exit 1.
"""

from __future__ import annotations

import argparse
import math
import re
import struct
import sys
from pathlib import Path

import numpy as np

if __package__:
    from . import convert
else:  # run as a file (`python scripts/say.py`): Python finds convert.py next to this one
    import convert

FPS_RANGE = (1, 240)
MAX_NAME = 64


class SayError(Exception):
    """A problem with the arguments or the speech; the message is the whole report."""


def _fps(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        value = math.nan
    if not FPS_RANGE[0] <= value <= FPS_RANGE[1]:
        raise argparse.ArgumentTypeError(f"{text!r} is not a frame rate from {FPS_RANGE[0]} to {FPS_RANGE[1]}")
    return value


def _expression(text: str) -> tuple[str, float]:
    """`NAME:WEIGHT` (weight 0..1, default 1), e.g. joy:0.6; the name is checked against the table later."""
    name, colon, weight = text.partition(":")
    try:
        value = float(weight) if colon else 1.0
    except ValueError:
        value = math.nan
    if not name.strip() or not 0.0 <= value <= 1.0:
        raise argparse.ArgumentTypeError(f"{text!r} is not NAME:WEIGHT with a weight from 0 to 1, e.g. joy:0.6")
    return name.strip().lower(), value


def _name(text: str) -> str:
    if not re.fullmatch(r"[\w.-]+", text) or text.startswith(".") or len(text) > MAX_NAME:
        raise argparse.ArgumentTypeError(f"{text!r} is not a file name stem (letters, digits, _ . -)")
    return text


def parse_args(argv: list[str]) -> argparse.Namespace:
    parser = convert._Parser(prog="say.py", description="Make a talking face from text or a voice recording.")
    parser.add_argument("text", nargs="?", help="what the face says (with espeak-ng's voice)")
    parser.add_argument("--audio", type=Path, help="a voice recording to lip-sync instead of text")
    transcript = parser.add_mutually_exclusive_group()
    transcript.add_argument("--text", dest="transcript_text", help="what the recording says, word for word")
    transcript.add_argument("--transcript", type=Path, help="a UTF-8 .txt file with what the recording says")
    parser.add_argument(
        "--accuracy", choices=("standard", "high"), default="standard", help="PocketSphinx's search (high: slower)"
    )
    parser.add_argument(
        "--accent",
        choices=tuple(convert._addon("speech.phone_alignment").ACCENTS),
        default=convert._addon("speech.phone_alignment").DEFAULT_ACCENT,
        help="with a transcript: the speaker's accent, as one of espeak-ng's English voices (default: en-us)",
    )
    parser.add_argument(
        "--words",
        action="store_true",
        help="without a transcript: recognise words and align them (needs PocketSphinx's word model; slower)",
    )
    parser.add_argument(
        "--no-adapt",
        action="store_true",
        help="with a transcript: align once, the model not adapted to the voice (about twice as fast, less exact)",
    )
    parser.add_argument(
        "--adapt-recognition",
        action="store_true",
        help="without a transcript: recognise twice, the model adapted to the voice from the first (slower)",
    )
    parser.add_argument("--face", type=Path, required=True, help="the face .blend")
    parser.add_argument("-o", "--out", type=Path, required=True, help="output folder")
    parser.add_argument("--name", type=_name, help="output file stem (default: from the text)")
    parser.add_argument("--object", help="name of the face mesh (default: the first mesh with feature points)")
    parser.add_argument("--voice", default="en", help="espeak-ng voice name (default: en)")
    parser.add_argument("--rate", type=convert._int_in(80, 450), default=175, help="words per minute (80 to 450)")
    parser.add_argument("--expression", type=_expression, help="an expression held over the speech, e.g. joy:0.6")
    parser.add_argument("--fps", type=_fps, default=25.0, help="frame rate of the stream and the video")
    parser.add_argument(
        "--resolution", type=convert._int_in(*convert.RESOLUTIONS), default=480, help="video height and width"
    )
    parser.add_argument("--visemes", action="store_true", help="write FAP 1 (the viseme) in every frame too")
    parser.add_argument("--no-video", action="store_true", help="skip the MP4 (and the contact sheet)")
    args = parser.parse_intermixed_args(argv)
    if (args.text is None) == (args.audio is None):
        parser.error("give either the TEXT to speak or --audio VOICE.wav")
    if args.audio is None and (args.transcript_text is not None or args.transcript is not None):
        parser.error("--text and --transcript give the transcript of --audio")
    return args


def default_name(text: str) -> str:
    return "_".join(re.findall(r"[0-9a-z]+", text.lower())[:6])[:40] or "speech"


def padded(samples: np.ndarray, sample_rate: int, n_frames: int, fps: float) -> np.ndarray:
    """The samples with silence up to the end of the last frame (n_frames / fps seconds)."""
    total = max(len(samples), math.ceil(n_frames * sample_rate / fps))
    return np.concatenate([samples, np.zeros(total - len(samples), dtype=samples.dtype)])


def _stream(args, name: str, segments, duration: float):
    """The FAP stream of viseme segments over `duration` s at --fps, with the --expression layer."""
    coarticulation = convert._addon("speech.coarticulation")
    tracks = coarticulation.fap_tracks(segments, args.fps, duration=duration)
    if args.expression is not None:
        tracks = tracks.with_offsets(convert._addon("speech.high_level").expression_values(*args.expression))
    visemes = coarticulation.viseme_track(segments, tracks.times) if args.visemes else None
    return tracks.to_stream(name, visemes)


def synthesize(args, name: str):
    """Everything the files hold, computed and checked before any is written: (stream, speech, audio,
    segments)."""
    espeak = convert._addon("speech.espeak")
    try:
        spoken = espeak.synthesize(args.text, args.voice, rate=args.rate)
        segments = espeak.speech_segments(spoken)
        stream = _stream(args, name, segments, spoken.duration)
    except convert._addon("speech").SpeechError as exc:
        raise SayError(str(exc)) from None
    n_frames = len(stream.frame_numbers)
    return stream, spoken, padded(spoken.samples, spoken.sample_rate, n_frames, args.fps), segments


def transcript_of(args) -> str | None:
    """The transcript from --text or --transcript (None: recognise the phones without one)."""
    if args.transcript is not None:
        convert.check_input(args.transcript, "transcript file")
        return convert._addon("speech.phone_alignment").read_transcript_file(args.transcript)
    return args.transcript_text


def lipsync(args, name: str, transcript: str | None):
    """The recording's stream, phones and segments, computed and checked before any file is written."""
    phone_alignment = convert._addon("speech.phone_alignment")
    try:
        take = convert._addon("speech.recording").read_recording(args.audio)
        if transcript is not None and not transcript.strip():
            raise SayError("the transcript is empty: give what is said, or leave --text/--transcript out")
        shown = [-1]

        def progress(fraction: float) -> None:
            if take.duration > 30 and int(fraction * 10) > shown[0]:
                shown[0] = int(fraction * 10)
                print(f"say.py: {'aligning' if transcript else 'recognising'} {fraction:.0%}", flush=True)

        phones = phone_alignment.phones_from_recording(
            take,
            transcript,
            accuracy=args.accuracy.upper(),
            progress=progress,
            words=args.words,
            accent=args.accent,
            adapt=not args.no_adapt,
            adapt_recognition=args.adapt_recognition,
        )
        segments = phone_alignment.phone_segments(phones, str(args.audio))
        stream = _stream(args, name, segments, take.duration)
    except convert._addon("speech").SpeechError as exc:
        raise SayError(str(exc)) from None
    return stream, phones, segments, take.duration


def write_files(out: Path, name: str, stream, phones, segments) -> Path:
    """NAME.fap, NAME_phonemes.tsv and NAME_visemes.tsv; returns the .fap's path."""
    cue_files = convert._addon("speech.cue_files")
    label = convert._addon("speech.segments").TimedLabel
    fap = out / f"{name}.fap"
    try:
        convert._addon("mpeg4.fap_file").write_fap(stream, fap)
        cue_files.write_timed_labels(out / f"{name}_phonemes.tsv", phones)
        visemes = [label(s.start, s.end, s.viseme.name) for s in segments]
        cue_files.write_timed_labels(out / f"{name}_visemes.tsv", visemes)
    except (OSError, convert._addon("errors").Mpeg4Error) as exc:
        raise SayError(f"cannot write the speech files: {exc}") from None
    return fap


def write_speech(out: Path, name: str, stream, spoken, audio: np.ndarray, segments) -> tuple[Path, Path]:
    wav = out / f"{name}.wav"
    labels = convert._addon("speech.espeak").phoneme_labels(spoken)
    fap = write_files(out, name, stream, labels, segments)
    try:
        convert._addon("speech.wav").write_wav(wav, audio, spoken.sample_rate)
    except convert._addon("errors").Mpeg4Error as exc:
        raise SayError(f"cannot write the speech files: {exc}") from None
    return fap, wav


# ----------------------------------------------------------------------------- MP4 boxes


def _boxes(data: bytes, start: int, end: int):
    """(type, payload start, box end) of the ISO-BMFF boxes in data[start:end]."""
    i = start
    while i + 8 <= end:
        size, kind = struct.unpack_from(">I4s", data, i)
        head = 8
        if size == 1:
            (size,) = struct.unpack_from(">Q", data, i + 8)
            head = 16
        elif size == 0:
            size = end - i
        if size < head or i + size > end:
            raise ValueError(f"a broken box at byte {i}")
        yield kind.decode("latin-1"), i + head, i + size
        i += size


def _children(data: bytes, box: tuple, kind: str):
    return [child for child in _boxes(data, box[1], box[2]) if child[0] == kind]


def mp4_durations(path: Path) -> dict[str, float]:
    """Seconds each track of an MP4 plays, by handler ('vide', 'soun'): its edit list's length where it has one
    (an AAC track's list skips the encoder's priming samples), else its media length."""
    data = Path(path).read_bytes()
    out: dict[str, float] = {}
    for moov in (box for box in _boxes(data, 0, len(data)) if box[0] == "moov"):
        (mvhd,) = _children(data, moov, "mvhd")
        version = data[mvhd[1]]
        movie_scale = struct.unpack_from(">I", data, mvhd[1] + (20 if version == 1 else 12))[0]
        for trak in _children(data, moov, "trak"):
            (mdia,) = _children(data, trak, "mdia")
            (hdlr,) = _children(data, mdia, "hdlr")
            (mdhd,) = _children(data, mdia, "mdhd")
            handler = data[hdlr[1] + 8 : hdlr[1] + 12].decode("latin-1")
            version = data[mdhd[1]]
            scale, length = struct.unpack_from(
                ">IQ" if version == 1 else ">II", data, mdhd[1] + (20 if version == 1 else 12)
            )
            seconds = length / scale
            for edts in _children(data, trak, "edts"):
                for elst in _children(data, edts, "elst"):
                    version = data[elst[1]]
                    (count,) = struct.unpack_from(">I", data, elst[1] + 4)
                    entry = 20 if version == 1 else 12
                    lengths = [
                        struct.unpack_from(">Q" if version == 1 else ">I", data, elst[1] + 8 + k * entry)[0]
                        for k in range(count)
                    ]
                    seconds = sum(lengths) / movie_scale
            out[handler] = seconds
    return out


# ----------------------------------------------------------------------------- the command


def check_arguments(args) -> str:
    """Checks that need no speech (the face file opens and holds the face); returns the output stem."""
    convert.check_input(args.face, "face file")
    if args.audio is not None:
        convert.check_input(args.audio, "audio file")
    convert.check_output_folder(args.out)
    convert.addon_package()
    try:
        if args.audio is None:
            convert._addon("speech.espeak").check_text(args.text)
        if args.expression is not None:
            convert._addon("speech.high_level").expression_values(*args.expression)
    except convert._addon("speech").SpeechError as exc:
        raise SayError(str(exc)) from None
    convert.open_face(args.face.resolve(), args.object)
    return args.name or default_name(args.text if args.audio is None else args.audio.stem)


def make_files(args, name: str) -> tuple[Path, Path]:
    """Compute, check, then write the speech files: (the .fap, the sound for the video)."""
    if args.audio is None:
        stream, spoken, audio, segments = synthesize(args, name)
        fap, wav = write_speech(args.out, name, stream, spoken, audio, segments)
        seconds = len(audio) / spoken.sample_rate
    else:
        stream, phones, segments, seconds = lipsync(args, name, transcript_of(args))
        fap, wav = write_files(args.out, name, stream, phones, segments), args.audio
    frames = len(stream.frame_numbers)
    print(f"{fap}: {frames} frames at {args.fps:g} fps; {wav}: {seconds:.3f} s", flush=True)
    return fap, wav


def main(argv: list[str] | None = None) -> int:
    args = parse_args(convert.script_argv() if argv is None else argv)
    try:
        name = check_arguments(args)
        fap, wav = make_files(args, name)
    except (SayError, convert.ConvertError) as exc:
        print(f"say.py: error: {exc}", file=sys.stderr, flush=True)
        return 2
    except KeyboardInterrupt:
        print("say.py: interrupted", file=sys.stderr, flush=True)
        return 130
    options = ["--resolution", str(args.resolution)] + (["--object", args.object] if args.object else [])
    if args.no_video:
        options += ["--no-video", "--sheet", "0"]
    status = convert.main(["--face", str(args.face), str(fap), "-o", str(args.out), "--audio", str(wav), *options])
    if status != 0 or args.no_video:
        return status
    video = args.out / f"{name}.mp4"
    tracks = mp4_durations(video)
    if "soun" not in tracks:
        print(f"say.py: error: {video} has no audio track", file=sys.stderr, flush=True)
        return 1
    print(f"{video}: video {tracks.get('vide', 0.0):.3f} s, audio {tracks['soun']:.3f} s", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
