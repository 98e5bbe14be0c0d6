"""The speech tables: every viseme and expression is the shape phonetics and the standard describe, all values
stay within the FAP ranges, and a bad table file is refused naming the entry."""

import json

import numpy as np
import pytest

from addon.mpeg4.fap_tables import FAP_RANGE
from addon.mpeg4.faps import FAPS, Expression, Viseme, fap
from addon.speech import SpeechError
from addon.speech.tables import (
    RHUBARB_SHAPES,
    load_dominance,
    load_expressions,
    load_phonemes,
    load_rhubarb,
    load_visemes,
)

VISEMES = load_visemes()
EXPRESSIONS = load_expressions()
MOUTH = [n for n in range(3, 61) if fap(n).group in (2, 6, 8)]  # jaw, inner lip, tongue, outer lip


def value(table, row, name):
    return table.targets[row, fap(name).number - 1]


def gaps(shape, pairs=((4, 5), (8, 10), (9, 11))):
    """Inner lip gaps (MNS) at the middle and the two mid-lateral points; <= 0 = the lips touch (the neutral
    face has them in contact). With the outer lip pairs: how much closer the outer contour comes."""
    return np.array([shape[2] - shape[u - 1] - shape[lo - 1] for u, lo in pairs])


def test_fap_range_is_the_standards_intra_maximum_times_the_quantiser_step():
    assert FAP_RANGE[2] == 1080 * 4  # open_jaw
    assert FAP_RANGE[3] == 600 * 2  # lower_t_midlip
    assert FAP_RANGE[46] == 300 * 512  # tongue_roll, AU
    assert FAP_RANGE[0] == FAP_RANGE[1] == 0  # FAP 1/2 are not low-level values


@pytest.mark.parametrize("table", [VISEMES, EXPRESSIONS], ids=["visemes", "expressions"])
def test_values_stay_within_ranges_and_directions(table):
    assert np.all(np.abs(table.targets) <= FAP_RANGE)
    unidirectional = [f.number - 1 for f in FAPS if f.fapu and not f.bidirectional]
    assert np.all(table.targets[:, unidirectional] >= 0)
    assert not table.targets[:, :2].any()
    assert all(reason.strip() for reason in table.why[1:])


def test_silence_is_the_neutral_face_and_every_other_viseme_moves_the_mouth():
    assert not VISEMES.targets[Viseme.NONE].any()
    for viseme in list(Viseme)[1:]:
        assert np.any(VISEMES.targets[viseme, [n - 1 for n in MOUTH]] != 0), viseme.name
        assert not VISEMES.targets[viseme, [n - 1 for n in range(1, 69) if n not in MOUTH]].any(), viseme.name


def test_no_two_visemes_share_a_shape():
    shapes = VISEMES.targets
    distance = np.abs(shapes[:, None] - shapes[None]).max(axis=2)
    assert np.all(distance[~np.eye(len(Viseme), dtype=bool)] >= 20)


def test_bilabials_press_the_lips_together_and_every_other_viseme_parts_them():
    assert np.all(gaps(VISEMES.targets[Viseme.PP]) < 0)
    assert np.all(gaps(VISEMES.targets[Viseme.PP], ((51, 52), (55, 57), (56, 58))) < 0)  # pressed, not rolled
    for viseme in list(Viseme)[2:]:
        assert np.all(gaps(VISEMES.targets[viseme]) > 0), viseme.name


def test_labiodentals_lift_the_lower_lip_to_the_upper_teeth_and_pull_it_back():
    ff = VISEMES.targets[Viseme.FF]
    assert ff[4] - ff[2] > 0  # the lower lip ends above its neutral height (it rides the jaw)
    assert value(VISEMES, Viseme.FF, "push_b_lip") < 0
    assert value(VISEMES, Viseme.FF, "lower_t_midlip") < 0  # the upper lip clears the incisors
    assert 0 < gaps(ff)[0] < 60  # lip to teeth, not lip to lip


