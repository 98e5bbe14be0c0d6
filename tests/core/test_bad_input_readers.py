"""Bad input through the newer readers (issue 30): the FDP and XFace readers, cue files, the JSON reader under
them, the speech caps. Each of the reported breaks has its case here, then a generated corpus per reader that
asserts the promise: only an Mpeg4Error escapes, quickly, and memory stays bounded (under setrlimit in a
subprocess)."""

import json
import os
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from addon.errors import Mpeg4Error
from addon.fitting.fdp_file import FdpFileError, fdp_text, parse_fdp
from addon.fitting.xface_fdp import XfaceFdpError, parse_xface_fdp
from addon.mpeg4.faps import Viseme
from addon.speech import SpeechError, coarticulation, cue_files
from addon.speech.segments import Segment
from addon.speech.tables import load_dominance, load_visemes
from addon.speech.wav import write_wav
from addon.user_files import NAME_MAX, file_problem, output_problem
from addon.user_json import MAX_DEPTH, parse_json

from .test_fitting_files import XFACE_SAMPLE, sample_fdp

ROOT = Path(__file__).resolve().parents[2]
FDP = fdp_text(sample_fdp()).encode()
CUES_JSON = json.dumps(
    {"segments": [{"start": 0.0, "end": 0.1, "label": "_"}, {"start": 0.1, "end": 0.3, "label": "p"}]}
)
RHUBARB_JSON = json.dumps({"metadata": {}, "mouthCues": [{"start": 0.0, "end": 0.2, "value": "A"}]})
CUE_TSV = "0 0.1 _\n0.1 0.3 p\n0.3 0.5 AA\n"
RHUBARB_TSV = "0.00\tX\n0.05\tD\n0.27\tC\n0.47\tX\n"


def fdp_with(**changes) -> bytes:
    document = json.loads(FDP)
    document.update(changes)
    return json.dumps(document).encode()


# ----------------------------------------------------------------------------- the reported breaks


@pytest.mark.parametrize("digits", [400, 5001])
def test_an_fdp_number_with_hundreds_of_digits_is_refused_naming_where(digits):
    data = FDP.replace(b'"2.1": [', b'"2.1": [' + b"1" * digits + b", ", 1).replace(b", 0.0, ", b", ", 1)
    with pytest.raises(
        FdpFileError, match=rf"FDP: line \d+, column \d+: the number 1+\.\.\.1+ \({digits} characters\)"
    ):
        parse_fdp(data)


@pytest.mark.parametrize("name", ["c.json", "r.json"])
def test_cue_json_with_huge_numbers_or_deep_nesting_is_a_speech_error(tmp_path, name):
    path = tmp_path / name
    for text, message in (
        ('{"segments": [{"start": 0, "end": ' + "1" * 5001 + ', "label": "p"}]}', "more than 40 digits"),
        ('{"segments": [{"start": 0, "end": 1e400, "label": "p"}]}', "1e400 is out of range"),
        ("[" * 100_000 + "]" * 100_000, f"nested more than {MAX_DEPTH} deep"),
    ):
        path.write_text(text)
        with pytest.raises(SpeechError, match=f"{name}: the cue file: .*{message}"):
            cue_files.read_cue_file(path)


def test_json_strings_with_brackets_do_not_count_as_nesting():
    text = json.dumps({"about": "[" * 1000 + '\\"{' * 100, "segments": [[[]]]})
    assert parse_json(text, Mpeg4Error, "t")["segments"] == [[[]]]


@pytest.mark.parametrize("encoding", ["UTF-7", "klingon", "UTF-16", "cp1252"])
def test_xface_encoding_declarations_other_than_utf8_are_refused(encoding):
    with pytest.raises(XfaceFdpError, match=f"declares the encoding '{encoding}'; an XFace FDP is UTF-8"):
        parse_xface_fdp(f'<?xml version="1.0" encoding="{encoding}"?><xfdp/>'.encode())


