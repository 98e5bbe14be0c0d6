"""Fuzzing the .fap reader: any input gives a correct stream or a FapFileError, never anything else.

"Correct" is checked against `reference_read`, a slow, obvious per-token reading of the policy in the
module docstring of `addon.mpeg4.fap_file`: both must accept the same inputs and give the same arrays.
"""

import itertools
import math
import re

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from addon.mpeg4.fap_file import N_FAPS, FapFileError, FapStream, format_fap, parse_fap

NUMBER = re.compile(r"[-+]?(?:[0-9]+(?:\.[0-9]*)?|\.[0-9]+)(?:[eE][-+]?[0-9]+)?", re.ASCII)
DIGITS = re.compile(r"[0-9]+", re.ASCII)
BLANKS = re.compile(r"[ \t]+")
HIGH_LEVEL_FORMS = {
    (0, 0): [(0, 0)],
    (1, 0): [(4, 0), (1, 0)],
    (0, 1): [(0, 6), (0, 1)],
    (1, 1): [(4, 6), (4, 1), (1, 6), (1, 1)],
}


def reference_read(data):
    """(name, fps, frame numbers, mask, values, viseme, expression) or None for invalid input."""
    if isinstance(data, bytes):
        if b"\0" in data:
            return None
        try:
            data = data.decode("utf-8")
        except UnicodeDecodeError:
            return None
    if "\0" in data:
        return None
    data = data.removeprefix("\ufeff")
    lines = [line.strip(" \t") for line in data.replace("\r\n", "\n").replace("\r", "\n").split("\n")]
    lines = [line for line in lines if line and not line.startswith("#")]
    if not lines or any(len(line) > 8192 for line in lines):
        return None
    header = BLANKS.split(lines[0])
    if len(header) < 4 or header[0] not in ("2.0", "2.1", "2.2") or not DIGITS.fullmatch(header[-1]):
        return None
    if not NUMBER.fullmatch(header[-2]) or not 0 < float(header[-2]) < math.inf:
        return None
    name = lines[0][len(header[0]) :].strip(" \t")
    for token in header[-2:][::-1]:
        name = name[: -len(token)].rstrip(" \t")
    if len(lines) % 2 == 0:
        return None
    frames, length = [], None
    for mask_text, value_text in zip(lines[1::2], lines[2::2], strict=True):
        flags = BLANKS.split(mask_text)
        if len(flags) not in (68, 69) or any(flag not in ("0", "1") for flag in flags):
            return None
        length = length or len(flags)
        if len(flags) != length:
            return None
        tokens = BLANKS.split(value_text)
        if not DIGITS.fullmatch(tokens[0]) or len(tokens[0].lstrip("0")) > 16:
            return None
        frame = int(tokens[0].lstrip("0") or "0")  # int() takes at most 4,300 digits
        if frame > 2**53 - 1:
            return None
        if not all(NUMBER.fullmatch(token) and math.isfinite(float(token)) for token in tokens[1:]):
            return None
        numbers = [float(token) for token in tokens[1:]]
        mask = [flag == "1" for flag in flags]
        low_faps = [k for k in range(2, length) if mask[k]]
        for n_viseme, n_expression in HIGH_LEVEL_FORMS[mask[0], mask[1]]:
            if len(numbers) == len(low_faps) + n_viseme + n_expression:
                break
        else:
            return None
        values = [0.0] * N_FAPS
        for k, value in zip(low_faps, numbers[n_viseme + n_expression :], strict=True):
            if k < N_FAPS:
                values[k] = value
        viseme = numbers[:n_viseme] + [0.0] * (4 - n_viseme)
        expression = numbers[n_viseme : n_viseme + n_expression] + [0.0] * (6 - n_expression)
        frames.append((frame, mask[:N_FAPS], values, viseme, expression))
    if any(b[0] <= a[0] for a, b in itertools.pairwise(frames)):
        return None
    columns = list(zip(*frames, strict=True)) or [[]] * 5
    return (name, float(header[-2]), *(np.array(column) for column in columns))