def test_rounded_sounds_protrude_and_narrow_spread_vowels_widen():
    for viseme in (Viseme.CH, Viseme.RR, Viseme.OH, Viseme.OU):
        assert value(VISEMES, viseme, "push_t_lip") > 0 and value(VISEMES, viseme, "push_b_lip") > 0
        assert value(VISEMES, viseme, "stretch_l_cornerlip") < 0 and value(VISEMES, viseme, "stretch_r_cornerlip") < 0
    assert value(VISEMES, Viseme.OU, "push_t_lip") == VISEMES.targets[:, 16].max()
    assert value(VISEMES, Viseme.IH, "stretch_l_cornerlip") == VISEMES.targets[:, 5].max()
    assert value(VISEMES, Viseme.IH, "push_t_lip") < 0


def test_vowel_openings_follow_vowel_height():
    jaw = {v: value(VISEMES, v, "open_jaw") for v in Viseme}
    assert jaw[Viseme.AA] == max(jaw.values())
    assert jaw[Viseme.AA] > jaw[Viseme.OH] > jaw[Viseme.E] > jaw[Viseme.IH]
    assert (
        gaps(VISEMES.targets[Viseme.AA])[0] > gaps(VISEMES.targets[Viseme.OH])[0] > gaps(VISEMES.targets[Viseme.OU])[0]
    )


def test_the_tongue_makes_the_consonants_it_should():
    assert value(VISEMES, Viseme.TH, "thrust_tongue_tip") > 0  # between the teeth
    for viseme in (Viseme.DD, Viseme.NN, Viseme.SS, Viseme.CH):
        assert value(VISEMES, viseme, "raise_tongue_tip") >= 350, viseme.name
    assert value(VISEMES, Viseme.KK, "raise_tongue") == VISEMES.targets[:, 45].max()
    assert value(VISEMES, Viseme.KK, "raise_tongue_tip") < 0


def test_each_expression_has_its_standard_description():
    e = EXPRESSIONS
    assert not e.targets[Expression.NEUTRAL].any()
    assert all(e.targets[x].any() for x in list(Expression)[1:])
    # joy: corners back and up, cheeks lift the lower lids, brows relaxed
    assert value(e, Expression.JOY, "stretch_l_cornerlip") > 0 and value(e, Expression.JOY, "raise_r_cornerlip_o") > 0
    assert value(e, Expression.JOY, "close_b_l_eyelid") > 0
    assert not e.targets[Expression.JOY, 30:38].any()
    # sadness: inner brows up, outer down, lids droop, corners down
    assert value(e, Expression.SADNESS, "raise_l_i_eyebrow") > 0 > value(e, Expression.SADNESS, "raise_l_o_eyebrow")
    assert value(e, Expression.SADNESS, "close_t_r_eyelid") > 0
    assert value(e, Expression.SADNESS, "raise_l_cornerlip_o") < 0
    # anger: brows down and together, eyes wide, lips pressed
    assert value(e, Expression.ANGER, "raise_r_i_eyebrow") < 0 and value(e, Expression.ANGER, "squeeze_l_eyebrow") > 0
    assert value(e, Expression.ANGER, "close_t_l_eyelid") < 0
    assert gaps(e.targets[Expression.ANGER])[0] < 0
    # fear: brows up and together (inner bent up), eyes wide
    fear_brows = [value(e, Expression.FEAR, n) for n in ("raise_l_i_eyebrow", "raise_l_m_eyebrow", "raise_l_o_eyebrow")]
    assert fear_brows[0] > fear_brows[1] > fear_brows[2] > 0
    assert value(e, Expression.FEAR, "squeeze_r_eyebrow") > 0 and value(e, Expression.FEAR, "close_t_r_eyelid") < 0
    # disgust: upper lip raised, more on one side; nose wrinkled
    assert value(e, Expression.DISGUST, "lower_t_midlip") < 0
    assert value(e, Expression.DISGUST, "lower_t_lip_lm") < value(e, Expression.DISGUST, "lower_t_lip_rm")
    assert value(e, Expression.DISGUST, "raise_nose") > 0
    # surprise: brows up, upper lids up, lower lids relaxed, jaw open
    assert min(value(e, Expression.SURPRISE, f"raise_{s}_{p}_eyebrow") for s in "lr" for p in "imo") > 0
    assert (
        value(e, Expression.SURPRISE, "close_t_l_eyelid") < 0 and value(e, Expression.SURPRISE, "close_b_l_eyelid") == 0
    )
    assert value(e, Expression.SURPRISE, "open_jaw") >= 500