def test_an_xface_fdp_declared_utf8_or_latin1_still_reads():
    assert parse_xface_fdp(XFACE_SAMPLE.replace(b"UTF-8", b"ISO-8859-1")).fapu.ES0 == 64.0


@pytest.mark.parametrize("value", [1e308, -1e300, 1e5])
def test_fdp_coordinates_beyond_any_face_are_refused(value):
    with pytest.raises(FdpFileError, match=r"feature_points 2\.1: .* is more than 10000 from the face's origin"):
        parse_fdp(fdp_with(feature_points={"2.1": [value, value, value]}))


@pytest.mark.parametrize("value", [1e300, 1e-300, 1e6, 1e-6])
def test_fapu_no_face_has_is_refused_with_the_plausible_range(value):
    fapu = {"IRISD0": 0.01, "ES0": value, "ENS0": 0.04, "MNS0": 0.02, "MW0": 0.05}
    with pytest.raises(FdpFileError, match=r"implausible FAPU \(any unit\): ES0 = .* \(plausible 1e-05\.\.1e\+05\)"):
        parse_fdp(fdp_with(fapu=fapu))
    xml = XFACE_SAMPLE.replace(b'ES0="64"', f'ES0="{value!r}"'.encode())
    with pytest.raises(XfaceFdpError, match=r"<fapu>: implausible FAPU \(any unit\): ES0"):
        parse_xface_fdp(xml)


@pytest.mark.parametrize("time", ["1e308", "1e300", "3600.04", "36000"])
def test_huge_cue_times_are_refused_before_any_frame_is_made(tmp_path, time):
    path = tmp_path / "h.tsv"
    path.write_text(f"0 {time} p\n")
    segments = cue_files.read_cue_file(path)
    with pytest.raises(SpeechError, match="more than the 90000 frames allowed"):
        coarticulation.fap_tracks(segments, 25.0)


def test_a_cue_file_over_the_cap_is_refused_naming_the_line(tmp_path, monkeypatch):
    monkeypatch.setattr(cue_files, "MAX_CUES", 50)
    path = tmp_path / "many.tsv"
    path.write_text("0 0 PP\n" * (cue_files.MAX_CUES + 1))
    with pytest.raises(SpeechError, match=f"many.tsv line {cue_files.MAX_CUES + 1}: more than {cue_files.MAX_CUES}"):
        cue_files.read_cue_file(path)
    path = tmp_path / "many.json"
    path.write_text(json.dumps({"segments": [{"start": 0, "end": 0, "label": "p"}] * (cue_files.MAX_CUES + 1)}))
    with pytest.raises(SpeechError, match=f"more than {cue_files.MAX_CUES}; split the file"):
        cue_files.read_cue_file(path)


def test_names_too_long_are_reasons_not_errors(tmp_path):
    long = tmp_path / ("a" * (NAME_MAX + 1) + ".wav")
    assert "File name too long" in file_problem(long)
    assert f"longer than {NAME_MAX} bytes" in output_problem(long)
    assert output_problem(tmp_path / "ok.wav") is None and "NUL" in output_problem("a\0b")
    assert "not a regular file but a directory" in file_problem(tmp_path)
    with pytest.raises(SpeechError, match="cannot write the audio: File name too long"):
        write_wav(long, np.zeros(10, np.int16), 8000)  # its cleanup does not raise again
    assert os.listdir(tmp_path) == []


def test_a_silence_keeps_two_frames_and_linear_keys_give_every_frame_back():
    values = np.repeat([[0.0, 1.0], [2.0, 3.0], [5.0, 1.0]], [1, 1005, 3], axis=0)  # a jump, a long hold, a jump
    kept = coarticulation.changing_frames(values)
    np.testing.assert_array_equal(kept, [0, 1, 1005, 1006, 1008])
    for column in range(2):
        np.testing.assert_array_equal(np.interp(np.arange(len(values)), kept, values[kept, column]), values[:, column])


