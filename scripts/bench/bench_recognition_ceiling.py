"""How far recognition without a transcript can go with PocketSphinx 5.1.1's acoustic model (docs/voice.md).

    .venv/bin/python -m scripts.bench.bench_recognition_ceiling [--quick] [--json OUT.json] [--only TEXT]

(--only: the rows whose name holds TEXT, e.g. "(b)", "(c)", "(e)" or "beams". Needs espeak-ng and
pocketsphinx==5.1.1; for (c), `apt-get install pocketsphinx-en-us pocketsphinx-testdata`; for (e), `apt-get install
sphinxtrain sphinxbase-utils pocketsphinx` (measurement tools, not dependencies: without them (e) says so and is
skipped). PyPI's older bindings that bundle a model (pocketsphinx 0.1.15, PyPocketsphinx 0.1.20, pocketsphinx2
0.1.17, pocketsphinx-fork 1.0.0) were compared by hand, docs/voice.md.)

On the benchmark's dev takes (scripts/bench/bench_lipsync.py: its first 12 sentences, voices en-us and en, 150
and 200 words a minute, clean; synthesised once, every row decodes the same samples), scored as the benchmark
scores them (frame agreement against the text path's visemes and the burst-timed truth, closure recall and
precision), rows that give the recogniser what no user has, so that what they reach bounds what any language
model could:

  shipped         the phone loop as shipped (`phone_alignment.phone_loop_steps`: the wheel's phone LM, lw 2,
                  pip 0.3, 5 ms frames, the bilabial cues)
  (d) phone set   no recognition: the text path's own phonemes at their own times, renamed to the model's
                  phones (`phone_alignment.cmu_of_phonemes`) and read as recognised phones are
                  (`data/phones_cmu.json`): what a perfect recogniser of this phone set would give
  (a) oracle LM   the same search with the wheel's phone LM replaced by a phone trigram of the takes' own true
                  phone sequences (the text path's espeak-ng phonemes mapped to the model's phones by
                  `phone_alignment.cmu_of_phonemes`, a pause as SIL; absolute discounting, `arpa`): "all" from
                  the 24 sequences of the 12 sentences in both voices, "own" from the take's sequence alone (the
                  tightest LM a take can have; with a discount of 0.5, and of 0.01, where the LM all but
                  dictates the sequence); at the shipped weight lw 2 and at PocketSphinx's default 6.5; the
                  tight one also with the search's beams widened from 1e-20 to 1e-80
  (b) oracle words the words path (`recognition_steps(words=True)`: recognised words, aligned as a transcript is,
                  the phone loop's closures over them) with the wheel's word LM replaced by a word trigram of the
                  12 true sentences ("all") or of the take's sentence alone ("own"): the alignment stays free to
                  place the words, so this brackets the problem between recognition and a given transcript
  (c) other models the phone loop with the wheel's phone LM and another PocketSphinx acoustic model: every
                  model directory found in Debian's pocketsphinx-en-us and pocketsphinx-testdata (installed with
                  apt-get) is listed with whether its files are the wheel's model byte for byte; each that is not,
                  and reads 16 kHz speech with phones the phone LM names, is decoded
  (e) adapted     the shipped phone loop with the wheel's model adapted to the speaker by MLLR (one global mean
                  transform, PocketSphinx's `mllr` option), estimated with Debian's sphinxtrain as CMUSphinx's
                  adaptation tutorial does (sphinx_fe, bw, mllr_solve; the mixture weights bw needs read from the
                  wheel's sendump): supervised (bw given each take's true phone sequence, `true_phones`: the best
                  case) or unsupervised (given the phone loop's own phones), on all takes of the voice or on the
                  take alone; a take bw cannot align is left out of the statistics (said)
"""

from __future__ import annotations

import argparse
import contextlib
import hashlib
import json
import math
import struct
import subprocess
import tempfile
import time
from collections import Counter
from pathlib import Path