def test_left_and_right_match_except_where_the_standard_says_asymmetric():
    from addon.mpeg4.faps import LEFT_RIGHT_PAIRS

    for table, rows in ((VISEMES, list(Viseme)), (EXPRESSIONS, [x for x in Expression if x != Expression.DISGUST])):
        for row in rows:
            for left, right in LEFT_RIGHT_PAIRS:
                assert table.targets[row, left - 1] == table.targets[row, right - 1], (row, left)


def test_dominance_lets_consonants_yield_rounding_and_bilabials_own_lip_opening():
    d = load_dominance()
    assert set(d.groups) == {"jaw", "lip_opening", "lip_corners", "protrusion", "tongue"}
    grouped = {n for numbers in d.groups.values() for n in numbers}
    assert set(VISEMES.faps) <= grouped
    lips, push = 3, 15  # columns of FAP 4 (lip opening) and FAP 16 (protrusion)
    assert d.alpha[Viseme.PP, lips] == d.alpha[:, lips].max()
    plain_consonants = [Viseme.PP, Viseme.TH, Viseme.DD, Viseme.KK, Viseme.SS, Viseme.NN]
    assert max(d.alpha[v, push] for v in plain_consonants) < min(d.alpha[v, push] for v in (Viseme.OH, Viseme.OU))
    assert d.theta_before[Viseme.OU, push] < d.theta_after[Viseme.OU, push]  # rounding is anticipated
    assert np.all(d.exponent == 1.0)  # the paper's c


def test_phoneme_table_covers_espeak_english_names():
    table = load_phonemes()
    names = (
        "p b m f v T D t d t# k g N x tS dZ S Z s z n l r r- w j ; h ? "
        "a aa A: A@ V E e@ @ 3 3: I I2 i i: 0 O: O@ o@ U u: aI aU oU eI OI i@ U@ aI@ @L"
    ).split()
    assert [n for n in names if table.lookup(n) is None] == []
    assert table.lookup("'oU") == (Viseme.E, Viseme.OU)  # stress mark removed, diphthong in two parts
    assert table.lookup(",aI") == (Viseme.AA, Viseme.IH)
    assert table.lookup("_:") == (Viseme.NONE,) and table.lookup("_!") == (Viseme.NONE,)
    assert table.lookup("h") == ()
    assert table.lookup("p") == (Viseme.PP,) and table.lookup("u:") == (Viseme.OU,)
    assert table.lookup("qq") is None


def test_rhubarb_shapes_map_to_the_visemes_they_draw():
    table = load_rhubarb()
    assert tuple(table) == RHUBARB_SHAPES
    assert table == {
        "A": Viseme.PP, "B": Viseme.SS, "C": Viseme.E, "D": Viseme.AA, "E": Viseme.OH,
        "F": Viseme.OU, "G": Viseme.FF, "H": Viseme.NN, "X": Viseme.NONE,
    }  # fmt: skip


def _viseme_doc():
    from addon.speech.tables import DATA

    return json.loads((DATA / "visemes.json").read_text())


