"""The training / validation blocks of a diagnosis (:mod:`stictionbench.diagnosis.blocks`)
and their use by ``diagnose``: the shipped layout unchanged, the one-sided layouts as
their docstring says, bad arguments refused."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from stictionbench.diagnosis import diagnose
from stictionbench.diagnosis.blocks import LAYOUTS, N_BLOCKS, split_blocks

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "experiments"))
sys.path.insert(0, str(Path(__file__).resolve().parent))

from fopdt_record import fopdt_record  # noqa: E402


@pytest.mark.parametrize("layout", LAYOUTS)
@pytest.mark.parametrize("n_blocks", (2, 3, 5, 9))
def test_every_row_after_the_burn_in_is_fitted_or_judged_never_both(layout, n_blocks):
    b = split_blocks(3001, 137, n_blocks, layout)
    both = np.concatenate([b.train, b.val])
    assert np.array_equal(np.sort(both), np.arange(137, 3001))
    assert np.intersect1d(b.train, b.val).size == 0
    assert b.edges[0] == 137 and b.edges[-1] == 3001 and b.edges.size == n_blocks + 1
    # the knots are block edges that bound the training rows
    assert set(b.knot_edges.tolist()) <= set(b.edges.tolist())
    assert b.knot_edges[0] <= b.train.min() and b.knot_edges[-1] >= b.train.max()


def test_interleaved_is_the_shipped_split_and_the_one_sided_layouts_forecast():
    n, burn = 3000, 100
    edges = np.linspace(burn, n, N_BLOCKS + 1).round().astype(int)
    blocks = [np.arange(edges[i], edges[i + 1]) for i in range(N_BLOCKS)]
    b = split_blocks(n, burn)
    # the split the diagnosis made before the layouts existed, row for row
    assert np.array_equal(b.train, np.concatenate(blocks[0::2]))
    assert np.array_equal(b.val, np.concatenate(blocks[1::2]))
    assert np.array_equal(b.knot_edges, edges)
    tf = split_blocks(n, burn, layout="train_first")
    assert tf.train.max() < tf.val.min()                 # judged after the fitted span
    assert np.array_equal(tf.knot_edges, edges[:4])       # no knot inside validation
    vf = split_blocks(n, burn, layout="validation_first")
    assert vf.val.max() < vf.train.min()
    assert np.array_equal(vf.knot_edges, edges[2:])


@pytest.mark.parametrize("kwargs, match", [({"layout": "random"}, "layout"),
                                           ({"n_blocks": 1}, "n_blocks"),
                                           ({"n_blocks": 2.5}, "n_blocks")])
def test_bad_splits_are_refused(kwargs, match):
    with pytest.raises(ValueError, match=match):
        split_blocks(1000, 10, **kwargs)


def test_diagnose_uses_the_layout_it_is_given():
    rec, model = fopdt_record()
    shipped = diagnose(rec, model, detectability=False)
    again = diagnose(rec, model, detectability=False, n_blocks=5, block_layout="interleaved")
    assert shipped.missing_physics == again.missing_physics
    assert shipped.val_blocks == again.val_blocks
    assert len(shipped.val_blocks) == 2
    tf = diagnose(rec, model, detectability=False, block_layout="train_first")
    # the last two blocks, adjacent: one validation window, to the record's end
    assert len(tf.val_blocks) == 1
    assert tf.val_blocks[0][1] == float(rec.t[-1])
    assert tf.val_blocks[0][0] > shipped.val_blocks[0][1]
    with pytest.raises(ValueError, match="block_layout"):
        diagnose(rec, model, block_layout="shuffled")


def test_the_second_look_judges_on_the_blocks_of_the_main_comparison():
    # the slow-line look re-compares in a wider band; it must keep the layout it was
    # given (it fell back to five interleaved blocks before 2026-12-02)
    from types import SimpleNamespace

    from stictionbench.diagnosis.diagnose import compare, second_look

    rec, model = fopdt_record()
    cmp = compare(rec, model, n_blocks=3, block_layout="train_first")
    look = second_look(cmp, SimpleNamespace(pick="none"))
    assert look is not None
    assert (look.cmp.n_blocks, look.cmp.block_layout) == (3, "train_first")
    assert np.array_equal(look.cmp.prob.val, cmp.prob.val)
    assert np.array_equal(look.cmp.prob.train, cmp.prob.train)

def _frame() -> pd.DataFrame:
    """A hand-made block_layout table: two healthy loops and one disturbance per generator;
    the healthy loop h1 is a line only under the shipped layout."""
    import block_layout as bl

    rows = []
    for gen, s in (("A", "a"), ("C", "c")):
        for v in bl.VARIANTS:
            line = v == bl.SHIPPED
            rows.append({"generator": gen, "set": s, "name": f"h1{gen}", "level": 1,
                         "class": "none", "variant": v,
                         "predicted": bl.LINE if line else "none", "line_p": 0.001,
                         "line_improvement": 0.05, "line_period": 900.0, "band_dof": 30.0,
                         "stored": bl.LINE})
            rows.append({"generator": gen, "set": s, "name": f"h2{gen}", "level": 2,
                         "class": "none", "variant": v, "predicted": "none",
                         "line_p": 0.5, "line_improvement": 0.0, "line_period": 50.0,
                         "band_dof": 200.0, "stored": "none"})
            if v in bl.LAYOUT_VARIANTS:
                rows.append({"generator": gen, "set": s, "name": f"o1{gen}", "level": 1,
                             "class": bl.LINE, "variant": v, "predicted": bl.LINE,
                             "line_p": 1e-6, "line_improvement": 0.2, "line_period": 80.0,
                             "band_dof": 150.0, "stored": bl.LINE})
    return pd.DataFrame(rows)


def test_the_report_counts_the_shipped_line_alarms_and_the_predictions():
    import block_layout as bl

    df = _frame()
    text = bl.report(df, (6, 6))
    assert "on 6 of 6 recordings" in text
    # both h1 loops go under every other variant: predictions 1 and 2 hold
    assert "without the load 2 of the 2 line false alarms go (2 to `none`)" in text
    assert "Held." in text and "The false-alarm half held" in text
    assert "held for `train_first` on generator A" in text
    # no shipped alarm survives 3 or 9 blocks: prediction 3 fails
    assert "Not held: fewer than half survive" in text
    table = bl.summary(bl._flags(df))
    row = table[(table.variant == bl.SHIPPED) & (table.generator == "both")].iloc[0]
    assert row["healthy called a line"].startswith("2/4")
    assert row["of them slow loops"] == "2"
    tf = table[(table.variant == "train_first") & (table.generator == "both")].iloc[0]
    assert tf["line only here / only shipped"].startswith("0 / 2")
    assert tf["disturbances named, level 1"].startswith("2/2")


def test_a_surviving_line_alarm_is_reported_as_a_failed_prediction():
    import block_layout as bl

    df = _frame()
    keep = (df.name == "h1A") & (df.variant == "no_load")
    df.loc[keep, "predicted"] = bl.LINE
    text = bl.report(df, (6, 6))
    assert "Not held: some survive without the load." in text


def test_prediction_four_reads_the_wander_rows_when_they_are_there():
    import block_layout as bl

    df = _frame()
    assert "Prediction 4" not in bl.report(df, (6, 6))
    extra = []
    for v, named in (("train_first", "none"), ("no_wander", bl.LINE),
                     ("no_wander+train_first", bl.LINE)):
        extra.append({"generator": "C", "set": "c", "name": "o2C", "level": 1,
                      "class": bl.LINE, "variant": v, "predicted": named, "line_p": 1e-6,
                      "line_improvement": 0.2, "line_period": 80.0, "band_dof": 150.0,
                      "stored": bl.LINE})
    extra.append({**extra[0], "variant": "interleaved", "predicted": bl.LINE})
    df = pd.concat([df, pd.DataFrame(extra)], ignore_index=True)
    text = bl.report(df, (6, 6))
    # only the re-made recording is counted: lost to the forecast as recorded, not without
    assert "generator C's 1 disturbances named 1 interleaved → 0 forecast as recorded, " \
        "1 → 1 without the wander" in text
    assert "Prediction 4 (the wander)" in text and "Held: without the wander" in text
    table = bl.wander_table(bl._flags(df))
    assert table.set_index("variant").loc["no_wander", "both"].startswith("1/1")