import numpy as np

from addon.speech import espeak, phone_alignment, recording
from addon.speech.segments import TimedLabel
from scripts.bench import bench_lipsync as bench

MODEL_FILES = ("mdef", "means", "variances", "transition_matrices", "sendump", "mixture_weights")
OTHER_MODELS = (
    Path("/usr/share/pocketsphinx/model/en-us/en-us"),  # Debian's pocketsphinx-en-us
    Path("/usr/share/pocketsphinx/test/data/an4_ci_cont"),  # pocketsphinx-testdata: AN4, context-independent
    Path("/usr/share/pocketsphinx/test/data/tidigits/hmm"),  # pocketsphinx-testdata: digits, word-internal phones
)
DISCOUNT = 0.5  # absolute discounting of every n-gram count (the oracle LMs)
TIGHT_DISCOUNT = 0.01  # nearly all of a seen n-gram's count kept: the LM all but dictates the take's sequence
ORDER = 3  # the wheel's phone LM is a trigram (NGramModel.size())
LANGUAGE_WEIGHTS = (2.0, 6.5)  # the shipped phone loop's, and PocketSphinx's default
WIDE_BEAM = 1e-80  # the search's beams (shipped: 1e-20), so that a dictated sequence is not pruned away
OWN_SEQUENCE_ROWS = [  # (discount, lw, beams or None: the shipped ones) of the rows with the take's own sequence
    *((d, lw, None) for d in (DISCOUNT, TIGHT_DISCOUNT) for lw in LANGUAGE_WEIGHTS),
    *((TIGHT_DISCOUNT, lw, WIDE_BEAM) for lw in LANGUAGE_WEIGHTS),
]


def arpa(sentences: list[list[str]], vocabulary: set[str], order: int = ORDER, discount: float = DISCOUNT) -> str:
    """An ARPA back-off n-gram model of `sentences` (lists of tokens), absolute discounting; every word of
    `vocabulary` gets a unigram (the discounted mass spread evenly), so the search can still hypothesise it."""
    counts = [Counter() for _ in range(order + 1)]
    for tokens in sentences:
        padded = ["<s>", *tokens, "</s>"]
        for n in range(1, order + 1):
            for k in range(len(padded) - n + 1):
                gram = tuple(padded[k : k + n])
                if gram != ("<s>",):
                    counts[n][gram] += 1
    unigram_total = sum(counts[1].values())
    words = sorted(vocabulary | {g[0] for g in counts[1]} - {"<s>"})
    floor = discount * len(counts[1]) / unigram_total / max(len(words), 1)
    prob: dict[tuple[str, ...], float] = {}
    for w in words:
        prob[(w,)] = max(counts[1][(w,)] - discount, 0.0) / unigram_total + floor
    prob[("<s>",)] = 0.0
    histories: list[Counter] = [Counter() for _ in range(order + 1)]  # c(h), with how many words follow h
    followers: list[Counter] = [Counter() for _ in range(order + 1)]
    for n in range(2, order + 1):
        for gram, c in counts[n].items():
            histories[n][gram[:-1]] += c
            followers[n][gram[:-1]] += 1
        for gram, c in counts[n].items():
            prob[gram] = (c - discount) / histories[n][gram[:-1]]
    backoff: dict[tuple[str, ...], float] = {}
    for n in range(2, order + 1):
        seen: dict[tuple[str, ...], list[tuple[str, ...]]] = {}
        for gram in counts[n]:
            seen.setdefault(gram[:-1], []).append(gram)
        for history, grams in seen.items():
            left = discount * followers[n][history] / histories[n][history]
            lower = sum(_p(prob, backoff, g[1:]) for g in grams)
            backoff[history] = left / max(1.0 - lower, 1e-9)
    lines = ["\\data\\"]
    grams_of = [[]] + [[(w,) for w in ["<s>", *words]]] + [sorted(counts[n]) for n in range(2, order + 1)]
    lines += [f"ngram {n}={len(grams_of[n])}" for n in range(1, order + 1)]
    for n in range(1, order + 1):
        lines += ["", f"\\{n}-grams:"]
        for gram in grams_of[n]:
            p = prob[gram]
            text = f"{math.log10(p):.6f}" if p > 0 else "-99"
            bo = f"\t{math.log10(backoff[gram]):.6f}" if n < order and gram in backoff else ""
            lines.append(f"{text}\t{' '.join(gram)}{bo}")
    return "\n".join([*lines, "", "\\end\\", ""])