@pytest.mark.parametrize(
    ("change", "message"),
    [
        (lambda d: d["visemes"][1]["faps"].update(open_jawx=1), "viseme PP: unknown FAP 'open_jawx'"),
        (lambda d: d["visemes"][1]["faps"].update(open_jaw=5000), "'open_jaw' = 5000 is outside"),
        (lambda d: d["visemes"][1]["faps"].update(open_jaw=-10), "negative but the FAP is unidirectional"),
        (lambda d: d["visemes"][1]["faps"].update(viseme=1), "high-level"),
        (lambda d: d["visemes"][2].update(viseme=1), "viseme 1 is listed twice"),
        (lambda d: d["visemes"].pop(), "must list 15 entries"),
        (lambda d: d["visemes"][0]["faps"].update(open_jaw=10), "NONE must be the neutral face"),
        (lambda d: d["visemes"][3].update(name="PP"), "viseme 3 is TH, not 'PP'"),
        (lambda d: d["visemes"][4].update(why=""), "viseme DD: 'why'"),
        (lambda d: d["visemes"][4]["faps"].update(open_jaw=True), "True is not a finite number"),
    ],
)
def test_a_bad_viseme_table_is_refused_naming_the_entry(tmp_path, change, message):
    doc = _viseme_doc()
    change(doc)
    path = tmp_path / "visemes.json"
    path.write_text(json.dumps(doc))
    with pytest.raises(SpeechError, match=message.replace("(", r"\(")):
        load_visemes(path)


def test_json_traps_are_refused(tmp_path):
    path = tmp_path / "t.json"
    path.write_text('{"about": "x", "about": "y", "visemes": []}')
    with pytest.raises(SpeechError, match="key 'about' appears twice"):
        load_visemes(path)
    path.write_text('{"about": "x", "visemes": [{"faps": {"open_jaw": NaN}}]}')
    with pytest.raises(SpeechError, match="NaN is not a number"):
        load_visemes(path)
    path.write_text('{"about": ')
    with pytest.raises(SpeechError, match="the visemes table: line 1, column 11: not valid JSON"):
        load_visemes(path)
    with pytest.raises(SpeechError, match="cannot read"):
        load_visemes(tmp_path / "missing.json")


def test_a_bad_dominance_table_is_refused(tmp_path):
    from addon.speech.tables import DATA

    doc = json.loads((DATA / "dominance.json").read_text())
    doc["visemes"][1]["lip_opening"]["alpha"] = 0
    path = tmp_path / "d.json"
    path.write_text(json.dumps(doc))
    with pytest.raises(SpeechError, match="viseme PP: lip_opening: alpha = 0 must be positive"):
        load_dominance(path)
    doc = json.loads((DATA / "dominance.json").read_text())
    doc["groups"]["tongue"]["faps"].append(4)
    path.write_text(json.dumps(doc))
    with pytest.raises(SpeechError, match="FAP 4 is already in group 'lip_opening'"):
        load_dominance(path)
    doc = json.loads((DATA / "dominance.json").read_text())
    del doc["visemes"][5]
    path.write_text(json.dumps(doc))
    with pytest.raises(SpeechError, match="viseme KK must be listed once, found 0"):
        load_dominance(path)


def test_a_bad_phoneme_table_is_refused(tmp_path):
    path = tmp_path / "p.json"
    path.write_text(json.dumps({"about": "x", "groups": [{"visemes": ["QQ"], "phonemes": ["p"], "why": "w"}]}))
    with pytest.raises(SpeechError, match="unknown viseme 'QQ'"):
        load_phonemes(path)
    doc = {"about": "x", "groups": [{"visemes": ["PP"], "phonemes": ["p", "p"], "why": "w"}]}
    path.write_text(json.dumps(doc))
    with pytest.raises(SpeechError, match="phoneme 'p' is listed twice"):
        load_phonemes(path)


def test_default_tables_are_read_only():
    with pytest.raises(ValueError, match="read-only"):
        VISEMES.targets[1, 2] = 0
    with pytest.raises(TypeError):
        load_phonemes().visemes["p"] = ()
