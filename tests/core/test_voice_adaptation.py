"""MLLR adaptation of the acoustic model to a take (addon/speech/adaptation.py): hand-worked statistics, the
front end's features, the files PocketSphinx and sphinxtrain read and write."""

from __future__ import annotations

import importlib.util
import os

import numpy as np
import pytest

from addon.speech import adaptation
from addon.speech.adaptation import Model
from tests.markers import needs_espeak

needs_pocketsphinx = pytest.mark.skipif(importlib.util.find_spec("pocketsphinx") is None, reason="no pocketsphinx")


def _model(means: np.ndarray, variances: np.ndarray) -> tuple[Model, np.ndarray, np.ndarray]:
    """A model with one senone per Gaussian whose weight lies all on it (so a frame's posterior is that
    Gaussian's, exactly), and for each senone its codebook."""
    n_cb, n_feat, n_density, _ = means.shape
    senones = n_cb * n_density
    weights = np.zeros((senones, n_feat, n_density))
    for s in range(senones):
        weights[s, :, s % n_density] = 1.0
    model = Model(means, variances, weights, tuple(f"P{k}" for k in range(n_cb)), {})
    return model, np.arange(senones), np.arange(senones) // n_density


def test_one_dimension_by_hand():
    """Means 0 and 1 (variance 1), observed at 3 and 5: o = 2 mu + 3, W = [[2, 3]]. By hand: G = sum xi xi^T
    = [[0, 0], [0, 1]] + [[1, 1], [1, 1]] = [[1, 1], [1, 2]], k = 3 [0, 1] + 5 [1, 1] = [5, 8]; G w = k gives
    w = [2, 3]."""
    means = np.array([0.0, 1.0]).reshape(1, 1, 2, 1)
    model, senones, codebooks = _model(means, np.ones_like(means))
    feats = np.array([3.0, 5.0]).reshape(2, 1, 1)
    g, k = adaptation.statistics(feats, senones, codebooks, model)
    np.testing.assert_allclose(g[0, 0], [[1, 1], [1, 2]])
    np.testing.assert_allclose(k[0, 0], [5, 8])
    np.testing.assert_allclose(adaptation.solve(g, k), [[[2.0, 3.0]]])


def test_a_known_affine_transform_comes_back():
    """Three codebooks of five Gaussians in two streams of three dimensions, each stream's means moved by its
    own A mu + b: frames at the moved means (each frame in its Gaussian's senone) give A and b back, however
    the variances differ (each row is weighted by its own variances)."""
    rng = np.random.default_rng(3)
    means = rng.normal(size=(3, 2, 5, 3))
    variances = rng.uniform(0.2, 2.0, size=means.shape)
    model, senones, codebooks = _model(means, variances)
    a = np.eye(3)[None] + 0.3 * rng.normal(size=(2, 3, 3))
    b = rng.normal(size=(2, 3))
    truth = np.concatenate([a, b[..., None]], axis=-1)
    moved = adaptation.transformed_means(means, truth)  # (codebook, stream, density, dim)
    np.testing.assert_allclose(moved[1, 0, 2], a[0] @ means[1, 0, 2] + b[0])
    frames = np.repeat(np.arange(len(senones)), 4)  # four frames per senone: MIN_FRAMES is met
    assert len(frames) >= adaptation.MIN_FRAMES
    feats = moved.transpose(0, 2, 1, 3).reshape(-1, 2, 3)[frames]  # senone s = codebook * 5 + density
    found = adaptation.estimate([(feats, senones[frames], codebooks[frames])], model)
    np.testing.assert_allclose(found.means, truth, atol=1e-9)
    # every frame at its moved mean: no spread left, the variances' scales at their floor
    np.testing.assert_allclose(found.variances, adaptation.MIN_VARIANCE_SCALE)
    # the statistics of two pieces add: the take cut in two gives the same transform
    half = len(frames) // 2
    pieces = [(feats[:half], senones[frames][:half], codebooks[frames][:half])]
    pieces.append((feats[half:], senones[frames][half:], codebooks[frames][half:]))
    np.testing.assert_allclose(adaptation.estimate(pieces, model).means, truth, atol=1e-9)


