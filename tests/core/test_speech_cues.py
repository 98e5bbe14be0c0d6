"""Timed label files (ours) and Rhubarb Lip Sync cue files -> viseme segments, label resolution, and every
kind of bad input refused naming the file, the line, the label and the time."""

import json
import wave

import numpy as np
import pytest

from addon.mpeg4.faps import Viseme
from addon.speech import SpeechError
from addon.speech.cue_files import (
    read_cue_file,
    read_rhubarb,
    read_segments,
    read_timed_labels,
    write_timed_labels,
)
from addon.speech.segments import TimedLabel, segments_from_labels
from addon.speech.wav import write_wav

RHUBARB_TSV = "0.00\tX\n0.05\tD\n0.27\tC\n0.31\tB\n0.43\tX\n0.47\tX\n"  # Rhubarb's README example ('Hi.')
RHUBARB_JSON = {
    "metadata": {"soundFile": "hi.wav", "duration": 0.47},
    "mouthCues": [
        {"start": 0.00, "end": 0.05, "value": "X"},
        {"start": 0.05, "end": 0.27, "value": "D"},
        {"start": 0.27, "end": 0.31, "value": "C"},
        {"start": 0.31, "end": 0.43, "value": "B"},
        {"start": 0.43, "end": 0.47, "value": "X"},
    ],
}
HI = [(0.0, 0.05, Viseme.NONE), (0.05, 0.27, Viseme.AA), (0.27, 0.31, Viseme.E), (0.31, 0.43, Viseme.SS)]
HI.append((0.43, 0.47, Viseme.NONE))


def write(tmp_path, name, text):
    path = tmp_path / name
    path.write_text(text if isinstance(text, str) else json.dumps(text), encoding="utf-8")
    return path


def triples(segments):
    return [(s.start, s.end, s.viseme) for s in segments]


def test_rhubarb_tsv_and_json_give_the_same_segments(tmp_path):
    tsv = read_rhubarb(write(tmp_path, "hi.tsv", RHUBARB_TSV))
    assert triples(tsv) == HI
    assert triples(read_rhubarb(write(tmp_path, "hi.json", RHUBARB_JSON))) == HI
    assert tsv[1].label == "D" and tsv[1].where.endswith("hi.tsv line 2")
    assert triples(read_cue_file(tmp_path / "hi.tsv")) == triples(read_cue_file(tmp_path / "hi.json")) == HI


def test_our_tsv_and_json_formats(tmp_path):
    tsv = write(tmp_path, "t.tsv", "# a comment\n0 0.1\t_\n\n0.1  0.2  p\r\n0.2 0.5 'aI\n0.5 0.6 h\n0.6 0.7 OU\n")
    segments = read_segments(tsv)
    assert triples(segments) == [
        (0.0, 0.1, Viseme.NONE),
        (0.1, 0.2, Viseme.PP),
        (0.2, 0.35, Viseme.AA),  # the diphthong's two parts share its time
        (0.35, 0.5, Viseme.IH),
        (0.6, 0.7, Viseme.OU),  # h has no shape of its own: its neighbours cover 0.5-0.6
    ]
    doc = {
        "about": "test",
        "segments": [{"start": 0, "end": 0.1, "label": "_"}, {"start": 0.1, "end": 0.2, "label": "7"}],
    }
    assert triples(read_cue_file(write(tmp_path, "t.json", doc))) == [(0, 0.1, Viseme.NONE), (0.1, 0.2, Viseme.SS)]
    assert triples(read_cue_file(tsv)) == triples(segments)


def test_labels_resolve_as_viseme_names_numbers_and_phonemes():
    items = [TimedLabel(k * 0.1, k * 0.1 + 0.1, label) for k, label in enumerate(["PP", "14", "E", "e@", ",i:", "_:"])]
    assert [s.viseme for s in segments_from_labels(items)] == [
        Viseme.PP, Viseme.OU, Viseme.E, Viseme.E, Viseme.IH, Viseme.NONE,
    ]  # fmt: skip


def test_written_labels_read_back(tmp_path):
    items = [TimedLabel(0.0, 0.011, "_"), TimedLabel(0.011, 0.062, "h"), TimedLabel(0.062, 0.1234567891, "'oU")]
    write_timed_labels(tmp_path / "out.tsv", items)
    assert [tuple(x[:3]) for x in read_timed_labels(tmp_path / "out.tsv")] == [tuple(x[:3]) for x in items]