def check(data) -> FapStream | None:
    """Read `data` with parse_fap; assert it agrees with reference_read and keeps its invariants."""
    expected = reference_read(data)
    try:
        stream = parse_fap(data, "fuzz.fap")
    except FapFileError as exc:
        assert str(exc).startswith("fuzz.fap: line "), str(exc)
        assert expected is None, "parse_fap rejected input that the reference reads"
        return None
    assert expected is not None, "parse_fap read input that the reference rejects"
    n = stream.n_frames
    assert stream.frame_numbers.dtype == np.int64 and stream.frame_numbers.shape == (n,)
    assert stream.mask.dtype == bool and stream.mask.shape == (n, N_FAPS)
    assert stream.values.shape == (n, N_FAPS) and stream.viseme.shape == (n, 4)
    assert stream.expression.shape == (n, 6)
    assert np.all(np.isfinite(stream.values)) and not np.any(stream.values[~stream.mask])
    assert not np.any(stream.values[:, :2])
    assert not np.any(stream.viseme[~stream.mask[:, 0]]) and not np.any(stream.expression[~stream.mask[:, 1]])
    assert np.all(np.diff(stream.frame_numbers) > 0)
    name, fps, frame_numbers, mask, values, viseme, expression = expected
    assert (stream.name, stream.fps) == (name, fps)
    if n:
        np.testing.assert_array_equal(stream.frame_numbers, frame_numbers)
        np.testing.assert_array_equal(stream.mask, mask)
        np.testing.assert_array_equal(stream.values, values)
        np.testing.assert_array_equal(stream.viseme, viseme)
        np.testing.assert_array_equal(stream.expression, expression)
    return stream


def mask_text(faps, length=N_FAPS, sep=" "):
    return sep.join("1" if k in faps else "0" for k in range(1, length + 1))


VALID_FILES = [
    f"2.1 example 25 2\n{mask_text({3, 31})}\n0 200 100\n{mask_text({3, 31})}\n1 400 150\n",
    f"2.0 jag 5 2\r\n{mask_text({3, 4}, sep=chr(9))}\r\n0\t57\t-114\r\n{mask_text({3, 4})} \r\n1\t58\t-116 \r\n",
    f"2.1 Xface::FapFile 25 2\n# anger\n{mask_text(set())} \n0 \n# joy\n{mask_text({4, 5})}\n1 0.322581 -4.6e1\n",
    f"2.1 AU Interpolation_1214.fap 25 1\n{mask_text({19, 20, 21, 22}, 69)} \n0 940 940 200 200 \n",
    f"2.1 1-Welcome_1.fap 25 2\n{mask_text({1, 69}, 69)}\n0 3 7\n{mask_text({1, 2, 3}, 69)}\n4 1 2 -5\n",
    f"2.2 high 25 2\n{mask_text({1, 2, 5})}\n3 1 10 40 0 3 63 6 20 1 0 -2\n{mask_text({2})}\n9 6 1 0 0 0 0\n",
]
JUNK_TOKENS = [
    "nan",
    "inf",
    "1e999",
    "x",
    "0.5",
    "-1",
    "2",
    "1,5",
    "#",
    "1e",
    ".",
    "+",
    "0",
    "1",
    "\t",
    "",
    "\r",
    "\n",
    "9" * 30,
    "1" * 70,
    "0" * 4400 + "7",  # more digits than int() converts
    str(2**53 - 1),
    str(2**53),
    "\x0c",
    "\u00a0",
    "\xff",
    "٣",
]


