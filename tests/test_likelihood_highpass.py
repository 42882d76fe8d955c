"""The likelihood tests' high-pass (``openloop.likelihood_highpass``, ``diagnose
--test-highpass-order``) and ``experiments/likelihood_highpass.py``'s summary."""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

import stictionbench as sb
from stictionbench.diagnosis import NominalModel, diagnose
from stictionbench.diagnosis.diagnose import compare
from stictionbench.diagnosis.evidence import output_error
from stictionbench.diagnosis.noise import fit_noise_model
from stictionbench.diagnosis.openloop import comparison_band, likelihood_highpass

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "experiments"))

import likelihood_highpass as lh  # noqa: E402

NOM = NominalModel(3.0, 10.0, 10.0, 0.2, 10.0, 1.0)
MODEL_YAML = ("process: {gain: 3.0, time_constant: 10.0, dead_time: 10.0}\n"
              "controller: {kc: 0.2, ti: 10.0}\nsample_time: 1.0\n")


def test_orders_zero_and_one():
    x = np.arange(400.0)
    # a ramp through a first-order high-pass settles at slope / (2 pi f_c)
    assert likelihood_highpass(x, 1.0, 0.02, 1)[-1] == pytest.approx(1 / (2 * np.pi * 0.02),
                                                                       rel=0.02)
    y = likelihood_highpass(x, 1.0, 0.02, 0)
    assert y.mean() == pytest.approx(0.0, abs=1e-9) and np.allclose(np.diff(y), 1.0)
    # causal: nothing before a step
    step = np.r_[np.zeros(50), np.ones(50)]
    assert np.allclose(likelihood_highpass(step, 1.0, 0.05, 1)[:50], 0.0)
    with pytest.raises(ValueError, match="order"):
        likelihood_highpass(x, 1.0, 0.02, 2)


def test_unfiltered_random_walk_gets_an_integrated_noise_model():
    # the series a drifting load leaves: unfiltered, the noise model differences it
    # itself; after the comparison band's two zeros at DC it is never integrated
    rng = np.random.default_rng(3)
    x = np.cumsum(rng.standard_normal(3000)) + 0.3 * rng.standard_normal(3000)
    assert fit_noise_model(likelihood_highpass(x, 1.0, 0.01, 0)[:2000]).integrated
    assert not fit_noise_model(comparison_band(x, 1.0, 0.01)[:2000]).integrated


@pytest.fixture(scope="module")
def sticky():
    return sb.simulate("linear", duration=3000.0, seed=4, sample_time=1.0, sensor="noisy",
                       valve="physical", valve__Fs=120.0, valve__Fc=65.0,
                       controller__sample_time=1.0, sensor__noise_std=0.05,
                       sensor__time_constant=0.0)


def test_output_error_of_order_two_is_the_band(sticky):
    cmp = compare(sticky, NOM)
    ft = cmp.nominal
    band = output_error(ft, cmp.ctx.pv, cmp.ctx.Ts, cmp.prob.f_hp)
    assert np.array_equal(band, output_error(ft, cmp.ctx.pv, cmp.ctx.Ts, cmp.prob.f_hp, 2))
    raw = output_error(ft, cmp.ctx.pv, cmp.ctx.Ts, cmp.prob.f_hp, 0)
    assert raw.shape == band.shape and not np.allclose(raw, band)
    assert raw.mean() == pytest.approx(0.0, abs=1e-9)


def test_a_large_sticky_valve_is_named_under_every_order(sticky):
    for order in (2, 1, 0):
        d = diagnose(sticky, NOM, test_highpass_order=order)
        assert d.details["test_highpass_order"] == order
        assert d.missing_physics == "stiction"
    with pytest.raises(ValueError, match="test_highpass_order"):
        diagnose(sticky, NOM, test_highpass_order=3)


def test_the_command_takes_the_order(tmp_path, sticky, capsys):
    from stictionbench.cli import main
    from stictionbench.io import write_recording

    csv = tmp_path / "r.csv"
    write_recording(sticky, csv)
    model = tmp_path / "m.yaml"
    model.write_text(MODEL_YAML)
    out = tmp_path / "d.json"
    assert main(["diagnose", str(csv), "--model", str(model), "--json", str(out),
                 "--test-highpass-order", "0"]) == 0
    assert json.loads(out.read_text())["details"]["test_highpass_order"] == 0
    capsys.readouterr()
    bad = tmp_path / "bad.json"
    assert main(["diagnose", str(csv), "--json", str(bad), "--test-highpass-order", "1"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--test-highpass-order needs --model" in err[0]
    assert not bad.exists()


def test_summary_scores_and_counts():
    rows = [("none", "none", "none", "none"), ("none", "deadband", "deadband", "none"),
            ("stiction", "stiction", "stiction", "none"),
            ("stiction", "stiction", "none", "stiction")]
    df = pd.DataFrame([{"part": lh.PARTS[1], "level": 1, "class": c, "order_2": a,
                        "order_1": b, "order_0": z} for c, a, b, z in rows])
    row = lh.summary(df).iloc[0]
    # order 2: none 1/2, stiction 2/2 -> 16 x 3/4 = 12.0; order 0: none 2/2, stiction 1/2
    assert row["named right of 16, order 2"].startswith("12.0 [")
    assert row["named right of 16, order 0"].startswith("12.0 [")
    assert row["named right of 16, order 1"].startswith("8.0 [")
    assert row["healthy called physics, order 2"].startswith("1/2")
    assert row["healthy called physics, order 0"].startswith("0/2")
    assert row["right only with order 0 / only order 2"].startswith("1 / 1")
    assert lh.part_of("c") == lh.PARTS[0] and lh.part_of("j") == lh.PARTS[1]
    assert lh.part_of("k") == lh.PARTS[2] and lh.part_of("holdout") == lh.PARTS[3]


def test_drift_table_sets_recorded_beside_remade():
    rec = pd.DataFrame([{"group": lh.DRIFT_SET, "level": 1, "class": c, "order_2": a,
                         "order_0": b}
                        for c, a, b in [("none", "stiction", "none"),
                                        ("stiction", "stiction", "none")]])
    remade = pd.DataFrame([{"level": 1, "class": c, "order_2": a, "order_0": b}
                           for c, a, b in [("none", "none", "none"),
                                           ("stiction", "stiction", "stiction")]])
    t = lh.drift_table(rec, remade)
    first = t[t.level == 1].set_index("set D")
    assert first.loc["as recorded", "healthy called physics, order 2"].startswith("1/1")
    assert first.loc["as recorded", "named right of 16, order 0"].startswith("8.0 [")
    assert first.loc["without the load", "named right of 16, order 0"].startswith("16.0 [")
    assert "as recorded +0.0 / " in lh.drift_reading(rec, remade).replace("-0.0", "+0.0")


@pytest.mark.skipif(not (lh.lig.DATA / "set_d" / "truth.csv").exists(),
                    reason="independent set D is not generated (make independent)")
def test_effect_tertiles_split_each_class_in_thirds():
    t = lh.lig.set_truth("d")
    df = t[["group", "name", "class", "level"]].assign(order_2="none", order_0="none")
    x = lh.effect_tertiles(df)
    assert set(x.tertile) == {1, 2, 3} and "none" not in set(x["class"])
    for _, g in x.groupby("class"):
        counts = g.tertile.value_counts()
        assert counts.max() - counts.min() <= 1
        assert g.groupby("tertile").effect.max().is_monotonic_increasing
