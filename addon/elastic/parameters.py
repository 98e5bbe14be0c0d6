"""The engine's trainable parameters: a gain per bone and the elastic weight w_i of every (bone,
neighbour) pair of eq. 4.

UNTRAINED is what the paper gives before training: every gain 1 and every w_i UNTRAINED_WEIGHT (the
paper gives no value; its figure 4 raises them "to show the difference"). TRAINED comes from
`training.train` on the development units (`trained.py`, written by `scripts/bench/train_elastic.py`).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field

import numpy as np

from .errors import RuleTableError
from .skeleton import BONES, Bone, Skeleton
from .trained import TRAINED_ELASTIC, TRAINED_GAINS

UNTRAINED_WEIGHT = 0.25


def neighbour_pairs(bones: tuple[Bone, ...] = BONES) -> tuple[tuple[str, str], ...]:
    """Every (bone, neighbour) pair of the elastic layer, in table order."""
    return tuple((b.name, n) for b in bones for n in b.neighbours)


@dataclass(frozen=True)
class Parameters:
    gains: Mapping[str, float] = field(default_factory=dict)  # bone -> gain; absent bones 1
    elastic: Mapping[tuple[str, str], float] = field(default_factory=dict)  # (bone, neighbour) -> w_i; absent 0

    def gain_array(self, skeleton: Skeleton) -> np.ndarray:
        unknown = sorted(set(self.gains) - set(skeleton.names))
        if unknown:
            raise RuleTableError(f"gains name unknown bones {', '.join(unknown)}")
        return np.array([float(self.gains.get(name, 1.0)) for name in skeleton.names])

    def pair_arrays(self, skeleton: Skeleton) -> tuple[np.ndarray, np.ndarray]:
        """(K, 2) bone rows (bone, neighbour) and (K,) w_i of the skeleton's pairs."""
        pairs = neighbour_pairs(skeleton.bones)
        unknown = sorted(f"{b}<-{n}" for b, n in set(self.elastic) - set(pairs))
        if unknown:
            raise RuleTableError(f"elastic weights name pairs that are not neighbours: {', '.join(unknown)}")
        rows = np.array([[skeleton.index(b), skeleton.index(n)] for b, n in pairs], dtype=np.intp).reshape(-1, 2)
        return rows, np.array([float(self.elastic.get(pair, 0.0)) for pair in pairs])

    def without_elastic(self) -> Parameters:
        return Parameters(self.gains, {})


UNTRAINED = Parameters({}, dict.fromkeys(neighbour_pairs(), UNTRAINED_WEIGHT))
TRAINED = Parameters(TRAINED_GAINS, TRAINED_ELASTIC)
