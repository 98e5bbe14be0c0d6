"""FAP groups with a gain each and a soft limit to plausible ranges (no bpy).

Real streams carry values no face makes: VREng's jag.fap pulls the jaw back by 1.2 MNS0 (the chin
spikes through the neck), Crystal's anger squeezes the inner brows 14 mm toward each other (the brow
folds), Crystal's interpolation turns the eyes by 6 rad. `shape_faps` scales each group by its gain and
then saturates every value smoothly toward its range (`soft_limit`): values well inside the range pass
unchanged, values past it approach the limit without a hard cut (a hard cut turns a smooth overshoot
into a flat plateau with corners).

Ranges are in FAP units of each FAP's own FAPU (research/mpeg4-fba.md section 3), set from what a face
can do: the jaw opens about one MNS0, retracts a few millimetres and protrudes about 8.5 mm (8.2 +- 2.5 mm
in 1,011 people, Hirsch et al. 2006, Eur J Oral Sci 114:465; 8.8 +- 2.3 mm in 500 adults: thrust_jaw's upper
limit 600 MNS passes the 480 MNS this is on the sample head (MNS0 18.1 mm), which the old symmetric 250 eased to
about 230, half the protrusion; its lower limit stays the retraction's 250), lips move about half an MNS0 or a
third of MW0 past neutral, a lid travels its opening (the lids' meeting is enforced in decode) and opens
past neutral by about a third of IRISD0 (the levator lifts the upper lid 2-3 mm), the eyes turn about 40
degrees, the brows rise about 0.3 ENS0 and lower about 0.2 ENS0 (10-15 mm up, 7-10 mm down on an adult face:
more folds the skin between brow and lid or up the forehead) and squeeze about 7 mm, the head turns about
40 degrees in pitch, 70 in yaw and 35 in roll. The expression tables (speech/data/expressions.json) stay
inside the knees but for surprise's brows (320) and lids (-300), eased by a tenth.
"""

from __future__ import annotations

import numpy as np

from .faps import N_FAPS

KNEE = 0.8  # values within this fraction of the limit pass unchanged

# group -> {FAP numbers: (lower, upper) limit in FAP units}
GROUPS: dict[str, dict[tuple[int, ...], tuple[float, float]]] = {
    "jaw": {(3,): (-100.0, 1100.0), (14,): (-250.0, 600.0), (15,): (-250.0, 250.0), (18,): (-400.0, 400.0)},
    "lips": {
        (4, 5, 8, 9, 10, 11, 12, 13, 51, 52, 55, 56, 57, 58, 59, 60): (-500.0, 500.0),
        (6, 7, 53, 54): (-400.0, 400.0),
        (16, 17): (-400.0, 400.0),
    },
    "eyelids": {(19, 20, 21, 22): (-300.0, 1400.0)},
    "eyes": {(23, 24, 25, 26): (-70000.0, 70000.0), (27, 28): (-100.0, 100.0), (29, 30): (-600.0, 600.0)},
    "brows": {(31, 32, 33, 34, 35, 36): (-200.0, 300.0), (37, 38): (-120.0, 120.0)},
    "head": {(48,): (-70000.0, 70000.0), (49,): (-120000.0, 120000.0), (50,): (-60000.0, 60000.0)},
}
GROUP_NAMES = tuple(GROUPS)


def _tables() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    group = np.full(N_FAPS, -1)
    lower = np.full(N_FAPS, -np.inf)
    upper = np.full(N_FAPS, np.inf)
    for g, ranges in enumerate(GROUPS.values()):
        for numbers, (lo, hi) in ranges.items():
            index = np.array(numbers) - 1
            group[index], lower[index], upper[index] = g, lo, hi
    return group, lower, upper


FAP_GROUP, LOWER, UPPER = _tables()  # per FAP column: group index (-1: none), limits (+-inf: none)


def soft_limit(values: np.ndarray, lower: np.ndarray, upper: np.ndarray, knee: float = KNEE) -> np.ndarray:
    """Smooth saturation of `values` into [lower, upper] (broadcast; limits may be +-inf).

    Identity inside [knee * lower, knee * upper]; past the knee k toward the limit L it continues as
    k + (L - k) tanh((x - k) / (L - k)), which has slope 1 at the knee (no corner), rises monotonically
    and reaches L only in the limit (numerically, for huge values). Needs lower < 0 < upper.
    """
    x = np.asarray(values, dtype=np.float64)
    out = x.copy()
    for limit, side in ((np.asarray(upper, dtype=np.float64), 1.0), (np.asarray(lower, dtype=np.float64), -1.0)):
        limit = np.broadcast_to(limit, x.shape)
        over = np.isfinite(limit) & (side * (x - knee * limit) > 0.0)
        k = np.where(over, knee * limit, 0.0)
        span = np.where(over, limit - k, 1.0)
        out = np.where(over, k + span * np.tanh((x - k) / span), out)
    return out


def shape_faps(values: np.ndarray, gains: dict[str, float] | None = None, limit: bool = True) -> np.ndarray:
    """A new (F, 68) array: each group's FAPs times its gain (default 1), then soft-limited to its range.

    Columns of FAPs in no group (viseme, expression, cheeks, tongue, nose, ears) pass unchanged.
    """
    out = np.array(values, dtype=np.float64)
    if out.ndim != 2 or out.shape[1] != N_FAPS:
        raise ValueError(f"FAP values must be (frames, {N_FAPS}), got {out.shape}")
    for name, gain in (gains or {}).items():
        if name not in GROUPS:
            raise KeyError(f"unknown FAP group {name!r}; the groups are {', '.join(GROUP_NAMES)}")
        if not (np.isfinite(gain) and gain >= 0.0):
            raise ValueError(f"the {name} gain must be a finite number of at least 0, found {gain!r}")
        out[:, FAP_GROUP == GROUP_NAMES.index(name)] *= gain
    if limit:
        grouped = FAP_GROUP >= 0
        out[:, grouped] = soft_limit(out[:, grouped], LOWER[grouped], UPPER[grouped])
    return out