@pytest.mark.parametrize(
    ("name", "text", "message"),
    [
        ("a.tsv", "0 0.1 p\n0.1 0.2 qq\n", r"a.tsv line 2: 'qq' at 0.100 s: unknown phoneme or viseme"),
        ("a.tsv", "0 0.1 p\n0.1 0.2 15\n", r"line 2: '15' at 0.100 s: unknown phoneme or viseme"),
        (
            "a.tsv",
            "0 0.2 p\n0.1 0.3 a\n",
            r"line 2: 'a' at 0.100 s: it overlaps .*a.tsv line 1: 'p' at 0.000 s, which ends at 0.200 s",
        ),
        ("a.tsv", "-0.1 0.2 p\n", r"line 1: 'p' at -0.100 s: negative start time"),
        ("a.tsv", "0.5 0.6 p\n0.1 0.2 a\n", r"line 2: 'a' at 0.100 s: times are not sorted"),
        ("a.tsv", "0.5 0.4 p\n", r"line 1: 'p' at 0.500 s: it ends at 0.400 s, before it starts"),
        ("a.tsv", "0 0.1\n", r"a.tsv line 1: expected 'start end label', found 2 field"),
        ("a.tsv", "0 x p\n", r"line 1: time 'x' is not a number"),
        ("a.tsv", "0 1e999 p\n", r"line 1: time '1e999' is not a finite number"),
        ("a.tsv", "# only a comment\n", r"a.tsv: no timed lines"),
        ("r.tsv", "0.00\tX\n0.05\tQ\n0.1\tX\n", r"r.tsv line 2: 'Q' at 0.050 s: unknown Rhubarb mouth shape"),
        ("r.tsv", "0.00\tX\n0.30\tD\n0.10\tX\n", r"line 3: 'X' at 0.100 s: times are not sorted"),
        ("r.tsv", "-0.5\tX\n0.1\tD\n0.2\tX\n", r"line 1: 'X' at -0.500 s: negative start time"),
        ("r.tsv", "0.00\tX\n", r"needs at least two lines"),
    ],
)
def test_bad_timed_files_are_refused_naming_line_label_and_time(tmp_path, name, text, message):
    path = write(tmp_path, name, text)
    reader = read_rhubarb if name.startswith("r") else read_segments
    with pytest.raises(SpeechError, match=message):
        reader(path)


@pytest.mark.parametrize(
    ("doc", "message"),
    [
        (
            {"mouthCues": [{"start": 0, "end": 0.1, "value": "X"}, {"start": 0.05, "end": 0.2, "value": "A"}]},
            "overlaps",
        ),
        ({"mouthCues": [{"start": 0, "end": 0.1, "value": "Z"}]}, "mouth cue 1: 'Z' at 0.000 s: unknown Rhubarb"),
        ({"mouthCues": [{"start": "0", "end": 0.1, "value": "X"}]}, "mouth cue 1: start: '0' is not a finite number"),
        ({"mouthCues": [{"start": 0, "end": 0.1}]}, 'mouth cue 1: expected {"start"'),
        ({"mouthCues": []}, "non-empty list of mouth cues"),
        ({"cues": []}, "expected a Rhubarb JSON file"),
    ],
)
def test_bad_rhubarb_json_is_refused(tmp_path, doc, message):
    with pytest.raises(SpeechError, match=message):
        read_rhubarb(write(tmp_path, "r.json", doc))


def test_bad_json_label_files_are_refused(tmp_path):
    doc = {"segments": [{"start": 0, "end": 0.1, "label": "p"}, {"start": 0.1, "end": 0.2, "label": "zz"}]}
    with pytest.raises(SpeechError, match="segment 2: 'zz' at 0.100 s: unknown phoneme"):
        read_segments(write(tmp_path, "s.json", doc))
    with pytest.raises(SpeechError, match="NaN is not a number"):
        read_segments(write(tmp_path, "n.json", '{"segments": [{"start": NaN, "end": 0.1, "label": "p"}]}'))
    with pytest.raises(SpeechError, match="no timed labels"):
        segments_from_labels([])


def test_wav_writer_round_trips_samples(tmp_path):
    samples = (np.sin(np.arange(2205) / 10) * 20000).astype(np.int16)
    path = write_wav(tmp_path / "a.wav", samples, 22050)
    with wave.open(str(path)) as audio:
        assert (audio.getnchannels(), audio.getsampwidth(), audio.getframerate()) == (1, 2, 22050)
        np.testing.assert_array_equal(np.frombuffer(audio.readframes(audio.getnframes()), "<i2"), samples)
    with pytest.raises(SpeechError, match="1-D array of int16"):
        write_wav(tmp_path / "b.wav", samples.astype(np.float32), 22050)
    with pytest.raises(SpeechError, match="sample rate 0 Hz"):
        write_wav(tmp_path / "b.wav", samples, 0)
    with pytest.raises(SpeechError, match="cannot write the audio"):
        write_wav(tmp_path / "missing" / "b.wav", samples, 22050)


def test_a_cue_path_that_is_not_a_regular_file_is_refused_without_reading(tmp_path):
    import os

    fifo = tmp_path / "cues.tsv"
    os.mkfifo(fifo)
    with pytest.raises(SpeechError, match="not a regular file"):
        read_cue_file(fifo)
    with pytest.raises(SpeechError, match="not a regular file"):
        read_cue_file("/dev/zero")
