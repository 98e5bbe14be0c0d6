"""Speaker adaptation of PocketSphinx's acoustic model to one take: an MLLR mean transform and variance scales
(no bpy).

With a transcript the aligner knows what is said, so the take's own state alignment (pass 1) is supervision
enough to move the model's Gaussians towards this voice: one affine transform of every mean, per feature stream,
estimated by maximum likelihood (Leggetter & Woodland 1995, "Maximum likelihood linear regression for speaker
adaptation of continuous density hidden Markov models", Computer Speech and Language 9; diagonal covariances,
their row-by-row closed form), and given it, one scale of every variance per stream and dimension (Gales &
Woodland 1996, "Mean and variance adaptation within the MLLR framework", Computer Speech and Language 10, with
a diagonal H: the variance transform sphinxtrain's file carries and PocketSphinx applies, `var *= h`), written
as sphinxtrain's `mllr_matrix` text file, which PocketSphinx applies when it loads the model
(`Decoder(mllr=PATH)`); the take is then aligned again (pass 2, `phone_alignment`).

Reading chosen where the paper leaves it open: the extended mean is [mu, 1] (sphinxtrain's order, so the
transform's last column is the bias b and W = [A b]); one global class per stream, the only one PocketSphinx's
loader applies (`gauden_mllr_transform` uses class 0); the frame-to-state assignment is the alignment's
(Viterbi), the assignment to the Gaussians within a state's mixture is soft (their posteriors, from the model
as it is); the means' transform and the variances' scales come from the same posteriors (one EM step: the
scales given the new means), the scales per dimension of each stream, not a full matrix (PocketSphinx's file
has one scale per dimension).

The statistics need the take's features as the decoder saw them: `cepstra` re-implements PocketSphinx 5.1.1's
front end in floating point as the model's `feat.params` configure it (pre-emphasis 0.97, 410-sample Hamming
window every 160 samples, 512-point power spectrum, `nfilt` triangular mel filters of unit area with edges
rounded to the FFT's bins between `lowerf` and `upperf`, its spectral noise removal (`remove_noise`), natural
log with a floor of 1e-4, the orthonormal DCT-II, sinusoidal lifter), and `features` its `1s_c_d_dd` features
(cepstral mean removed over the piece; deltas c[t+2] - c[t-2]; second deltas (c[t+3] - c[t-1]) - (c[t+1] -
c[t-3]); the ends padded by repeating the first and last frames). The model files are read in sphinx's binary
formats: Gaussian parameters (`means`, `variances`: s3 header, byte-order magic, dimensions, float32), the
binary model definition (`mdef`: only its base-phone names, whose order numbers the codebooks of a
phonetically-tied model) and the quantised mixture weights (`sendump`).
"""

from __future__ import annotations

import functools
import operator
import struct
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from . import SpeechError

RATE = 16000
FRAME_SHIFT = 160  # samples: 100 frames a second, the aligner's rate
WINDOW = 410  # samples: PocketSphinx's default window, 0.025625 s
FFT_SIZE = 512
PRE_EMPHASIS = 0.97
N_CEPSTRA = 13
LOG_FLOOR = 1e-4
MAGIC = 0x11223344  # sphinx binary files' byte-order word
# Spectral noise removal (PocketSphinx's fe_noise.c constants)
_SMOOTH_WINDOW = 4
_LAMBDA_POWER, _LAMBDA_A, _LAMBDA_B, _LAMBDA_T, _MU_T, _MAX_GAIN = 0.7, 0.995, 0.5, 0.85, 0.2, 20.0
_SENDUMP_SHIFT = 1024 * np.log(1.0001)  # a sendump byte v is the weight 1.0001 ** -(v << 10) (logmath)
# Fewer frames than this leave the transform's 14 unknowns per row poorly determined: no adaptation
MIN_FRAMES = 50
VARIANCE_FLOOR = 1e-4  # PocketSphinx's `varfloor`, applied to the variances when it loads them
# A take whose frames all sit at their transformed means would scale its variances to 0; PocketSphinx floors the
# scaled variances at `varfloor` anyway, and a scale of 0 would be no Gaussian at all
MIN_VARIANCE_SCALE = 1e-4
SUPPORTED = {"transform": "dct", "feat": "1s_c_d_dd", "svspec": "0-12/13-25/26-38", "agc": "none", "varnorm": "no"}


