"""The recognition ceiling bench's oracle language models and model reading (scripts/bench/
bench_recognition_ceiling.py), worked by hand and read back by PocketSphinx."""

import importlib.util
from pathlib import Path

import pytest

from scripts.bench.bench_recognition_ceiling import arpa, model_phones

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