def test_variance_scale_by_hand():
    """Means 0 and 1 with variances 1 and 4; frames 2 and 4 in the first Gaussian, 4 and 6 in the second. By
    hand: G = 2 [[0, 0], [0, 1]] + 2 / 4 [[1, 1], [1, 1]] = [[0.5, 0.5], [0.5, 2.5]], k = 6 [0, 1] + 10 / 4 [1, 1]
    = [2.5, 8.5], so w = [2, 3] (the frames' means 3 and 5 exactly); the residuals (+-1 around 3 and around 5)
    over their variances sum to 1 + 1 + 1 / 4 + 1 / 4 = 2.5 over 4 frames: h = 0.625."""
    means = np.array([0.0, 1.0]).reshape(1, 1, 2, 1)
    variances = np.array([1.0, 4.0]).reshape(1, 1, 2, 1)
    model, senones, codebooks = _model(means, variances)
    feats = np.array([2.0, 4.0, 4.0, 6.0]).reshape(4, 1, 1)
    at = np.array([0, 0, 1, 1])
    counts = adaptation.counts(feats, senones[at], codebooks[at], model)
    np.testing.assert_allclose(counts.occupancy[0, 0], [2, 2])
    g, k = adaptation.mean_statistics(counts, model)
    np.testing.assert_allclose(g[0, 0], [[0.5, 0.5], [0.5, 2.5]])
    np.testing.assert_allclose(k[0, 0], [2.5, 8.5])
    w = adaptation.solve(g, k)
    np.testing.assert_allclose(w, [[[2.0, 3.0]]])
    np.testing.assert_allclose(adaptation.variance_scales(counts, model, w), [[0.625]])


def test_too_few_frames_give_no_transform():
    means = np.zeros((1, 1, 2, 1))
    model, senones, codebooks = _model(means, np.ones_like(means))
    feats = np.zeros((adaptation.MIN_FRAMES - 1, 1, 1))
    assert adaptation.estimate([(feats, np.zeros(len(feats), int), np.zeros(len(feats), int))], model) is None


def test_mllr_file_round_trip_and_layout(tmp_path):
    """sphinxtrain's layout, as PocketSphinx's ps_mllr_read reads it: classes, streams, then per stream its
    length, A row by row, b, the variances' scales."""
    w = np.array([[[1.5, -0.25, 3.0], [0.125, 2.0, -1.0]]])
    path = tmp_path / "mllr_matrix"
    adaptation.write_mllr(path, adaptation.Transform(w, np.array([[0.5, 2.0]])))
    assert path.read_text().split("\n") == ["1", "1", "2", "1.5 -0.25", "0.125 2", "3 -1", "0.5 2", ""]
    back = adaptation.read_mllr(path)
    np.testing.assert_array_equal(back.means, w)
    np.testing.assert_array_equal(back.variances, [[0.5, 2.0]])
    rng = np.random.default_rng(0)
    many = adaptation.Transform(rng.normal(size=(3, 13, 14)), rng.uniform(0.5, 2.0, size=(3, 13)))
    adaptation.write_mllr(path, many)
    back = adaptation.read_mllr(path)
    np.testing.assert_allclose(back.means, many.means, rtol=1e-8)
    np.testing.assert_allclose(back.variances, many.variances, rtol=1e-8)


def test_gaussian_file_round_trip(tmp_path):
    values = np.arange(2 * 3 * 4 * 5, dtype=np.float64).reshape(2, 3, 4, 5) / 8
    adaptation.write_gaussians(tmp_path / "means", values)
    np.testing.assert_array_equal(adaptation.read_gaussians(tmp_path / "means"), values)
    (tmp_path / "bad").write_bytes(b"not a model")
    with pytest.raises(adaptation.AdaptationError, match="no s3 header"):
        adaptation.read_gaussians(tmp_path / "bad")


