"""Files that are not .fap streams, or far too large, stop at once with one clear error."""

import os
import time

import pytest

from addon.mpeg4 import fap_file
from addon.mpeg4.fap_file import FapFileError, parse_fap, read_fap

MASK = " ".join(["1"] + ["0"] * 67)  # FAP 1 only: 4 values after the frame number


def test_a_fifo_is_refused_without_opening_it(tmp_path):
    fifo = tmp_path / "stream.fap"
    os.mkfifo(fifo)
    start = time.monotonic()
    with pytest.raises(FapFileError, match="stream.fap: not a regular file"):
        read_fap(fifo)  # opening it would block until a writer comes
    assert time.monotonic() - start < 5


@pytest.mark.parametrize("path", ["/dev/zero", "/"])
def test_devices_and_folders_are_refused(path):
    with pytest.raises(FapFileError, match="not a regular file"):
        read_fap(path)


def test_a_file_beyond_the_size_cap_is_refused_after_reading_at_most_the_cap(tmp_path, monkeypatch):
    monkeypatch.setattr(fap_file, "MAX_FILE_BYTES", 1000)
    path = tmp_path / "big.fap"
    path.write_text("2.1 big 25 1\n" + "x" * 5000)
    with pytest.raises(FapFileError, match=r"big.fap: larger than 0 MiB"):
        read_fap(path)


def test_a_309_digit_frame_number_says_it_is_too_large():
    text = f"2.1 x 25 1\n{MASK}\n{'9' * 309} 0 0 0 0\n"
    with pytest.raises(FapFileError) as err:
        parse_fap(text, "t.fap")
    message = str(err.value)
    assert message == "t.fap: line 3: frame number 999999999999...(309 digits) is too large (at most 9007199254740991)"


def test_a_frame_number_just_beyond_exact_doubles_is_too_large():
    with pytest.raises(FapFileError, match=r"line 3: frame number 9007199254740993 is too large"):
        parse_fap(f"2.1 x 25 1\n{MASK}\n{2**53 + 1} 0 0 0 0\n", "t.fap")


@pytest.mark.parametrize(
    ("text", "line"),
    [
        (f"2.1 x 25 1\n{MASK}\n0 " + "x" * 8_000_000 + "\n", 3),
        ("2.1 x 25 1\n" + "1 " * 4_000_000 + "\n0 1\n", 2),
        (f"2.1 x 25 1\n{MASK}\n0 " + "1 " * 4_000_000 + "\n", 3),
        ("2.1 " + "n" * 8_000_000 + " 25 1\n", 1),
    ],
)
def test_a_huge_line_is_refused_before_it_is_split(text, line):
    with pytest.raises(FapFileError, match=rf"t.fap: line {line}: \d+ characters long; a .fap line has at most 8192"):
        parse_fap(text, "t.fap")


def test_the_longest_line_a_producer_writes_still_reads():
    mask = " ".join(["1"] * 68)
    values = " ".join(["-123456.789012345"] * 76)  # 4 viseme + 6 expression + 66 low-level values
    stream = parse_fap(f"2.1 {'n' * 2000} 25 1\n{mask}\n0 {values}\n", "t.fap")
    assert stream.values[0, 2] == pytest.approx(-123456.789012345)
