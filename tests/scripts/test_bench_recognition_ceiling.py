"""The recognition ceiling bench's oracle language models and model reading (scripts/bench/
bench_recognition_ceiling.py), worked by hand and read back by PocketSphinx."""

import importlib.util
import math
import struct
from pathlib import Path

import numpy as np
import pytest

from scripts.bench.bench_recognition_ceiling import arpa, mixture_weights, model_phones, spoken

needs_pocketsphinx = pytest.mark.skipif(importlib.util.find_spec("pocketsphinx") is None, reason="no pocketsphinx")


@needs_pocketsphinx
def test_the_oracle_lm_is_absolute_discounting_with_back_off_as_pocketsphinx_reads_it(tmp_path):
    import pocketsphinx

    path = tmp_path / "oracle.lm"
    path.write_text(arpa([["a", "b"], ["a", "c"]], {"a", "b", "c", "d"}, discount=0.5))
    model = pocketsphinx.NGramModel(pocketsphinx.Config(), pocketsphinx.LogMath(), str(path))
    log = pocketsphinx.LogMath()

    def p(*words):  # P(last | the ones before); PocketSphinx takes the words newest first
        return log.exp(model.prob(list(reversed(words))))

    # unigrams: counts a 2, b 1, c 1, </s> 2 of 6, less 0.5 each; the 2.0 / 6 taken spread over the 5 words
    floor = 0.5 * 4 / 6 / 5
    assert p("a") == pytest.approx(1.5 / 6 + floor, rel=1e-3)
    assert p("d") == pytest.approx(floor, rel=1e-3)  # never seen, still possible
    assert p("a", "b") == pytest.approx(0.5 / 2, rel=1e-3)  # (1 - 0.5) / c(a)
    assert p("a", "b", "</s>") == pytest.approx(0.5, rel=1e-3)
    # unseen after a: its back-off weight (the 0.5 taken, over what b and c do not hold of the unigrams)
    alpha = 0.5 / (1.0 - (0.5 / 6 + floor) * 2)
    assert p("a", "d") == pytest.approx(alpha * floor, rel=1e-3)
    assert sum(p("a", w) for w in ("a", "b", "c", "d", "</s>")) == pytest.approx(1.0, rel=1e-3)


@needs_pocketsphinx
def test_the_phones_of_a_binary_and_a_text_mdef(tmp_path):
    import pocketsphinx

    wheel = Path(pocketsphinx.get_model_path()) / "en-us" / "en-us"
    phones = model_phones(wheel)
    assert len(phones) == 42 and {"SIL", "AA", "ZH", "+NSN+"} <= phones
    (tmp_path / "mdef").write_text(
        "0.3\n2 n_base\n0 n_tri\n#\n#base lft rt p attrib tmat ... state id's ...\n"
        "AA - - - n/a 0 0 1 2 N\nSIL - - - filler 1 3 4 5 N\n"
    )
    assert model_phones(tmp_path) == {"AA", "SIL"}


def _s3(data: bytes) -> np.ndarray:
    header, body = data.split(b"endhdr\n", 1)
    assert len(header) + 7 == 28  # the floats 4-byte aligned
    magic, *shape, total = struct.unpack_from("<I4i", body)
    assert magic == 0x11223344 and total == math.prod(shape) and len(body) == 20 + 4 * total
    return np.frombuffer(body, "<f4", offset=20).reshape(shape)


def test_mixture_weights_from_a_sendump_by_hand(tmp_path):
    # header strings, their end, 2 codewords, 3 senones; stream 0: codeword 0's byte per senone, then codeword 1's
    title = b"cluster_count 0\0"
    codewords = bytes([0, 7, 0]) + bytes([7, 0, 255])
    (tmp_path / "sendump").write_bytes(struct.pack("<i", len(title)) + title + struct.pack("<3i", 0, 2, 3) + codewords)
    weights = _s3(mixture_weights(tmp_path / "sendump"))
    low = 1.0001 ** -(7 << 10)  # a byte v is P = 1.0001 ** -(v << 10) before normalising
    tiny = 1.0001 ** -(255 << 10)
    expected = [
        [[1 / (1 + low), low / (1 + low)]],
        [[low / (1 + low), 1 / (1 + low)]],
        [[1 / (1 + tiny), tiny / (1 + tiny)]],
    ]
    assert weights == pytest.approx(np.array(expected), rel=1e-6)


@needs_pocketsphinx
def test_mixture_weights_of_the_wheels_model():
    import pocketsphinx

    weights = _s3(mixture_weights(Path(pocketsphinx.get_model_path()) / "en-us" / "en-us" / "sendump"))
    assert weights.shape == (5126, 3, 128)  # senones (mdef's n_tied_state), streams, densities
    assert weights.sum(axis=2) == pytest.approx(np.ones((5126, 3)), abs=1e-5)


def test_a_transcript_for_bw_has_one_sil_per_pause_and_none_at_the_ends():
    assert spoken(["SIL", "M", "AY", "SIL", "SIL", "B", "SIL"]) == ["M", "AY", "SIL", "B"]
    assert spoken(["SIL"]) == []