class AdaptationError(SpeechError):
    """A model file this module cannot read, or a front end it does not reproduce."""


@dataclass(frozen=True)
class Model:
    """A phonetically-tied model: means, variances (codebook, stream, density, dim), weights (senone, stream,
    density), base phones (codebook order) and the front end's parameters."""

    means: np.ndarray
    variances: np.ndarray
    weights: np.ndarray
    phones: tuple[str, ...]
    params: dict


# ----------------------------------------------------------------------------- model files


def read_feat_params(path: Path) -> dict[str, str]:
    """`-key value` lines -> {key: value}; a front end other than the one `cepstra` reproduces is refused."""
    words = Path(path).read_text().split()
    params = {k.lstrip("-"): v for k, v in zip(words[::2], words[1::2], strict=False)}
    for key, value in SUPPORTED.items():
        if params.get(key, value) != value:
            raise AdaptationError(f"{path}: {key} {params[key]} is not supported (only {value})")
    return params


def _s3_data(path: Path) -> tuple[bytes, int, str]:
    """A sphinx s3 binary file's bytes, the offset after its header, and its byte order ('<' or '>')."""
    data = Path(path).read_bytes()
    end = data.find(b"endhdr\n")
    if not data.startswith(b"s3\n") or end < 0:
        raise AdaptationError(f"{path}: not a sphinx binary parameter file (no s3 header)")
    offset = end + len(b"endhdr\n")
    for order in "<>":
        if struct.unpack_from(order + "I", data, offset)[0] == MAGIC:
            return data, offset + 4, order
    raise AdaptationError(f"{path}: no byte-order word after the header")


def read_gaussians(path: Path) -> np.ndarray:
    """A means or variances file -> (codebooks, streams, densities, dim) float64 (streams of one length)."""
    data, offset, order = _s3_data(path)
    n_mgau, n_feat, n_density = struct.unpack_from(order + "3i", data, offset)
    lengths = struct.unpack_from(order + f"{n_feat}i", data, offset + 12)
    if len(set(lengths)) != 1:
        raise AdaptationError(f"{path}: streams of lengths {lengths}; only equal lengths are read")
    offset += 12 + 4 * n_feat
    (count,) = struct.unpack_from(order + "i", data, offset)
    shape = (n_mgau, n_feat, n_density, lengths[0])
    if count != int(np.prod(shape)) or len(data) < offset + 4 + 4 * count:
        raise AdaptationError(f"{path}: {count} values for a shape {shape}")
    values = np.frombuffer(data, order + "f4", count, offset + 4)
    return values.reshape(shape).astype(np.float64)


def write_gaussians(path: Path, values: np.ndarray) -> None:
    """(codebooks, streams, densities, dim) -> a sphinx s3 means or variances file (little-endian, no checksum)."""
    n_mgau, n_feat, n_density, dim = values.shape
    header = b"s3\nversion 1.0\nendhdr\n"
    dims = struct.pack(f"<I3i{n_feat}ii", MAGIC, n_mgau, n_feat, n_density, *[dim] * n_feat, values.size)
    Path(path).write_bytes(header + dims + np.ascontiguousarray(values, "<f4").tobytes())