@st.composite
def mutated_files(draw):
    data = draw(st.sampled_from(VALID_FILES))
    for _ in range(draw(st.integers(1, 3))):
        op = draw(
            st.sampled_from(
                [
                    "delete token",
                    "duplicate token",
                    "replace token",
                    "delete line",
                    "duplicate line",
                    "swap lines",
                    "crowd line",
                    "truncate",
                    "insert",
                ]
            )
        )
        tokens = re.split(r"([ \t\r\n]+)", data)  # tokens at even indices, separators at odd ones
        lines = data.split("\n")
        i = draw(st.integers(0, max(len(tokens) - 1, 0)))
        j = draw(st.integers(0, max(len(lines) - 1, 0)))
        k = draw(st.integers(0, max(len(lines) - 1, 0)))
        if op == "delete token":
            tokens[i] = ""
        elif op == "duplicate token":
            tokens[i] = tokens[i] + " " + tokens[i]
        elif op == "replace token":
            tokens[i] = draw(st.sampled_from(JUNK_TOKENS))
        elif op == "delete line":
            del lines[j]
        elif op == "duplicate line":
            lines.insert(j, lines[j])
        elif op == "swap lines":
            lines[j], lines[k] = lines[k], lines[j]
        elif op == "crowd line":  # around the most tokens a value line can hold (78)
            lines[j] += draw(st.sampled_from([" 1", " x", "\t2.5"])) * draw(st.integers(50, 200))
        elif op == "truncate":
            data = data[: draw(st.integers(0, len(data)))]
        else:
            at = draw(st.integers(0, len(data)))
            data = data[:at] + draw(st.sampled_from(JUNK_TOKENS + [" ", "\n"])) + data[at:]
        if op.endswith("token"):
            data = "".join(tokens)
        elif op.endswith(("line", "lines")):
            data = "\n".join(lines)
    return data


def test_valid_files_read():
    for data in VALID_FILES:
        assert check(data) is not None
        assert check(data.encode()) is not None


@settings(max_examples=400, deadline=None)
@given(st.binary(max_size=600))
def test_random_bytes(data):
    check(data)


@settings(max_examples=300, deadline=None)
@given(st.text(max_size=300))
def test_random_text(data):
    check(data)


@settings(max_examples=400, deadline=None)
@given(
    st.sampled_from(["", "2.1 soup 25 3\n", "2.0 a b 10 1\r\n"]),
    st.lists(st.sampled_from(JUNK_TOKENS + [" ", "\n", "\r\n", "0 " * 68, "0 " * 69, "1 " * 68]), max_size=60),
)
def test_token_soup(prefix, tokens):
    check(prefix + " ".join(tokens))


@settings(max_examples=800, deadline=None)
@given(mutated_files(), st.booleans())
def test_mutated_valid_files(data, as_bytes):
    check(data.encode("utf-8", errors="surrogatepass") if as_bytes else data)


@settings(max_examples=100, deadline=None)
@given(st.integers(0, 2**32 - 1), st.integers(1, 40))
def test_mutated_written_streams(seed, n_frames):
    rng = np.random.default_rng(seed)
    mask = rng.random((n_frames, N_FAPS)) < rng.random()
    values = np.where(mask, np.round(rng.normal(0, 300, (n_frames, N_FAPS)), 2), 0.0)
    values[:, :2] = 0
    viseme = np.where(mask[:, :1], rng.integers(0, 15, (n_frames, 4)), 0)
    expression = np.where(mask[:, 1:2], rng.integers(0, 7, (n_frames, 6)), 0)
    stream = FapStream("2.1", "w", 25.0, np.arange(n_frames), mask, values, viseme, expression)
    data = bytearray(format_fap(stream).encode())
    check(bytes(data))
    for _ in range(3):
        at = int(rng.integers(0, len(data)))
        data[at : at + int(rng.integers(0, 4))] = rng.choice(
            np.frombuffer(b"0123456789 .-+e\nx\t\r#", np.uint8), 2
        ).tobytes()
        check(bytes(data))


@settings(max_examples=200, deadline=None)
@given(
    st.lists(
        st.tuples(
            st.sets(st.integers(1, N_FAPS), max_size=N_FAPS),
            st.integers(0, 200),  # values after the frame number: 78 at most can be right
            st.sampled_from(["1", "-2.5", "x", "1e999", "\t1"]),
        ),
        min_size=1,
        max_size=4,
    )
)
def test_value_lines_around_the_most_values_a_frame_holds(frames):
    lines = ["2.1 crowded 25 1"]
    for i, (faps, n_values, odd) in enumerate(frames):
        values = ["1"] * n_values
        if values:
            values[n_values // 2] = odd
        lines += [mask_text(faps), " ".join([str(i), *values])]
    check("\n".join(lines) + "\n")
