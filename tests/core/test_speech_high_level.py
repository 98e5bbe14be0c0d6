"""FAP 1 and FAP 2 -> low-level FAPs: the standard's blend and intensities, worked by hand on small tables, the
override rule for transmitted low-level FAPs, the real Greta file, and refused field values."""

from pathlib import Path

import numpy as np
import pytest

from addon.mpeg4.fap_file import read_fap
from addon.mpeg4.faps import Expression, Viseme
from addon.speech import SpeechError
from addon.speech.high_level import apply_high_level, expression_values
from addon.speech.tables import ShapeTable, load_expressions, load_visemes

GRETA = Path(__file__).resolve().parents[3] / "shared" / "interop" / "fap" / "isir_greta" / "1-Welcome_1.fap"


def table(enum, rows: dict) -> ShapeTable:
    targets = np.zeros((len(enum), 68))
    for row, faps in rows.items():
        for number, value in faps.items():
            targets[row, number - 1] = value
    faps = np.flatnonzero(targets.any(axis=0)) + 1
    return ShapeTable(tuple(m.name for m in enum), targets, faps, ("",) * len(enum))


VISEMES = table(Viseme, {Viseme.PP: {3: 100, 4: 60}, Viseme.AA: {3: 600, 17: 30}})
EXPRESSIONS = table(Expression, {Expression.JOY: {3: 120, 6: 150}, Expression.SURPRISE: {3: 550, 31: 300}})


def stream(n_frames=2):
    return (
        np.zeros((n_frames, 68), bool),
        np.zeros((n_frames, 68)),
        np.zeros((n_frames, 4)),
        np.zeros((n_frames, 6)),
    )


def test_hand_worked_frame_blends_visemes_adds_expressions_and_keeps_transmitted_faps():
    mask, values, viseme, expression = stream()
    mask[0, [0, 1, 3]] = True  # FAP 1, FAP 2 and lower_t_midlip (FAP 4) transmitted in frame 0
    values[0, 3] = -10.0
    viseme[0] = (Viseme.PP, Viseme.AA, 21, 0)  # 21/63 = 1/3 PP + 2/3 AA
    expression[0] = (Expression.JOY, 63, Expression.SURPRISE, 21, 0, 0)  # all of joy + 1/3 of surprise
    out_mask, out = apply_high_level(mask, values, viseme, expression, visemes=VISEMES, expressions=EXPRESSIONS)

    # open_jaw: 100/3 + 600 * 2/3 (visemes) + 120 + 550/3 (expressions) = 433.33 + 303.33
    assert out[0, 2] == pytest.approx(100 / 3 + 400 + 120 + 550 / 3, abs=1e-12)
    assert out[0, 2] == pytest.approx(736.6666666666667, abs=1e-9)
    assert out[0, 16] == pytest.approx(20.0)  # push_t_lip: 30 * 2/3
    assert out[0, 5] == pytest.approx(150.0)  # stretch_l_cornerlip: joy
    assert out[0, 30] == pytest.approx(100.0)  # raise_l_i_eyebrow: 300 / 3
    assert out[0, 3] == -10.0  # transmitted lower_t_midlip wins over the viseme's 60/3
    assert set(np.flatnonzero(out_mask[0]) + 1) == {1, 2, 3, 4, 6, 17, 31}
    # frame 1 transmits nothing: unchanged, so the importer's hold keeps frame 0's values
    assert not out_mask[1].any() and not out[1].any()
    assert not mask[0, 2] and values[0, 2] == 0  # the inputs are not modified


def test_blend_63_plays_select1_and_blend_0_plays_select2_with_the_real_tables():
    visemes = load_visemes()
    mask, values, viseme, expression = stream(2)
    mask[:, 0] = True
    viseme[0] = (Viseme.OU, Viseme.AA, 63, 0)
    viseme[1] = (Viseme.OU, Viseme.AA, 0, 0)
    _, out = apply_high_level(mask, values, viseme, expression)
    columns = visemes.faps - 1
    np.testing.assert_array_equal(out[0, columns], visemes.targets[Viseme.OU, columns])
    np.testing.assert_array_equal(out[1, columns], visemes.targets[Viseme.AA, columns])


def test_expression_intensity_scales_linearly_and_two_expressions_add():
    expressions = load_expressions()
    mask, values, viseme, expression = stream(1)
    mask[0, 1] = True
    expression[0] = (Expression.SADNESS, 42, Expression.ANGER, 21, 0, 0)
    _, out = apply_high_level(mask, values, viseme, expression)
    expected = expressions.targets[Expression.SADNESS] * 42 / 63 + expressions.targets[Expression.ANGER] / 3
    np.testing.assert_allclose(out[0, expressions.faps - 1], expected[expressions.faps - 1], atol=1e-12)


@pytest.mark.skipif(not GRETA.is_file(), reason=f"the shared interop file {GRETA} is not on this machine")
def test_the_real_greta_file_with_a_one_integer_fap1_decodes():
    greta = read_fap(GRETA)
    assert greta.mask[0, 0] and greta.viseme[0].tolist() == [0, 0, 0, 0]
    mask, values = apply_high_level(
        greta.mask, greta.values, greta.viseme, greta.expression, frame_numbers=greta.frame_numbers
    )
    visemes = load_visemes()
    assert set(np.flatnonzero(mask[0]) + 1) == {1, *visemes.faps.tolist()}
    assert not values.any()  # select2 = 0 at blend 0: silence, the neutral mouth


@pytest.mark.parametrize(
    ("column", "fields", "message"),
    [
        (0, (15, 0, 63, 0), "frame 7: viseme_select1 = 15 is not an integer in 0..14"),
        (0, (1, 2.5, 63, 0), "frame 7: viseme_select2 = 2.5 is not an integer"),
        (0, (1, 2, 64, 0), "frame 7: viseme_blend = 64 is not a number in 0..63"),
        (0, (1, 2, np.nan, 0), "viseme_blend = nan"),
        (1, (7, 63, 0, 0, 0, 0), "frame 7: expression_select1 = 7 is not an integer in 0..6"),
        (1, (1, -1, 0, 0, 0, 0), "frame 7: expression_intensity1 = -1"),
        (1, (1, 63, 2, 70, 0, 0), "frame 7: expression_intensity2 = 70"),
    ],
)
def test_out_of_range_fields_are_refused_naming_the_frame(column, fields, message):
    mask, values, viseme, expression = stream(2)
    mask[1, column] = True
    (viseme if column == 0 else expression)[1] = fields
    with pytest.raises(SpeechError, match=message):
        apply_high_level(mask, values, viseme, expression, frame_numbers=np.array([6, 7]))


def test_fields_of_frames_that_do_not_transmit_fap1_or_2_are_not_read():
    mask, values, viseme, expression = stream(1)
    viseme[0] = (99, 99, 99, 0)
    out_mask, out = apply_high_level(mask, values, viseme, expression)
    assert not out_mask.any() and not out.any()


def test_expression_values_scale_a_table_row():
    expressions = load_expressions()
    np.testing.assert_array_equal(expression_values("joy", 0.5), expressions.targets[Expression.JOY] * 0.5)
    np.testing.assert_array_equal(expression_values(6, 1.0), expressions.targets[Expression.SURPRISE])
    with pytest.raises(SpeechError, match="unknown expression 'glee'"):
        expression_values("glee", 0.5)
    with pytest.raises(SpeechError, match="expression joy: weight 1.5 is not a number in 0..1"):
        expression_values("joy", 1.5)