def read_phones(path: Path) -> tuple[str, ...]:
    """The base (context-independent) phones of a binary `mdef`, in order: after the format description,
    4-byte aligned, ten int32 counts (the first n_ciphone), then the names, each ended by a zero byte."""
    data = Path(path).read_bytes()
    marker = b"END FILE FORMAT DESCRIPTION\n"
    if not data.startswith(b"BMDF") or marker not in data:
        raise AdaptationError(f"{path}: not a binary model definition (BMDF)")
    start = -(-(data.index(marker) + len(marker)) // 4) * 4
    (count,) = struct.unpack_from("<i", data, start)
    names = data[start + 40 :].split(b"\0")[:count]
    return tuple(name.decode("ascii") for name in names)


def read_mixture_weights(path: Path) -> np.ndarray:
    """The quantised `sendump` -> (senones, streams, densities) mixture weights, each mixture summing to 1.
    After its header strings (int32 length, then the string; a zero length ends them): int32 densities and
    senones, then per stream and density one byte per senone."""
    data = Path(path).read_bytes()
    offset = 0
    while length := struct.unpack_from("<i", data, offset)[0]:
        offset += 4 + length
    densities, senones = struct.unpack_from("<2i", data, offset + 4)
    quantised = np.frombuffer(data, np.uint8, offset=offset + 12)
    if densities <= 0 or senones <= 0 or quantised.size % (densities * senones):
        raise AdaptationError(f"{path}: {quantised.size} weights for {densities} densities x {senones} senones")
    weights = np.exp(-quantised.reshape(-1, densities, senones).astype(np.float64) * _SENDUMP_SHIFT)
    weights = weights.transpose(2, 0, 1)
    return weights / weights.sum(axis=2, keepdims=True)  # the quantisation's rounding


def read_model(folder: Path) -> Model:
    folder = Path(folder)
    means, variances = (
        read_gaussians(folder / "means"),
        np.maximum(read_gaussians(folder / "variances"), VARIANCE_FLOOR),
    )
    weights, phones = read_mixture_weights(folder / "sendump"), read_phones(folder / "mdef")
    if means.shape != variances.shape or means.shape[0] != len(phones) or weights.shape[1:] != means.shape[1:3]:
        raise AdaptationError(f"{folder}: not a phonetically-tied model (one codebook per base phone)")
    return Model(means, variances, weights, phones, read_feat_params(folder / "feat.params"))


# ----------------------------------------------------------------------------- features


def mel_filters(params: dict) -> np.ndarray:
    """(filters, FFT_SIZE // 2 + 1) triangular mel filters of unit area, edges rounded to the FFT's bins."""
    n, low, high = (
        int(params.get("nfilt", 40)),
        float(params.get("lowerf", 133.33)),
        float(params.get("upperf", 6855.5)),
    )
    mel = lambda f: 2595.0 * np.log10(1.0 + f / 700.0)  # noqa: E731
    width = (mel(high) - mel(low)) / (n + 1)
    step = RATE / FFT_SIZE
    edges = 700.0 * (10.0 ** ((mel(low) + width * np.arange(n + 2)) / 2595.0) - 1.0)
    edges = np.floor(edges / step + 0.5) * step
    hz = np.arange(FFT_SIZE // 2 + 1) * step
    filters = np.zeros((n, hz.size))
    for i in range(n):
        left, centre, right = edges[i : i + 3]
        inside = (hz >= left) & (hz <= right) & (np.arange(hz.size) < FFT_SIZE // 2)
        rising, falling = (hz - left) / (centre - left), (right - hz) / (right - centre)
        filters[i, inside] = np.minimum(rising, falling)[inside] * 2.0 / (right - left)
    return filters


def _noise_gains(band: list[float]) -> list[float]:
    """One mel band's gains over the frames (PocketSphinx's fe_remove_noise: the band's smoothed power, its
    noise as a lower envelope, the signal above it with its own floor and temporal masking). The bands do not
    interact until the gains are smoothed, so each runs on its own, in scalars (a frame at a time in numpy
    costs eight times as much)."""
    power = band[0]
    noise = floor = power / _MAX_GAIN
    peak = 0.0
    gains = []
    for value in band:  # comparisons, not max(): a call per value costs a third of the loop
        power = _LAMBDA_POWER * power + (1 - _LAMBDA_POWER) * value
        rate = _LAMBDA_A if power >= noise else _LAMBDA_B
        noise = rate * noise + (1 - rate) * power
        signal = power - noise
        if signal < 1.0:
            signal = 1.0
        rate = _LAMBDA_A if signal >= floor else _LAMBDA_B
        floor = rate * floor + (1 - rate) * signal
        peak *= _LAMBDA_T
        heard = peak * _MU_T if signal < _LAMBDA_T * peak else signal
        if signal > peak:
            peak = signal
        if heard < floor:
            heard = floor
        gain = heard / power if heard < _MAX_GAIN * power else _MAX_GAIN
        gains.append(gain if gain > 1.0 / _MAX_GAIN else 1.0 / _MAX_GAIN)
    return gains


def _remove_noise(spectra: np.ndarray) -> np.ndarray:
    """PocketSphinx's spectral noise removal over (frames, filters) mel power spectra, from a fresh start: each
    band times the mean gain of the bands within 4 of it."""
    gains = np.array([_noise_gains(band) for band in spectra.T.tolist()]).T.reshape(spectra.shape)
    n = spectra.shape[1]
    lo = np.maximum(np.arange(n) - _SMOOTH_WINDOW, 0)
    hi = np.minimum(np.arange(n) + _SMOOTH_WINDOW, n - 1)
    cumulative = np.concatenate([np.zeros((len(gains), 1)), np.cumsum(gains, axis=1)], axis=1)
    return spectra * (cumulative[:, hi + 1] - cumulative[:, lo]) / (hi - lo + 1)


def cepstra(pcm: np.ndarray, params: dict, warm_up: bool = True) -> np.ndarray:
    """int16 samples at 16 kHz -> (frames, 13) cepstra as PocketSphinx's front end computes them: frame k from
    samples [160 k, 160 k + 410), the last from what is left after the last whole window's shift, zero-padded.
    The noise removal runs on from utterance to utterance in a decoder: every pass over a piece after the
    first sees it as the first left it, and `warm_up` runs it over the piece once before, as there (the
    piece's mean is taken from these features; a decoder's first pass differs in its first frames only)."""
    x = np.asarray(pcm, np.float64)
    if x.size == 0:
        return np.zeros((0, N_CEPSTRA))
    emphasised = x - PRE_EMPHASIS * np.concatenate([[0.0], x[:-1]])
    # the whole windows, then one from the samples left after the last one's shift, zero-padded (end_utt)
    frames = 1 + (1 + (x.size - WINDOW) // FRAME_SHIFT if x.size >= WINDOW else 0)
    padded = np.zeros((frames - 1) * FRAME_SHIFT + WINDOW)
    padded[: x.size] = emphasised[: padded.size]
    windows = np.lib.stride_tricks.sliding_window_view(padded, WINDOW)[::FRAME_SHIFT][:frames] * np.hamming(WINDOW)
    spectra = np.abs(np.fft.rfft(windows, FFT_SIZE)) ** 2 @ mel_filters(params).T
    if params.get("remove_noise", "no") == "yes":  # PocketSphinx's default: no (the model's feat.params: yes)
        spectra = _remove_noise(np.concatenate([spectra, spectra]) if warm_up else spectra)[-frames:]
    logs = np.log(spectra + LOG_FLOOR)
    n = logs.shape[1]
    basis = np.cos(np.pi / n * np.arange(N_CEPSTRA)[:, None] * (np.arange(n) + 0.5)) * np.sqrt(2.0 / n)
    basis[0] = np.sqrt(1.0 / n)
    lifter = int(params.get("lifter", 0))
    weights = 1 + lifter / 2 * np.sin(np.arange(N_CEPSTRA) * np.pi / lifter) if lifter else np.ones(N_CEPSTRA)
    return logs @ basis.T * weights


def features(cep: np.ndarray) -> np.ndarray:
    """(frames, 13) cepstra -> (frames, 3, 13) `1s_c_d_dd` streams: the mean-removed cepstra, their deltas and
    second deltas, the ends padded with copies of the first and last frame."""
    c = cep - cep.mean(axis=0)
    p = np.concatenate([np.repeat(c[:1], 3, 0), c, np.repeat(c[-1:], 3, 0)])
    at = lambda k: p[3 + k : 3 + k + len(c)]  # noqa: E731
    return np.stack([c, at(2) - at(-2), (at(3) - at(-1)) - (at(1) - at(-3))], axis=1)


# ----------------------------------------------------------------------------- MLLR


@dataclass(frozen=True)
class Counts:
    """The posterior-weighted counts of each Gaussian (codebook, stream, density) over a take's frames: its
    occupancy, and the sums of its frames and of their squares (dim)."""

    occupancy: np.ndarray
    first: np.ndarray
    second: np.ndarray

    def __add__(self, other: Counts) -> Counts:
        return Counts(self.occupancy + other.occupancy, self.first + other.first, self.second + other.second)


@dataclass(frozen=True)
class Transform:
    """One global transform per stream: the means' W = [A b] (streams, dim, dim + 1) and the variances' scales
    H (streams, dim), as PocketSphinx applies them (mu -> A mu + b, var -> h var)."""

    means: np.ndarray
    variances: np.ndarray


def counts(feats: np.ndarray, senones: np.ndarray, codebooks: np.ndarray, model: Model) -> Counts:
    """The Gaussians' counts from frames (T, streams, dim), each frame's senone and codebook (the state
    alignment): gamma, the Gaussian's posterior within the frame's senone (its mixture weight times its density,
    normalised over the mixture), summed over the frames, times the frame, times its square."""
    shape = model.means.shape
    occupancy, first, second = np.zeros(shape[:3]), np.zeros(shape), np.zeros(shape)
    for c in np.unique(codebooks):  # the frames of one codebook at a time: their Gaussians are the same
        at = codebooks == c
        log_w = np.log(np.maximum(model.weights[senones[at]], 1e-300))  # (frames, streams, densities)
        for f in range(shape[1]):
            o, mu, var = feats[at, f], model.means[c, f], model.variances[c, f]
            inv = 1.0 / var
            # log N(o; mu, var) for every frame and Gaussian, the square expanded into products
            quadratic = (o * o) @ inv.T - 2.0 * o @ (mu * inv).T + (mu * mu * inv).sum(1)
            joint = log_w[:, f] - 0.5 * (quadratic + np.log(2 * np.pi * var).sum(1))
            gamma = np.exp(joint - joint.max(axis=1, keepdims=True))
            gamma /= gamma.sum(axis=1, keepdims=True)
            occupancy[c, f], first[c, f], second[c, f] = gamma.sum(0), gamma.T @ o, gamma.T @ (o * o)
    return Counts(occupancy, first, second)


def mean_statistics(counts: Counts, model: Model) -> tuple[np.ndarray, np.ndarray]:
    """Leggetter & Woodland's sufficient statistics of a mean transform per stream: G (streams, dim, dim + 1,
    dim + 1) and k (streams, dim, dim + 1), G_i = sum over Gaussians m of occ_m / var_mi xi_m xi_m^T, k_i = sum
    over frames and Gaussians of gamma_m(t) o_i(t) / var_mi xi_m, with xi = [mu, 1]."""
    seen = counts.occupancy.sum(axis=(1, 2)) > 0  # the codebooks the take's frames met
    means, variances = model.means[seen], model.variances[seen]
    xi = np.concatenate([means, np.ones(means.shape[:3] + (1,))], axis=3)  # (codebooks, streams, m, dim + 1)
    n_feat, dim = means.shape[1], means.shape[3]
    g, k = np.zeros((n_feat, dim, dim + 1, dim + 1)), np.zeros((n_feat, dim, dim + 1))
    for f in range(n_feat):
        x = xi[:, f].reshape(-1, dim + 1)  # every Gaussian of the stream, one row each
        occupancy_inv = (counts.occupancy[seen, f][..., None] / variances[:, f]).reshape(-1, dim)  # occ_m / var_mi
        g[f] = (occupancy_inv.T[:, None, :] * x.T[None]) @ x
        k[f] = ((counts.first[seen, f] / variances[:, f]).reshape(-1, dim)).T @ x
    return g, k


def statistics(
    feats: np.ndarray, senones: np.ndarray, codebooks: np.ndarray, model: Model
) -> tuple[np.ndarray, np.ndarray]:
    """`mean_statistics` of the frames' `counts`."""
    return mean_statistics(counts(feats, senones, codebooks, model), model)


def solve(g: np.ndarray, k: np.ndarray) -> np.ndarray:
    """(streams, dim, dim + 1) transforms W = [A b], row i of stream f solving G_fi w = k_fi."""
    return np.linalg.solve(g, k[..., None])[..., 0]


def variance_scales(counts: Counts, model: Model, transforms: np.ndarray) -> np.ndarray:
    """(streams, dim) the maximum-likelihood scale of every variance given the transformed means (Gales and
    Woodland 1996 with a diagonal H, one global class): h_i = sum over frames and Gaussians of
    gamma_m(t) (o_i(t) - mu'_mi)^2 / var_mi, over the total occupancy, the square expanded into the counts."""
    adapted = transformed_means(model.means, transforms)
    residual = counts.second - 2.0 * adapted * counts.first + counts.occupancy[..., None] * adapted**2
    return (residual / model.variances).sum(axis=(0, 2)) / counts.occupancy.sum(axis=(0, 2))[:, None]


def estimate(pieces: list[tuple[np.ndarray, np.ndarray, np.ndarray]], model: Model) -> Transform | None:
    """The transform from aligned pieces of a take, each (features, senones, codebooks) (their counts add): the
    means' from the counts, then the variances' given the means', from the same counts (one EM step from the
    model as it is). None when the pieces have too few frames or their statistics are singular."""
    if sum(len(feats) for feats, _, _ in pieces) < MIN_FRAMES:
        return None
    total = functools.reduce(
        operator.add, (counts(feats, np.asarray(s), np.asarray(c), model) for feats, s, c in pieces)
    )
    try:
        w = solve(*mean_statistics(total, model))
    except np.linalg.LinAlgError:
        return None
    if not np.all(np.isfinite(w)):
        return None
    h = variance_scales(total, model, w)
    return Transform(w, np.maximum(h, MIN_VARIANCE_SCALE)) if np.all(np.isfinite(h)) else None


def transformed_means(means: np.ndarray, transforms: np.ndarray) -> np.ndarray:
    """The means as PocketSphinx transforms them: A mu + b per stream."""
    a, b = transforms[..., :-1], transforms[..., -1]
    return np.einsum("fij,cfmj->cfmi", a, means) + b[None, :, None, :]


def write_mllr(path: Path, transform: Transform) -> None:
    """sphinxtrain's `mllr_matrix` text: classes (1), streams, then per stream its length, A row by row, b and
    the variances' scales h."""
    lines = ["1", str(len(transform.means))]
    for w, h in zip(transform.means, transform.variances, strict=True):
        lines.append(str(len(w)))
        lines += [" ".join(f"{v:.9g}" for v in row) for row in w[:, :-1]]
        lines += [" ".join(f"{v:.9g}" for v in w[:, -1]), " ".join(f"{v:.9g}" for v in h)]
    Path(path).write_text("\n".join(lines) + "\n")


def read_mllr(path: Path) -> Transform:
    """An `mllr_matrix` file of one class -> its Transform."""
    values = iter(Path(path).read_text().split())
    classes, streams = int(next(values)), int(next(values))
    if classes != 1:
        raise AdaptationError(f"{path}: {classes} classes; only one is read")
    means, scales = [], []
    for _ in range(streams):
        n = int(next(values))
        numbers = np.array([float(next(values)) for _ in range(n * n + 2 * n)])
        means.append(np.column_stack([numbers[: n * n].reshape(n, n), numbers[n * n : n * n + n]]))
        scales.append(numbers[n * n + n :])
    return Transform(np.array(means), np.array(scales))