def test_features_are_sphinx_deltas():
    """1s_c_d_dd on a ramp c[t] = t: the mean removed; deltas c[t+2] - c[t-2] = 4 inside, and at the ends with
    the first and last frames repeated (t = 0: c[2] - c[0] = 2); second deltas (c[t+3] - c[t-1]) - (c[t+1] -
    c[t-3]) = 0 inside."""
    cep = np.repeat(np.arange(10.0)[:, None], 13, axis=1)
    feats = adaptation.features(cep)
    assert feats.shape == (10, 3, 13)
    np.testing.assert_allclose(feats[:, 0, 0], np.arange(10.0) - 4.5)
    np.testing.assert_allclose(feats[:, 1, 0], [2, 3, 4, 4, 4, 4, 4, 4, 3, 2])
    np.testing.assert_allclose(feats[3:7, 2, 0], 0.0)
    # t = 0: (c[3] - c[0]) - (c[1] - c[0]) = 3 - 1 = 2
    assert feats[0, 2, 0] == pytest.approx(2.0)


def test_mel_filters_have_unit_area_and_rounded_edges():
    params = {"nfilt": "25", "lowerf": "130", "upperf": "6800"}
    filters = adaptation.mel_filters(params)
    assert filters.shape == (25, adaptation.FFT_SIZE // 2 + 1)
    step = adaptation.RATE / adaptation.FFT_SIZE
    # a triangle of height 2 / (right - left) over bins `step` apart has the area 1 (its sum times step)
    np.testing.assert_allclose(filters.sum(axis=1) * step, 1.0, rtol=1e-9)
    first = np.flatnonzero(filters[0])
    assert first[0] * step >= 125.0 - step / 2  # 130 Hz rounded to the bin at 125 Hz; its weight 0 there


@needs_pocketsphinx
def test_the_wheels_model_reads():
    import pocketsphinx

    model = adaptation.read_model(os.path.join(pocketsphinx.get_model_path(), "en-us", "en-us"))
    assert model.means.shape == (42, 3, 128, 13) == model.variances.shape
    assert model.weights.shape[1:] == (3, 128)
    np.testing.assert_allclose(model.weights.sum(axis=2), 1.0)
    assert "SIL" in model.phones and "M" in model.phones and len(model.phones) == 42
    assert model.variances.min() >= adaptation.VARIANCE_FLOOR


@needs_espeak
@needs_pocketsphinx
def test_an_identity_transform_aligns_as_the_unadapted_model(monkeypatch):
    """The second alignment runs on its own decoder (the take's words as its dictionary, the transform loaded
    with the model): with the identity transform it gives the first alignment's phones exactly; with the
    transform estimated from the take, the same labels in the same order."""
    from addon.speech import espeak, phone_alignment, recording

    text = "Maybe Bob should show you the whole map."
    speech = espeak.synthesize(text, "en-us", rate=175)
    take = recording.from_samples(speech.samples, speech.sample_rate, "test")
    plain = phone_alignment.run(phone_alignment.alignment_steps(take, text, adapt=False))
    adapted = phone_alignment.run(phone_alignment.alignment_steps(take, text))
    assert [p.label for p in adapted] == [p.label for p in plain]
    assert [(p.start, p.end) for p in adapted] != [(p.start, p.end) for p in plain]  # the transform moved some

    made = []
    new_decoder = phone_alignment._new_decoder
    monkeypatch.setattr(phone_alignment, "_new_decoder", lambda *a, **k: made.append(k) or new_decoder(*a, **k))
    identity = adaptation.Transform(
        np.concatenate([np.eye(13), np.zeros((13, 1))], axis=1)[None].repeat(3, axis=0), np.ones((3, 13))
    )
    monkeypatch.setattr(adaptation, "estimate", lambda pieces, model: identity)
    assert phone_alignment.run(phone_alignment.alignment_steps(take, text)) == plain
    assert [sorted(k) for k in made] == [["dict", "mllr"]]


@needs_espeak
@needs_pocketsphinx
def test_recognition_adapted_with_the_identity_recognises_as_before(monkeypatch):
    """Without a transcript, on request: the phone loop's phones aligned give the states, the phone loop runs
    again on the adapted model (its own decoder, `mllr` and a one-word dictionary): with the identity transform,
    the same phones as the phone loop alone."""
    from addon.speech import espeak, phone_alignment, recording

    speech = espeak.synthesize("Maybe Bob should show you the whole map.", "en-us", rate=175)
    take = recording.from_samples(speech.samples, speech.sample_rate, "test")
    plain = phone_alignment.run(phone_alignment.recognition_steps(take))
    made = []
    new_decoder = phone_alignment._new_decoder
    monkeypatch.setattr(phone_alignment, "_new_decoder", lambda *a, **k: made.append(a[0]) or new_decoder(*a, **k))
    identity = adaptation.Transform(
        np.concatenate([np.eye(13), np.zeros((13, 1))], axis=1)[None].repeat(3, axis=0), np.ones((3, 13))
    )
    monkeypatch.setattr(adaptation, "estimate", lambda pieces, model: identity)
    assert phone_alignment.run(phone_alignment.recognition_steps(take, adapt=True)) == plain
    assert made[-1] == "recognise"


@needs_espeak
@needs_pocketsphinx
def test_pieces_are_decoded_from_their_own_cepstral_mean(monkeypatch):
    """Alignment hands the decoder the mean of the piece's own cepstra (batch normalisation, as the model's
    feat.params ask), not PocketSphinx's live estimate, which for a take of a few seconds stays near the model's
    initial mean (c0 about 40; this take's own is above 50)."""
    from addon.speech import espeak, phone_alignment, recording

    text = "Blame the ambitious mayor for the bumpy roads."
    speech = espeak.synthesize(text, "en-029", rate=240)
    take = recording.from_samples(speech.samples, speech.sample_rate, "test")
    pcm = np.frombuffer(phone_alignment._pcm(take.samples), "<i2")
    params = phone_alignment._model().params
    handed: list[np.ndarray] = []
    original = phone_alignment._decode_pass

    def spy(decoder, pcm, mean, *rest):
        handed.append(np.array(mean.split(","), float))
        return original(decoder, pcm, mean, *rest)

    monkeypatch.setattr(phone_alignment, "_decode_pass", spy)
    phone_alignment.phones_from_recording(take, text, adapt=False)
    own = adaptation.cepstra(pcm, params).mean(axis=0)
    assert own[0] > 50.0
    np.testing.assert_allclose(handed[-1], own, rtol=1e-5, atol=1e-4)


@needs_pocketsphinx
def test_an_adapted_decoders_dictionary_holds_only_what_its_search_uses(monkeypatch):
    """The adapted alignment decoder's dictionary is the take's words alone: alignment takes each piece's mean
    from its own cepstra and never searches the mean word (the same phones with it as without, measured on 186
    dev-side takes). Recognition measures the mean under a one-word grammar, so its dictionary keeps that word."""
    from addon.speech import phone_alignment

    read: list[list[str]] = []
    new_decoder = phone_alignment._new_decoder

    def spy(task, accuracy, **files):
        with open(files["dict"], encoding="utf-8") as lines:
            read.append([line.split()[0] for line in lines])
        return new_decoder(task, accuracy, **files)

    monkeypatch.setattr(phone_alignment, "_new_decoder", spy)
    identity = adaptation.Transform(
        np.concatenate([np.eye(13), np.zeros((13, 1))], axis=1)[None].repeat(3, axis=0), np.ones((3, 13))
    )
    words = {"bob__b_aa_b": ("B", "AA", "B"), "map__m_ae_p": ("M", "AE", "P")}
    decoder = phone_alignment._adapted_decoder("align", "STANDARD", identity, words)
    assert read[-1] == list(words)
    assert decoder.lookup_word(phone_alignment._MEAN_WORD) is None
    decoder = phone_alignment._adapted_decoder("recognise", "STANDARD", identity, {})
    assert read[-1] == [phone_alignment._MEAN_WORD]
    assert decoder.lookup_word(phone_alignment._MEAN_WORD) == "AH"
