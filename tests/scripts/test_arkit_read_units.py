"""Reading recipes from units' FP motion (`scripts.bench.arkit_read_units`), on hand-made units: FP motions made
from known FAP values are read back as those values."""

import numpy as np
import pytest

from addon.arkit.recipes import mirror_faps
from addon.mpeg4.faps import N_FAPS, fap
from addon.mpeg4.fapu import Fapu
from addon.mpeg4.feature_points import FP_IDS
from scripts.bench.arkit_read_units import (
    READABLE_FAPS,
    disjoint_groups,
    fap_bounds,
    fap_motion_basis,
    free_faps,
    held_faps,
    held_out_tables,
    read_recipes,
)

FAPU = Fapu(IRISD0=0.011, ES0=0.063, ENS0=0.045, MNS0=0.018, MW0=0.052)  # metres, an adult's sizes
SKIN = tuple(f for f in FP_IDS if f.split(".")[0] in ("2", "3", "4", "5", "8", "9"))


def values(**named) -> np.ndarray:
    out = np.zeros(N_FAPS)
    for name, value in named.items():
        out[fap(name).number - 1] = value
    return out


def motion(basis: np.ndarray, *recipes: np.ndarray) -> np.ndarray:
    return np.einsum("k,kmc->mc", sum(recipes), basis)


KNOWN = {
    "eyeBlinkLeft": values(close_t_l_eyelid=900, close_b_l_eyelid=60),
    "jawOpen": values(open_jaw=1000, depress_chin=40),
    "mouthSmileLeft": values(
        raise_l_cornerlip=500, stretch_l_cornerlip=120, raise_l_cornerlip_o=480, raise_b_midlip=-30
    ),
    "mouthLeft": values(stretch_l_cornerlip=150, stretch_r_cornerlip=-140),
}


def known(name: str) -> np.ndarray:
    return KNOWN[name] if name in KNOWN else mirror_faps(KNOWN[name.replace("Right", "Left")])


@pytest.fixture(scope="module")
def basis():
    return fap_motion_basis(FAPU, SKIN)


def hand_made_pairs(basis):
    return [
        (("eyeBlinkLeft",), motion(basis, known("eyeBlinkLeft"))),
        (("eyeBlinkRight",), motion(basis, known("eyeBlinkRight"))),
        (("jawOpen",), motion(basis, known("jawOpen"))),
        (("mouthSmileLeft", "mouthSmileRight"), motion(basis, known("mouthSmileLeft"), known("mouthSmileRight"))),
        (("mouthLeft",), motion(basis, known("mouthLeft"))),
        (("mouthRight",), motion(basis, known("mouthRight"))),
    ]


def test_the_basis_moves_each_fap_s_fp_along_its_axis_by_its_fapu_and_open_jaw_its_riders(basis):
    row = {f: i for i, f in enumerate(SKIN)}
    blink = basis[fap("close_t_l_eyelid").number - 1]
    assert np.allclose(blink[row["3.1"]], [0.0, 0.0, -FAPU.IRISD0 / 1024])  # down is -z in Blender's head frame
    assert np.count_nonzero(np.linalg.norm(blink, axis=1)) == 1
    jaw = basis[fap("open_jaw").number - 1]
    assert np.allclose(jaw[row["2.1"]], [0.0, 0.0, -FAPU.MNS0 / 1024])
    assert np.allclose(jaw[row["2.4"]], 0.5 * jaw[row["2.1"]])  # the corners ride half
    assert not np.any(basis[fap("yaw_l_eyeball").number - 1])  # not read: a rotation
    assert fap("thrust_l_eyeball").number not in READABLE_FAPS


def test_units_made_from_known_values_are_read_back_exactly(basis):
    prior = {name: np.zeros(N_FAPS) for name in ("eyeBlinkLeft", "jawOpen", "mouthSmileLeft", "mouthLeft")}
    prior |= {n.replace("Left", "Right"): p for n, p in prior.items() if "Left" in n}
    read = read_recipes(hand_made_pairs(basis), basis, prior)
    for name in ("eyeBlinkLeft", "eyeBlinkRight", "jawOpen", "mouthSmileLeft", "mouthSmileRight", "mouthLeft"):
        np.testing.assert_allclose(read[name], known(name), atol=0.05, err_msg=name)
    np.testing.assert_allclose(read["mouthRight"], mirror_faps(read["mouthLeft"]))