def _close_one_at_a_time(values, times, spans, closure_fps):
    """The closure constraint segment after segment, as it was written before issue 30 (the reference)."""
    visemes, dominance = load_visemes(), load_dominance()
    shape = visemes.targets[Viseme.PP]
    column = coarticulation.CLOSURE_PAIRS[0][0] - 1
    tb, ta = dominance.theta_before[Viseme.PP, column], dominance.theta_after[Viseme.PP, column]
    c = dominance.exponent[Viseme.PP, column]
    for start, end in spans:
        a, b = start, end
        nearest = round(0.5 * (start + end) * closure_fps) / closure_fps
        a, b = min(a, nearest), max(b, nearest)
        t = times
        weight = np.where(
            t < a,
            np.exp(-tb * np.maximum(a - t, 0) ** c),
            np.where(t > b, np.exp(-ta * np.maximum(t - b, 0) ** c), 1.0),
        )
        for upper, lower, upper_outer, lower_outer in coarticulation.CLOSURE_PAIRS:
            up, down, jaw = upper - 1, lower - 1, coarticulation.OPEN_JAW - 1
            share = shape[up] / (shape[up] + shape[down])
            gap = values[:, jaw] - values[:, up] - values[:, down]
            correction = weight * np.maximum(gap - (shape[jaw] - shape[up] - shape[down]), 0.0)
            for fu, fl in ((upper, lower), (upper_outer, lower_outer)):
                values[:, fu - 1] += share * correction
                values[:, fl - 1] += (1.0 - share) * correction
    return values


@settings(max_examples=25, deadline=None)
@given(st.lists(st.tuples(st.integers(0, 40), st.integers(0, 6)), min_size=1, max_size=8))
def test_closing_every_bilabial_in_one_pass_equals_closing_them_one_at_a_time(steps):
    segments, t = [], 0.0
    for gap, length in steps:
        t += gap * 0.01
        segments.append(Segment(t, t + length * 0.01, Viseme.PP))
        t += length * 0.01
    times = np.arange(int(t * 25) + 20) / 25.0
    open_mouth = coarticulation.coarticulate([Segment(0.0, t + 1.0, Viseme.AA)], times)
    expected = _close_one_at_a_time(open_mouth.copy(), times, [(s.start, s.end) for s in segments], 25.0)
    got = open_mouth.copy()
    coarticulation._close_bilabials(got, times, segments, load_visemes(), load_dominance(), 25.0)
    np.testing.assert_allclose(got, expected, rtol=0, atol=1e-9)


# ----------------------------------------------------------------------------- generated corpora

SEEDS = {
    "fdp": FDP,
    "xface": XFACE_SAMPLE,
    "cues.json": CUES_JSON.encode(),
    "rhubarb.json": RHUBARB_JSON.encode(),
    "cues.tsv": CUE_TSV.encode(),
    "rhubarb.tsv": RHUBARB_TSV.encode(),
}
HOSTILE = [
    b"1" * 500, b"-" + b"9" * 60, b"1e999", b"-1e400", b"NaN", b"Infinity", b"[" * 200, b"{" * 80, b"]" * 5,
    b'"' * 3, b"\x00", b"\xff\xfe", b"\xef\xbb\xbf", b"<!ENTITY x 'y'>", b'<?xml version="1.0" encoding="UTF-7"?>',
    b"1e308", b"0.0000000000000000000000000000000000000000000001", b"\t", b"\r", b"\n" * 3, b"PP", b"X", b"#",
]  # fmt: skip


def _mutate(seed: bytes, edits) -> bytes:
    data = bytearray(seed)
    for where, kind, payload in edits:
        at = where % (len(data) + 1)
        if kind == 0:
            data[at:at] = payload
        elif kind == 1:
            del data[at : at + len(payload)]
        elif kind == 2:
            data[at : at + len(payload)] = payload
        else:
            data = data[:at]
    return bytes(data)


EDITS = st.lists(
    st.tuples(
        st.integers(0, 1 << 16),
        st.integers(0, 3),
        st.one_of(st.sampled_from(HOSTILE), st.binary(min_size=1, max_size=8)),
    ),
    min_size=1,
    max_size=4,
)