def _p(prob: dict, backoff: dict, gram: tuple[str, ...]) -> float:
    """P(gram[-1] | gram[:-1]) in the back-off model being built."""
    if gram in prob:
        return prob[gram]
    return backoff.get(gram[:-1], 1.0) * _p(prob, backoff, gram[1:])


def true_phones(speech: espeak.Speech, voice: str) -> list[str]:
    """The text path's phonemes of a take as the model's phones (upper case), a pause as SIL, with SIL at both
    ends (the recording's padding)."""
    labels = [p.label for p in speech.phonemes]
    rhotic = voice.split("+")[0] in phone_alignment.RHOTIC_VOWELS
    out = ["SIL"]
    for cmu in phone_alignment.cmu_of_phonemes(labels, rhotic):
        for phone in cmu or ("SIL",):
            if not (phone == "SIL" and out[-1] == "SIL"):
                out.append(phone.upper())
    return out if out[-1] == "SIL" else [*out, "SIL"]


def model_phones(model_dir: Path) -> set[str]:
    """The context-independent phones of a model's mdef: text (a base phone's row has no context, "- - -") or
    binary (after the format description, 4-byte aligned: ten int32 counts, the first n_ciphone, then the names)."""
    data = (model_dir / "mdef").read_bytes()
    marker = b"END FILE FORMAT DESCRIPTION\n"
    if marker not in data:
        rows = (line.split() for line in data.decode().splitlines())
        return {row[0] for row in rows if len(row) > 4 and row[1:4] == ["-", "-", "-"]}
    start = -(-(data.index(marker) + len(marker)) // 4) * 4
    count = int.from_bytes(data[start : start + 4], "little")
    return {name.decode() for name in data[start + 40 :].split(b"\0")[:count]}


class _Swapped:
    """`pocketsphinx` with some options of every `allphone` decoder, or every decoder, replaced."""

    def __init__(self, module, options: dict, phone_loop_only: bool = True):
        self.module, self.options, self.phone_loop_only = module, options, phone_loop_only

    def __getattr__(self, name):
        return getattr(self.module, name)

    def Decoder(self, **options):
        if "allphone" in options or not self.phone_loop_only:
            options = {**options, **self.options}
        return self.module.Decoder(**options)


@contextlib.contextmanager
def swapped(options: dict | None = None, word_lm: str | None = None):
    """Decoders made inside get `options` (phone loop only); the words path's LM is `word_lm`."""
    module = phone_alignment._pocketsphinx()
    saved = phone_alignment._pocketsphinx, phone_alignment.word_language_model
    task = "recognise" if options else "words"
    drop = lambda: [phone_alignment._idle_decoders.pop((task, a), None) for a in phone_alignment.ACCURACY]  # noqa: E731
    drop()
    if options:
        phone_alignment._pocketsphinx = lambda: _Swapped(module, options)
    if word_lm:
        phone_alignment.word_language_model = lambda: word_lm
    try:
        yield
    finally:
        phone_alignment._pocketsphinx, phone_alignment.word_language_model = saved
        drop()


def takes(quick: bool) -> list[dict]:
    sentences = bench.read_sentences()[: 3 if quick else bench.N_SENTENCES]
    out = []
    for text in sentences:
        for voice in bench.DEV["voices"]:
            for rate in bench.DEV["rates"]:
                speech = espeak.synthesize(text, voice, rate=rate)
                take = recording.from_samples(speech.samples, speech.sample_rate, f"{voice} {rate}")
                truths = (espeak.speech_segments(speech), bench.burst_truth(speech))
                out.append({"text": text, "voice": voice, "take": take, "truths": truths, "speech": speech})
    return out


def score_row(cases: list[dict], decode) -> dict:
    """Decode every take with `decode(case)` -> phones; the benchmark's scores against both truths."""
    results, cpu, duration = [], 0.0, 0.0
    for case in cases:
        began = time.process_time()
        found = phone_alignment.phone_segments(decode(case))
        cpu += time.process_time() - began
        duration += case["take"].duration
        results.append([bench.score(truth, found, case["take"].duration) for truth in case["truths"]])
    text_path, burst = (bench.summary_of([r[k] for r in results]) for k in (0, 1))
    return {
        "agreement": text_path["agreement"],
        "burst_agreement": burst["agreement"],
        "speech_agreement": text_path["speech_agreement"],
        "closure_recall": text_path["closure_recall"],
        "closure_precision": text_path["closure_precision"],
        "speed_cpu": duration / max(cpu, 1e-9),
    }


def as_cmu(case: dict) -> list:
    """The text path's own phonemes at their times (stops from their closure), each renamed to the model's phones
    (a phoneme of two phones split in equal halves): what a perfect recogniser of the model's phone set gives."""
    speech = case["speech"]
    labels = espeak.phoneme_labels(speech)
    rhotic = case["voice"].split("+")[0] in phone_alignment.RHOTIC_VOWELS
    out = [TimedLabel(0.0, labels[0].start, "sil")] if labels[0].start > 0 else []
    for label, cmu in zip(labels, phone_alignment.cmu_of_phonemes([x.label for x in labels], rhotic), strict=True):
        names = cmu or ("sil",)
        step = (label.end - label.start) / len(names)
        out += [TimedLabel(label.start + k * step, label.start + (k + 1) * step, n) for k, n in enumerate(names)]
    return out


def phone_loop(case: dict) -> list:
    return phone_alignment.run(phone_alignment.phone_loop_steps(case["take"]))


def words_path(case: dict) -> list:
    return phone_alignment.phones_from_recording(case["take"], None, words=True)


def md5(path: Path) -> str:
    return hashlib.md5(path.read_bytes()).hexdigest()


# ----------------------------------------------------------------------------- (e) speaker adaptation (MLLR)

SPHINXTRAIN = Path("/usr/lib/sphinxtrain")  # Debian's sphinxtrain: bw, mllr_solve
SPHINX_FE = Path("/usr/bin/sphinx_fe")  # Debian's sphinxbase-utils
MDEF_CONVERT = Path("/usr/bin/pocketsphinx_mdef_convert")  # Debian's pocketsphinx
BW_BEAMS = ("1e-200", "1e-300")  # bw's alpha and beta beams, tried in turn: its default 1e-100 leaves more takes
# unaligned ("final state not reached"), 1e-300 aborts on some (an assertion) but aligns others
LOG_BASE_SHIFT = 1024 * math.log(1.0001)  # a sendump byte v is P = 1.0001 ** -(v << 10) (logmath, SENSCR_SHIFT)


def adaptation_tools() -> list[Path]:
    """The programs row (e) needs that are missing (`apt-get install sphinxtrain sphinxbase-utils pocketsphinx`)."""
    tools = (SPHINXTRAIN / "bw", SPHINXTRAIN / "mllr_solve", SPHINX_FE, MDEF_CONVERT)
    return [t for t in tools if not t.is_file()]


def mixture_weights(sendump: Path) -> bytes:
    """The model's mixture weights as sphinxtrain reads them (s3 float32, senone x stream x density) from the
    wheel's quantised `sendump` (which bw cannot read): after its header strings, #codewords and #pdfs (int32),
    then per stream and codeword one byte per senone (cluster_count 0)."""
    data = sendump.read_bytes()
    offset = 0
    while length := int.from_bytes(data[offset : offset + 4], "little"):
        offset += 4 + length
    densities, senones = struct.unpack_from("<2i", data, offset + 4)
    quantised = np.frombuffer(data, np.uint8, offset=offset + 12).reshape(-1, densities, senones)
    weights = np.exp(-quantised.astype(np.float64) * LOG_BASE_SHIFT).transpose(2, 0, 1)
    weights /= weights.sum(axis=2, keepdims=True)  # the quantisation's rounding
    header = b"s3\nversion 1.0\n" + b" " * 6 + b"endhdr\n"  # 28 bytes: the data 4-byte aligned
    dims = struct.pack("<I4i", 0x11223344, *weights.shape, weights.size)
    return header + dims + weights.astype("<f4").tobytes()


def mllr_transform(cases: list[dict], sequences: list[list[str]], folder: Path, wheel: Path) -> Path | None:
    """MLLR of the wheel's model on `cases` (CMUSphinx's adaptation steps): features with the model's
    feat.params (sphinx_fe), Baum-Welch statistics (bw) of each take against its phone sequence in `sequences`
    (the model's phones, SIL for a pause; a dictionary whose words are the phones, a pause as the filler <sil>),
    one global mean transform from the statistics of the takes bw could align (mllr_solve). Returns the
    mllr_matrix path, or None when bw aligned none of them."""
    model = folder / "model"
    model.mkdir(parents=True)
    for name in ("means", "variances", "transition_matrices", "feat.params", "noisedict"):
        (model / name).symlink_to(wheel / name)
    (model / "mixture_weights").write_bytes(mixture_weights(wheel / "sendump"))
    run = lambda *command: subprocess.run([str(c) for c in command], capture_output=True)  # noqa: E731
    run(MDEF_CONVERT, "-text", wheel / "mdef", model / "mdef.txt").check_returncode()
    phones = model_phones(wheel) - {"SIL"}
    (folder / "dictionary").write_text("".join(f"{p.lower()} {p}\n" for p in sorted(phones)))
    for k, case in enumerate(cases):
        (np.clip(case["take"].samples, -1.0, 1.0) * 32767).astype("<i2").tofile(folder / f"take{k}.raw")
    (folder / "ids").write_text("".join(f"take{k}\n" for k in range(len(cases))))
    fe = ("-argfile", wheel / "feat.params", "-samprate", recording.RATE, "-c", folder / "ids", "-di", folder)
    run(SPHINX_FE, *fe, "-do", folder, "-ei", "raw", "-eo", "mfc", "-raw", "yes", "-input_endian", "little")
    bw = (SPHINXTRAIN / "bw", "-hmmdir", model, "-moddeffn", model / "mdef.txt", "-ts2cbfn", ".ptm.")
    bw += ("-feat", "1s_c_d_dd", "-svspec", "0-12/13-25/26-38", "-cmn", "batch", "-agc", "none", "-varnorm", "no")
    bw += ("-dictfn", folder / "dictionary", "-fdictfn", wheel / "noisedict", "-cepdir", folder, "-cepext", "mfc")
    aligned = []
    for k, sequence in enumerate(sequences):  # one take at a time: bw aborts on some, and drops others
        take = folder / f"stats{k}"
        take.mkdir()
        (take / "ids").write_text(f"take{k}\n")
        words = ["<sil>" if p == "SIL" else p.lower() for p in sequence]
        (take / "transcription").write_text(f"<s> {' '.join(words)} </s> (take{k})\n")
        for beam in BW_BEAMS:
            files = ("-ctlfn", take / "ids", "-lsnfn", take / "transcription", "-accumdir", take)
            done = run(*bw, *files, "-abeam", beam, "-bbeam", beam)
            if done.returncode == 0 and b" ignored" not in done.stderr:
                aligned.append(take)
                break
    if len(aligned) < len(cases):
        print(f"  bw could not align {len(cases) - len(aligned)} of {len(cases)} takes (left out)", flush=True)
    if not aligned:
        return None
    matrix = folder / "mllr_matrix"
    solve = (SPHINXTRAIN / "mllr_solve", "-meanfn", wheel / "means", "-varfn", wheel / "variances")
    run(*solve, "-outmllrfn", matrix, "-accumdir", ",".join(map(str, aligned))).check_returncode()
    return matrix


def spoken(phones: list[str]) -> list[str]:
    """A phone sequence as bw's transcript takes it: the model's phones, one SIL per pause, none at the ends."""
    out: list[str] = []
    for phone in phones:
        if not (phone == "SIL" and (not out or out[-1] == "SIL")):
            out.append(phone)
    return out[:-1] if out and out[-1] == "SIL" else out


def adapted_rows(cases: list[dict], row, folder: Path, wheel: Path) -> None:
    """Rows (e): the shipped phone loop with the model adapted by MLLR, on the voice's takes or the take alone,
    against the true phones (supervised: the best case) or the phone loop's own phones (unsupervised)."""
    missing = adaptation_tools()
    if missing:
        names = " ".join(str(m) for m in missing)
        print(f"(e) skipped: {names} missing (apt-get install sphinxtrain sphinxbase-utils pocketsphinx)")
        return
    phones = model_phones(wheel)
    truth = {id(c): spoken(true_phones(c["speech"], c["voice"])) for c in cases}
    for supervised in (True, False):
        if not supervised:
            found = {id(c): [p.label.upper() for p in phone_loop(c)] for c in cases}
            hypothesis = {k: spoken([p for p in v if p in phones]) for k, v in found.items()}
        sequences = truth if supervised else hypothesis
        for scope in ("voice", "take"):
            transforms: dict = {}

            def adapted(case: dict, scope: str = scope, sequences: dict = sequences, transforms: dict = transforms):
                key = case["voice"] if scope == "voice" else id(case)
                if key not in transforms:
                    group = [c for c in cases if (c["voice"] if scope == "voice" else id(c)) == key]
                    where = Path(tempfile.mkdtemp(dir=folder))
                    transforms[key] = mllr_transform(group, [sequences[id(c)] for c in group], where, wheel)
                if transforms[key] is None:  # the take decoded unadapted (said above)
                    return phone_loop(case)
                with swapped({"mllr": str(transforms[key])}):
                    return phone_loop(case)

            kind = "supervised (the true phones)" if supervised else "unsupervised (the phone loop's own phones)"
            group = "the voice's takes" if scope == "voice" else "the take alone"
            row(f"(e) phone loop, model adapted by MLLR, {kind}, on {group}", adapted)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--quick", action="store_true", help="3 sentences (a smoke run)")
    parser.add_argument("--json", type=Path, help="write the figures here")
    parser.add_argument("--only", help="only the rows whose name holds this text")
    args = parser.parse_args(argv)
    cases = takes(args.quick)
    wheel = Path(phone_alignment._pocketsphinx().get_model_path()) / "en-us"
    wheel_phones = model_phones(wheel / "en-us")
    report: dict[str, dict] = {}

    def row(name: str, decode, options: dict | None = None, word_lm: str | None = None) -> None:
        if args.only and args.only not in name:
            return
        with swapped(options, word_lm) if options or word_lm else contextlib.nullcontext():
            figures = report[name] = score_row(cases, decode)
        print(
            f"{name}: agreement {figures['agreement']:.1%} (burst truth {figures['burst_agreement']:.1%}, speech "
            f"{figures['speech_agreement']:.1%}), closure recall {figures['closure_recall']:.1%}, precision "
            f"{figures['closure_precision']:.1%}, {figures['speed_cpu']:.1f}x real time (CPU)",
            flush=True,
        )

    row("(d) the true phones in the model's phone set, at the true times (no recognition)", as_cmu)
    row("shipped phone loop", phone_loop)
    with tempfile.TemporaryDirectory() as folder:
        sequences = {(c["text"], c["voice"]): true_phones(c["speech"], c["voice"]) for c in cases}
        pooled = Path(folder, "all-phones.lm")
        pooled.write_text(arpa(list(sequences.values()), wheel_phones))
        for lw in LANGUAGE_WEIGHTS:
            name = f"(a) oracle phone LM, all 24 sequences, D {DISCOUNT:g}, lw {lw:g}"
            row(name, phone_loop, {"allphone": str(pooled), "lw": lw})
        for discount, lw, beam in OWN_SEQUENCE_ROWS:

            def own_phones(case: dict, lw: float = lw, discount: float = discount, beam: float | None = beam) -> list:
                path = Path(folder, "own-phones.lm")
                path.write_text(arpa([sequences[case["text"], case["voice"]]], wheel_phones, discount=discount))
                beams = {"beam": beam, "wbeam": beam, "pbeam": beam} if beam else {}
                with swapped({"allphone": str(path), "lw": lw, **beams}):
                    return phone_loop(case)

            wide = f", beams {beam:g}" if beam else ""
            row(f"(a) oracle phone LM, the take's own sequence, D {discount:g}, lw {lw:g}{wide}", own_phones)
        texts = sorted({c["text"] for c in cases})
        vocabulary = {w for t in texts for w in phone_alignment.transcript_words(t)}
        words_lm = Path(folder, "all-words.lm")
        words_lm.write_text(arpa([phone_alignment.transcript_words(t) for t in texts], vocabulary))
        row("(b) words path, word LM of the 12 true sentences", words_path, word_lm=str(words_lm))

        def own_words(case: dict) -> list:
            path = Path(folder, "own-words.lm")
            words = phone_alignment.transcript_words(case["text"])
            path.write_text(arpa([words], set(words)))
            with swapped(word_lm=str(path)):
                return words_path(case)

        row("(b) words path, word LM of the take's own sentence", own_words)
        if not args.only or "(e)" in args.only:
            adapted_rows(cases, row, Path(folder), wheel / "en-us")
    if args.only and "(c)" not in args.only:
        return _write(report, args.json)
    print("(c) other PocketSphinx acoustic models (Debian: pocketsphinx-en-us, pocketsphinx-testdata):")
    for model in OTHER_MODELS:
        if not (model / "mdef").is_file():
            print(f"  {model}: not installed")
            continue
        same = [f for f in MODEL_FILES if (model / f).is_file() and (wheel / "en-us" / f).is_file()]
        identical = bool(same) and all(md5(model / f) == md5(wheel / "en-us" / f) for f in same)
        phones = model_phones(model)
        params = (model / "feat.params").read_text().split()
        upper = float(params[params.index("-upperf") + 1]) if "-upperf" in params else 6800.0
        note = f"{len(phones)} phones, upper frequency {upper:g} Hz"
        if identical:
            print(f"  {model}: the wheel's acoustic model byte for byte ({', '.join(same)}); {note}")
            continue
        if upper < 6000 or not phones & wheel_phones or len(phones & wheel_phones) < len(phones) / 2:
            print(f"  {model}: not a 16 kHz model of the phone LM's phones ({note}: {' '.join(sorted(phones))})")
            continue
        print(f"  {model}: {note}; lacks {' '.join(sorted(wheel_phones - phones)) or 'none'} of the phone LM's")
        with swapped({"hmm": str(model)}):
            row(f"(c) phone loop with {model.parent.name}/{model.name}", phone_loop, {"hmm": str(model)})
    return _write(report, args.json)


def _write(report: dict, path: Path | None) -> int:
    if path:
        path.write_text(json.dumps(report, indent=1))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