def test_a_bilateral_unit_splits_by_side_and_halves_the_midline(basis):
    free = free_faps(hand_made_pairs(basis), basis)
    right_corner = fap("raise_r_cornerlip").number - 1
    assert not free["mouthSmileLeft"][right_corner]  # shown only with its twin: its own side and the midline
    assert free["mouthLeft"][right_corner]  # mouthLeft has a unit of its own: both corners read
    assert free["eyeBlinkLeft"][fap("close_t_r_eyelid").number - 1]


def test_a_fap_no_unit_constrains_keeps_the_table_s_value(basis):
    prior = {"jawOpen": values(open_jaw=1220, lift_l_cheek=100, lift_r_cheek=100)}
    pairs = [(("jawOpen",), motion(basis, known("jawOpen")))]
    free = {"jawOpen": np.ones(N_FAPS, bool)}
    free["jawOpen"][[fap("lift_l_cheek").number - 1, fap("lift_r_cheek").number - 1]] = False
    read = read_recipes(pairs, basis, prior, free)
    assert read["jawOpen"][fap("lift_l_cheek").number - 1] == 100
    assert abs(read["jawOpen"][fap("open_jaw").number - 1] - 1000) < 0.05


def test_bounds_keep_unidirectional_faps_non_negative(basis):
    lower, upper = fap_bounds()
    assert lower[fap("open_jaw").number - 1] == 0 and lower[fap("raise_b_midlip").number - 1] < 0
    pairs = [(("jawOpen",), -motion(basis, values(open_jaw=300)))]  # a jaw that closes past rest
    read = read_recipes(pairs, basis, {"jawOpen": np.zeros(N_FAPS)})
    assert 0.0 <= read["jawOpen"][fap("open_jaw").number - 1] < 1e-6


def test_held_out_reads_left_from_the_right_twin_and_keeps_a_lone_unit_s_prior(basis):
    pairs = hand_made_pairs(basis)
    prior = {name: np.full(N_FAPS, 0.0) for name in ("eyeBlinkLeft", "jawOpen", "mouthSmileLeft", "mouthLeft")}
    prior |= {n.replace("Left", "Right"): p for n, p in prior.items() if "Left" in n}
    prior["jawOpen"] = values(open_jaw=1220)
    held = held_out_tables(pairs, basis, prior)
    np.testing.assert_allclose(held[0]["eyeBlinkLeft"], known("eyeBlinkLeft"), atol=0.05)  # from the Right unit
    np.testing.assert_array_equal(held[2]["jawOpen"], prior["jawOpen"])  # no other pair shows it


def test_held_faps_are_those_whose_every_fp_the_key_leaves_still(basis):
    row = {f: i for i, f in enumerate(SKIN)}
    key = np.zeros((len(SKIN), 3))
    key[row["2.3"]] = [0.0, 0.0, -0.004]  # the lower lip's middle moves 4 mm, the chin stays
    held = held_faps(key, basis)
    assert not held[fap("raise_b_midlip").number - 1]
    assert not held[fap("open_jaw").number - 1]  # its rider 2.3 moves
    assert held[fap("depress_chin").number - 1]
    assert not held[fap("yaw_l_eyeball").number - 1]  # moves no FP here: not read


def test_disjoint_groups_share_no_name():
    assert disjoint_groups([("a",), ("a", "b"), ("c",), ("b",)]) == [[0, 2, 3], [1]]


def test_read_about_the_keys_discounts_what_the_keys_move_beyond_their_faps(basis):
    from scripts.bench.arkit_read_units import about_keys

    row = {f: i for i, f in enumerate(SKIN)}
    extra = np.zeros((len(SKIN), 3))
    extra[row["2.3"], 1] = 0.003  # a deformation's motion along push_b_lip's axis (the lip swung back, +y)
    table = values(open_jaw=1220)
    keys = {"jawOpen": motion(basis, table) + extra}
    unit = motion(basis, known("jawOpen")) + extra  # the unit shows the same swing
    pairs = about_keys([(("jawOpen",), unit)], keys, basis, {"jawOpen": table})
    read = read_recipes(pairs, basis, {"jawOpen": table})
    np.testing.assert_allclose(read["jawOpen"], known("jawOpen"), atol=0.05)
    plain = read_recipes([(("jawOpen",), unit)], basis, {"jawOpen": table})
    assert plain["jawOpen"][fap("push_b_lip").number - 1] < -100  # read plainly, the swing becomes a FAP