def _read(kind: str, data: bytes, folder: Path):
    if kind == "fdp":
        return parse_fdp(data)
    if kind == "xface":
        return parse_xface_fdp(data)
    path = folder / kind
    path.write_bytes(data)
    return cue_files.read_cue_file(path)


@pytest.mark.parametrize("kind", SEEDS)
@settings(max_examples=60, deadline=2000, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(edits=EDITS)
def test_only_mpeg4_errors_escape_a_reader_of_mutated_files(tmp_path, kind, edits):
    try:
        _read(kind, _mutate(SEEDS[kind], edits), tmp_path)
    except Mpeg4Error as exc:
        assert str(exc) and "Traceback" not in str(exc)


@settings(max_examples=25, deadline=3000)
@given(
    st.recursive(
        st.one_of(
            st.none(),
            st.booleans(),
            st.integers(-(10**60), 10**60),
            st.floats(allow_nan=False),
            st.text(max_size=8),
        ),
        lambda inner: st.one_of(st.lists(inner, max_size=4), st.dictionaries(st.text(max_size=6), inner, max_size=4)),
        max_leaves=30,
    )
)
def test_only_mpeg4_errors_escape_cue_and_fdp_readers_of_any_json(tmp_path_factory, document):
    text = json.dumps(document, allow_nan=True)
    folder = tmp_path_factory.mktemp("j")
    for kind in ("fdp", "cues.json", "rhubarb.json"):
        try:
            _read(kind, text.encode(), folder)
        except Mpeg4Error:
            pass


MEMORY_CASES = {
    # what: (script run under the limit, the message it must print)
    "16 MiB of zero-length PP cues": (
        "p.write_text('0 0 PP\\n' * (16 * 2**20 // 7))\nread_cue_file(p)",
        "more than 100000 timed lines",
    ),
    "one cue an hour long": ("p.write_text('0 3600.04 p\\n')\nfap_tracks(read_cue_file(p), 25.0)", "frames allowed"),
    "ten hours of AA": ("p.write_text('0 36000 AA\\n')\nfap_tracks(read_cue_file(p), 25.0)", "frames allowed"),
    "an hour of silence at the cap": (
        "p.write_text('0 3599 _\\n')\nprint('frames', fap_tracks(read_cue_file(p), 25.0).n_frames)",
        "frames 89975",
    ),
    "16 MiB of nested JSON": (
        "p = p.with_suffix('.json')\np.write_text('[' * (8 * 2**20) + ']' * (8 * 2**20))\nread_cue_file(p)",
        "nested more than 64 deep",
    ),
}


@pytest.mark.parametrize("case", MEMORY_CASES)
def test_caps_bound_memory_and_time_under_a_limit(tmp_path, case):
    """Each case in a subprocess limited to 1.5 GB of address space and 60 s of CPU: a refusal (or the capped
    result) printed, no MemoryError, no kill."""
    body, expected = MEMORY_CASES[case]
    script = "\n".join(
        [
            "import resource, sys",
            "from pathlib import Path",
            "resource.setrlimit(resource.RLIMIT_AS, (1536 * 2**20, 1536 * 2**20))",
            "resource.setrlimit(resource.RLIMIT_CPU, (60, 60))",
            "from addon.errors import Mpeg4Error",
            "from addon.speech.coarticulation import fap_tracks",
            "from addon.speech.cue_files import read_cue_file",
            "p = Path(sys.argv[1]) / 'cues.tsv'",
            "try:",
            textwrap.indent(body, "    "),
            "except Mpeg4Error as exc:",
            "    print('refused:', exc)",
        ]
    )
    result = subprocess.run(
        [sys.executable, "-c", script, str(tmp_path)], capture_output=True, text=True, cwd=ROOT, timeout=120
    )
    assert result.returncode == 0, result.stderr[-2000:]
    assert expected in result.stdout
