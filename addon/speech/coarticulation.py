"""Cohen & Massaro (1993) co-articulation: viseme segments -> continuous low-level FAP tracks.

The paper (research/deformation-lipsync.md section 4.1; Mujika et al. section 3.2 use it as their
co-articulation module). For segment s with centre c_s and FAP p:

    tau = c_s - t
    D_sp(t) = alpha_sp * exp(-theta_sp * |tau| ** c_sp),  theta = theta_before where tau >= 0 (anticipation)
                                                          and theta_after where tau < 0 (carry-over)
    F_p(t) = sum_s D_sp(t) * T_sp / sum_s D_sp(t),        T_sp = the viseme table's value of p for s

Parameters per viseme and FAP group: `data/dominance.json`. The original's optional time offset of the
dominance peak is 0: the peak sits at the segment centre.

Bilabial closure. We chose both mechanisms: /p b m/ have a high dominance on the lip-opening FAPs (alpha 6,
which shapes the approach and release), and a closure constraint makes the closure exact at any speaking
rate. Averaging alone cannot guarantee it: neighbouring open vowels always keep some weight. After averaging,
over each PP segment (and out to the nearest video frame of its centre, when sampling at a frame rate) every
lip pair's gap, open_jaw - upper lip FAP - lower lip FAP (MNS; the jaw carries the lower lip), is brought
down to the PP shape's own gap (pressed lips). The excess is shared between the upper and lower lip in the
proportion of the PP shape's own lip FAPs, and the outer contour moves with the inner one. Outside the
segment the correction fades with PP's lip-opening dominance shape, exp(-theta * distance ** c), so the
tracks stay continuous.

Rounding spreading. Consonants have a low dominance on protrusion and width (dominance.json), so a rounded
vowel's protrusion carries over the consonants before and after it.

Numerics. FAPs whose parameters agree for every viseme share one dominance function. Dominances are combined
as logarithms relative to their maximum per frame, so the average stays exact where every dominance
underflows (a long gap). Within a block of frames, a segment is left out only where its dominance is below
e^-50 times the smallest dominance the nearest segment has in that block. Its share of the average is then
below 2e-22.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from ..mpeg4.fap_file import FapStream
from ..mpeg4.faps import N_FAPS, Viseme
from . import SpeechError
from .segments import Segment, check_segments
from .tables import DominanceTable, ShapeTable, load_dominance, load_visemes

MAX_SECONDS = 3600.0  # the longest speech made at once (an hour): caps the frames before anything is allocated
DEFAULT_MAX_FRAMES = 90_000  # MAX_SECONDS at 25 fps; the Blender side passes its frame range, at most MAX_SECONDS
OPEN_JAW = 3
# Lip pairs the closure constraint closes: (inner upper, inner lower, outer upper, outer lower); the lower
# points 2.3, 2.8, 2.9 ride the jaw, so each pair's gap is open_jaw - upper - lower.
CLOSURE_PAIRS = ((4, 5, 51, 52), (8, 10, 55, 57), (9, 11, 56, 58))
_MARGIN = 50.0  # natural-log units below the nearest segment's dominance at which a segment is left out
_BLOCK_FRAMES = 256
_BLOCK_ELEMENTS = 1 << 20  # segments x frames evaluated at once


def _weighted_average(centres, targets, log_alpha, theta_before, theta_after, exponent, times) -> np.ndarray:
    """(T, K) sum D*T / sum D at sorted `times` for FAPs that share one dominance function per segment:
    centres, log_alpha, theta_before, theta_after, exponent (S,), centres sorted; targets (S, K)."""
    n_times, n_faps = len(times), targets.shape[1]
    out = np.empty((n_times, n_faps))
    theta_min = min(theta_before.min(), theta_after.min())
    c_range = (exponent.min(), exponent.max())

    linear = bool(np.all(exponent == 1.0))  # the paper's c = 1: skip the power

    def log_dominance(index, t):
        tau = centres[index] - t
        theta = np.where(tau >= 0.0, theta_before[index], theta_after[index])
        distance = np.abs(tau) if linear else np.abs(tau) ** exponent[index]
        return log_alpha[index] - theta * distance

    for first in range(0, n_times, _BLOCK_FRAMES):
        t = times[first : first + _BLOCK_FRAMES]
        # A lower bound of the largest log-dominance at each time: that of the segment with the nearest centre.
        if len(centres) == 1:
            nearest = np.zeros(len(t), np.intp)
        else:
            right = np.clip(np.searchsorted(centres, t), 1, len(centres) - 1)
            nearest = np.where(np.abs(centres[right] - t) < np.abs(t - centres[right - 1]), right, right - 1)
        floor = log_dominance(nearest, t).min() - _MARGIN
        # No segment whose centre is further than `reach` from every time here gets above the floor.
        gain = log_alpha.max() - floor
        reach = max((gain / theta_min) ** (1.0 / c) for c in c_range)
        lo = np.searchsorted(centres, t[0] - reach, side="left")
        hi = np.searchsorted(centres, t[-1] + reach, side="right")
        top = np.full(len(t), -np.inf)
        weight = np.zeros(len(t))
        weighted = np.zeros((len(t), n_faps))
        batch = max(1, _BLOCK_ELEMENTS // len(t))
        for a in range(lo, hi, batch):
            index = np.arange(a, min(a + batch, hi))
            log_d = log_dominance(index[:, None], t[None, :])  # (S, T)
            new_top = np.maximum(top, log_d.max(axis=0))
            rescale = np.exp(top - new_top)
            d = np.exp(log_d - new_top)
            weight = weight * rescale + d.sum(axis=0)
            weighted = weighted * rescale[:, None] + d.T @ targets[index]
            top = new_top
        out[first : first + len(t)] = weighted / weight[:, None]
    return out


def _check_closure_shape(visemes: ShapeTable) -> None:
    shape = visemes.targets[Viseme.PP]
    for upper, lower, _, _ in CLOSURE_PAIRS:
        closing = shape[upper - 1] + shape[lower - 1]
        if closing <= 0 or shape[OPEN_JAW - 1] - closing > 0:
            raise SpeechError(
                f"the viseme table's PP does not close the lips at FAPs {upper}/{lower}: open_jaw - "
                f"FAP {upper} - FAP {lower} must be <= 0, with the lips moving toward each other"
            )


def _close_bilabials(values, times, segments, visemes, dominance, closure_fps) -> None:
    """The closure constraint (module docstring), in place on (T, 68) `values` at sorted `times`.

    Closing one PP segment after another leaves each lip pair's excess gap times (1 - w_s) per segment, w_s
    its weight at that frame (1 over the segment, fading outside), whatever the order: the excess left is
    the product of (1 - w_s) over the segments, taken here in one pass over (segment, frame) pairs, so that
    many overlapping segments cost their pairs, not a pass over the tracks each."""
    shape = visemes.targets[Viseme.PP]
    column = CLOSURE_PAIRS[0][0] - 1
    theta_before = dominance.theta_before[Viseme.PP, column]
    theta_after = dominance.theta_after[Viseme.PP, column]
    c = dominance.exponent[Viseme.PP, column]
    spans = []
    for segment in segments:
        if segment.viseme != Viseme.PP:
            continue
        a, b = segment.start, segment.end
        if closure_fps is not None:
            nearest_frame = round(segment.centre * closure_fps) / closure_fps
            a, b = min(a, nearest_frame), max(b, nearest_frame)
        spans.append((a, b))
    if not spans:
        return
    a, b = np.array(spans).T
    lo = np.searchsorted(times, a - (_MARGIN / theta_before) ** (1.0 / c))
    hi = np.searchsorted(times, b + (_MARGIN / theta_after) ** (1.0 / c), side="right")
    log_left = np.zeros(len(times))  # sum over segments of log(1 - w_s): the excess gap each frame keeps
    ends = np.cumsum(hi - lo)
    first = 0
    while first < len(spans):
        last = max(first + 1, int(np.searchsorted(ends, ends[first] - (hi - lo)[first] + _BLOCK_ELEMENTS)))
        rows = np.arange(first, last)
        counts = (hi - lo)[rows]
        row = np.repeat(rows, counts)
        frame = lo[row] + np.arange(counts.sum()) - np.repeat(np.cumsum(counts) - counts, counts)
        t = times[frame]
        weight = np.ones(len(t))
        before, after = t < a[row], t > b[row]
        weight[before] = np.exp(-theta_before * (a[row][before] - t[before]) ** c)
        weight[after] = np.exp(-theta_after * (t[after] - b[row][after]) ** c)
        with np.errstate(divide="ignore"):  # w = 1 over a segment: nothing of the excess is left
            log_left += np.bincount(frame, np.log1p(-weight), minlength=len(times))
        first = last
    closed = -np.expm1(log_left)  # 1 - the product: the share of the excess taken away
    for upper, lower, upper_outer, lower_outer in CLOSURE_PAIRS:
        up, down, jaw = upper - 1, lower - 1, OPEN_JAW - 1
        share = shape[up] / (shape[up] + shape[down])
        target_gap = shape[jaw] - shape[up] - shape[down]
        gap = values[:, jaw] - values[:, up] - values[:, down]
        correction = closed * np.maximum(gap - target_gap, 0.0)
        for fap_upper, fap_lower in ((upper, lower), (upper_outer, lower_outer)):
            values[:, fap_upper - 1] += share * correction
            values[:, fap_lower - 1] += (1.0 - share) * correction


def coarticulate(
    segments: Sequence[Segment],
    times: np.ndarray,
    *,
    visemes: ShapeTable | None = None,
    dominance: DominanceTable | None = None,
    closure_fps: float | None = None,
) -> np.ndarray:
    """(T, 68) low-level FAP values (FAPU) at `times` (seconds, any order) for the segments.

    Only the viseme table's FAPs move; the others are 0. `closure_fps` (the frame rate `times` are sampled
    at) extends each bilabial closure to the frame nearest its centre, so that every /p b m/ shows closed on
    at least one frame even when it is shorter than a frame.
    """
    segments = list(segments)
    if not segments:
        raise SpeechError("no segments with a mouth shape to animate")
    check_segments(segments)
    times = np.asarray(times, dtype=np.float64)
    if times.ndim != 1 or not np.all(np.isfinite(times)):
        raise SpeechError("the sample times must be a 1-D array of finite seconds")
    if closure_fps is not None and not (math.isfinite(closure_fps) and closure_fps > 0):
        raise SpeechError(f"frame rate {closure_fps!r} is not a positive number")
    visemes = visemes or load_visemes()
    dominance = dominance or load_dominance()
    if any(s.viseme == Viseme.PP for s in segments):
        _check_closure_shape(visemes)

    order = np.argsort(times, kind="stable")
    sorted_times = times[order]
    rows = np.array([int(s.viseme) for s in segments])
    columns = visemes.faps - 1
    centres = np.array([s.centre for s in segments])
    values = np.zeros((len(times), N_FAPS))
    if len(times):
        table = np.stack([dominance.alpha, dominance.theta_before, dominance.theta_after, dominance.exponent])
        # FAPs whose parameters agree for every viseme share one dominance function per segment (a group)
        _, group = np.unique(table[:, :, columns].reshape(-1, len(columns)), axis=1, return_inverse=True)
        for g in np.unique(group):
            k = columns[np.flatnonzero(group.ravel() == g)]
            alpha, theta_before, theta_after, exponent = table[:, rows, k[0]]
            values[:, k] = _weighted_average(
                centres,
                visemes.targets[np.ix_(rows, k)],
                np.log(alpha),
                theta_before,
                theta_after,
                exponent,
                sorted_times,
            )
        _close_bilabials(values, sorted_times, segments, visemes, dominance, closure_fps)
    out = np.empty_like(values)
    out[order] = values
    return out


@dataclass(frozen=True, eq=False)
class FapTracks:
    """Low-level FAP values sampled at a frame rate: frame k is at time k / fps (seconds)."""

    fps: float
    values: np.ndarray  # (F, 68) FAPU
    faps: np.ndarray  # (K,) FAP numbers the tracks drive

    @property
    def n_frames(self) -> int:
        return len(self.values)

    @property
    def times(self) -> np.ndarray:
        return np.arange(self.n_frames) / self.fps

    @property
    def mask(self) -> np.ndarray:
        """(F, 68) True for the FAPs the tracks drive."""
        mask = np.zeros((self.n_frames, N_FAPS), dtype=bool)
        mask[:, self.faps - 1] = True
        return mask

    def with_offsets(self, offsets: np.ndarray) -> FapTracks:
        """These tracks plus (68,) FAP values on every frame, e.g. `high_level.expression_values("joy", 0.6)`
        to layer an expression on speech; the FAPs the offsets move join the driven set."""
        offsets = np.asarray(offsets, dtype=np.float64)
        if offsets.shape != (N_FAPS,) or not np.all(np.isfinite(offsets)):
            raise ValueError(f"offsets must be {N_FAPS} finite FAP values, got shape {offsets.shape}")
        faps = np.union1d(self.faps, np.flatnonzero(offsets[2:]) + 3)
        return FapTracks(self.fps, self.values + offsets, faps)

    def to_stream(self, name: str = "speech", viseme_fields: np.ndarray | None = None, held: bool = True) -> FapStream:
        """A `.fap` stream of the tracks (write it with `fap_file.write_fap`); `viseme_fields` (F, 4), e.g.
        from `viseme_track`, adds FAP 1 to every frame (players that read it take the low-level values first).
        `held=False` leaves out the frames inside a run of equal frames (`changing_frames`): linear keys
        then give the same motion, and a long silence costs two keys, not one per frame."""
        if not held:
            kept = changing_frames(self.values)
            faps = FapTracks(self.fps, self.values[kept], self.faps)
            fields = None if viseme_fields is None else np.asarray(viseme_fields)[kept]
            return dataclasses.replace(faps.to_stream(name, fields), frame_numbers=kept.astype(np.int64))
        mask = self.mask
        viseme = np.zeros((self.n_frames, 4))
        if viseme_fields is not None:
            viseme = np.asarray(viseme_fields, dtype=np.float64)
            if viseme.shape != (self.n_frames, 4):
                raise ValueError(f"viseme_fields must have shape ({self.n_frames}, 4), got {viseme.shape}")
            mask[:, 0] = True
        return FapStream(
            version="2.1",
            name=name,
            fps=float(self.fps),
            frame_numbers=np.arange(self.n_frames, dtype=np.int64),
            mask=mask,
            values=np.where(mask, self.values, 0.0),
            viseme=viseme,
            expression=np.zeros((self.n_frames, 6)),
        )


def changing_frames(values: np.ndarray) -> np.ndarray:
    """Indices of the (F, K) `values`' frames that linear interpolation between them cannot give: the first and
    the last, and every frame that differs from the one before or after it."""
    values = np.asarray(values)
    if len(values) <= 2:
        return np.arange(len(values))
    change = np.any(values[1:] != values[:-1], axis=1)
    keep = np.ones(len(values), bool)
    keep[1:-1] = change[:-1] | change[1:]
    return np.flatnonzero(keep)


def frame_count(duration: float, fps: float, max_frames: int = DEFAULT_MAX_FRAMES) -> int:
    """Frames that cover [0, duration) at `fps` (at least one), checked against `max_frames` first."""
    if isinstance(fps, bool) or not isinstance(fps, int | float) or not (math.isfinite(fps) and fps > 0):
        raise SpeechError(f"frame rate {fps!r} is not a positive number")
    if isinstance(max_frames, bool) or not isinstance(max_frames, int) or max_frames < 1:
        raise SpeechError(f"the frame cap {max_frames!r} is not a positive whole number")
    if not (isinstance(duration, int | float) and math.isfinite(duration) and duration >= 0):
        raise SpeechError(f"duration {duration!r} is not a non-negative number of seconds")
    exact = duration * fps
    if not exact <= max_frames:  # also an infinite product of two huge numbers
        seconds, frames = (f"{duration:.3f}", math.ceil(exact)) if exact < 1e15 else (f"{duration:.3g}", f"{exact:.3g}")
        raise SpeechError(
            f"the speech lasts {seconds} s, {frames} frames at {fps:g} fps, more than the "
            f"{max_frames} frames allowed: shorten the text or the cue file, or allow a longer frame range"
        )
    return max(1, math.ceil(exact - 1e-9))


def fap_tracks(
    segments: Sequence[Segment],
    fps: float,
    *,
    duration: float | None = None,
    max_frames: int = DEFAULT_MAX_FRAMES,
    visemes: ShapeTable | None = None,
    dominance: DominanceTable | None = None,
) -> FapTracks:
    """Co-articulated FAP tracks at `fps` from time 0 over `duration` (default: the last segment's end),
    with every bilabial closed on at least one frame."""
    segments = list(segments)
    if not segments:
        raise SpeechError("no segments with a mouth shape to animate")
    check_segments(segments)
    duration = segments[-1].end if duration is None else duration
    n_frames = frame_count(duration, fps, max_frames)
    visemes = visemes or load_visemes()
    times = np.arange(n_frames) / fps
    values = coarticulate(segments, times, visemes=visemes, dominance=dominance, closure_fps=fps)
    return FapTracks(float(fps), values, visemes.faps.copy())


def viseme_track(segments: Sequence[Segment], times: np.ndarray) -> np.ndarray:
    """(T, 4) FAP 1 fields naming the segment at each time (select1 = select2, blend 63, def 0); before the
    first segment its viseme, in a gap the previous one's."""
    segments = list(segments)
    if not segments:
        raise SpeechError("no segments with a mouth shape to animate")
    check_segments(segments)
    starts = np.array([s.start for s in segments])
    index = np.clip(np.searchsorted(starts, np.asarray(times, dtype=np.float64), side="right") - 1, 0, None)
    visemes = np.array([int(s.viseme) for s in segments])[index]
    return np.column_stack([visemes, visemes, np.full(len(index), 63), np.zeros(len(index))]).astype(np.float64)
