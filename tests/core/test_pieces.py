"""A mesh's connected pieces (`geometry.pieces.connected_pieces`), with scipy and with numpy alone, no scene."""

import builtins

import numpy as np

from addon.geometry.pieces import connected_pieces

# a path 0-1-2 given out of order, a pair 3-5, and vertex 4 alone
EDGES = np.array([[2, 1], [0, 1], [5, 3]])


def _same_pieces(labels: np.ndarray) -> list[set[int]]:
    return sorted(({int(v) for v in np.flatnonzero(labels == label)} for label in np.unique(labels)), key=min)


def test_the_pieces_by_hand_with_scipy():
    assert _same_pieces(connected_pieces(6, EDGES)) == [{0, 1, 2}, {3, 5}, {4}]


def test_the_pieces_by_hand_without_scipy(monkeypatch):
    """Where the platform has no scipy wheel the numpy path gives the same pieces, each labelled by its least
    vertex; on a longer chain given backwards it still joins all of it."""
    real_import = builtins.__import__

    def no_scipy(name, *args, **kwargs):
        if name.startswith("scipy"):
            raise ImportError(name)
        return real_import(name, *args, **kwargs)

    monkeypatch.setattr(builtins, "__import__", no_scipy)
    assert connected_pieces(6, EDGES).tolist() == [0, 0, 0, 3, 4, 3]
    chain = np.stack([np.arange(40, 0, -1), np.arange(39, -1, -1)], axis=1)
    assert (connected_pieces(42, chain)[:41] == 0).all() and connected_pieces(42, chain)[41] == 41
