"""The alternative decision rules of ``experiments/decision_rules.py`` on hand-made
evidence: each differs from the shipped rule where its docstring says it does."""

from __future__ import annotations

import json
import sys
from pathlib import Path

import pandas as pd

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "experiments"))

import decision_rules as dr  # noqa: E402


def _row(lag_tau: float = 3.0, lag_improvement: float = 0.03,
         delay_p: float = 1e-3) -> pd.Series:
    ev = [{"physics": "none", "p_value": 1.0, "improvement": 0.0, "score": 12.0,
           "at_bound": False, "parameters": {}},
          {"physics": "dead_time", "p_value": delay_p, "improvement": 0.03, "score": 2.0,
           "at_bound": False, "parameters": {"dead_time": 13.0}},
          {"physics": "sensor_lag", "p_value": 1e-3, "improvement": lag_improvement,
           "score": 0.0, "at_bound": False, "parameters": {"time_constant": lag_tau}}]
    return pd.Series({"evidence": json.dumps(ev), "slip_jump_p": float("nan"),
                      "dead_time_own_resolution": True, "class": "sensor_lag", "level": 2})


def test_the_lag_of_lower_bic_is_named_only_when_judged_by_its_own_resolution():
    row = _row()
    # shipped: the dead time, named on its own resolution only, gives way to the lag that
    # meets the same standard with the lower BIC
    assert dr.shipped(row) == "sensor_lag"
    assert dr.sensor_lag_own_resolution(row) == "sensor_lag"
    # where no dead time is significant, only the alternative names the lag
    assert dr.shipped(_row(delay_p=0.2)) == "none"
    assert dr.sensor_lag_own_resolution(_row(delay_p=0.2)) == "sensor_lag"
    # at or under one sample the alternative never names the lag
    assert dr.sensor_lag_own_resolution(_row(lag_tau=1.0)) == "dead_time"


def test_winner_gated_answers_none_when_the_best_fit_fails_its_gate():
    assert dr.winner_gated(_row()) == "none"
    assert dr.winner_gated(_row(lag_improvement=0.2)) == "sensor_lag"


def test_bic_only_ignores_the_likelihood_ratio_test():
    row = _row(lag_improvement=0.2)
    ev = json.loads(row["evidence"])
    ev[2]["p_value"] = 0.5
    row["evidence"] = json.dumps(ev)
    assert dr.shipped(row) == "dead_time"
    assert dr.bic_only(row) == "sensor_lag"


def test_score_counts_levels_and_none_recordings():
    df = pd.DataFrame({"class": ["none", "stiction", "none", "deadband"],
                       "level": [1, 1, 2, 2]})
    picks = pd.Series(["stiction", "stiction", "none", "none"])
    s = dr.score(df, picks)
    assert s["level 1: named"].startswith("1/2")
    assert s["level 1: none called physics"].startswith("1/1")
    assert s["level 2: physics classes"].startswith("0/1")
    assert dr.counts(df, picks) == (2, 1)


def test_kstep_gate_uses_the_kstep_effect_size_in_place_of_the_nrmse():
    row = _row(lag_improvement=0.2)
    ev = json.loads(row["evidence"])
    for e, k in zip(ev, (0.0, 0.0, 0.01), strict=True):
        e["improvement_kstep"] = k
    ev[1]["physics"] = "deadband"  # not judged by its own resolution
    row["evidence"] = json.dumps(ev)
    assert dr.shipped(row) == "sensor_lag"
    assert dr.kstep_gate(row, 0.005) == "sensor_lag"
    assert dr.kstep_gate(row, 0.02) == "none"


def test_kstep_threshold_keeps_none_recordings_under_the_limit():
    def rec(cls: str, k: float, stored: bool = True) -> dict:
        ev = [{"physics": "none", "p_value": 1.0, "improvement": 0.0, "score": 5.0,
               "at_bound": False, "parameters": {}, "improvement_kstep": 0.0},
              {"physics": "saturation", "p_value": 1e-4, "improvement": 0.2, "score": 0.0,
               "at_bound": False, "parameters": {}, "improvement_kstep": k}]
        if not stored:
            ev = [{key: v for key, v in e.items() if key != "improvement_kstep"}
                  for e in ev]
        return {"evidence": json.dumps(ev), "slip_jump_p": float("nan"), "class": cls,
                "level": 1}
    # a `none` recording whose spurious fit reaches 0.01: 0.02 is the threshold that
    # keeps it `none` and still names the saturation at 0.03
    df = pd.DataFrame([rec("none", 0.01), rec("saturation", 0.03)])
    assert dr.tune_kstep(df) == 0.02
    old = pd.DataFrame([rec("none", 0.01, False), rec("saturation", 0.03, False)])
    assert dr.tune_kstep(old) is None


def test_holm_adjusts_every_tested_hypothesis_and_leaves_the_nominal():
    rows = [{"physics": "none", "p_value": 1.0},
            {"physics": "a", "p_value": 0.01}, {"physics": "b", "p_value": 0.04},
            {"physics": "c", "p_value": 0.03}]
    adj = {r["physics"]: r["p_value"] for r in dr.holm_adjust(rows)}
    # ascending 0.01, 0.03, 0.04 times 3, 2, 1, made monotone
    assert adj == {"none": 1.0, "a": 0.03, "c": 0.06, "b": 0.06}
    assert rows[1]["p_value"] == 0.01  # the input rows are not changed


def test_holm_gate_withholds_what_only_the_unadjusted_test_passes():
    row = _row(lag_improvement=0.2)
    ev = json.loads(row["evidence"])
    ev[1]["p_value"], ev[2]["p_value"] = 0.5, 0.03  # the lag alone passes alpha 0.05
    row["evidence"] = json.dumps(ev)
    assert dr.shipped(row) == "sensor_lag"
    assert dr.holm_gate(row, 0.05, 0.1) == "none"       # 2 × 0.03 ≥ 0.05
    assert dr.holm_gate(row, 0.1, 0.1) == "sensor_lag"
    assert dr.holm_gate(row, 0.1, 0.25) == "none"       # the effect-size gate still holds


def test_calibration_counts_only_none_recordings():
    spurious = _row(lag_improvement=0.2)
    spurious["class"] = "none"
    clean = _row(lag_improvement=0.2)
    ev = json.loads(clean["evidence"])
    for e in ev[1:]:
        e["p_value"] = 0.9
    clean["evidence"], clean["class"] = json.dumps(ev), "none"
    other = _row(lag_improvement=0.2)                    # a physics class: not counted
    cal = dr.calibration(pd.DataFrame([spurious, clean, other]))
    assert all(v.startswith("1/2") for v in cal.values())


def test_full_data_lr_decides_by_the_test_on_every_block():
    row = _row(lag_improvement=0.2)
    ev = json.loads(row["evidence"])
    ev[1]["p_value"] = ev[2]["p_value"] = 0.5          # the validation test: nothing
    ev[0].update(p_full=1.0, p_k_step=1.0)
    ev[1].update(p_full=0.5, p_k_step=0.5)
    ev[2].update(p_full=0.001, p_k_step=0.9)           # every block: the lag
    row["evidence"] = json.dumps(ev)
    assert dr.shipped(row) == "none"
    assert dr.full_data_lr(row, 0.05, 0.1) == "sensor_lag"   # 2 × 0.001 < 0.05
    assert dr.full_data_lr(row, 0.001, 0.1) == "none"
    assert dr._has_keys(pd.DataFrame([row]), "p_full", "p_k_step")
    assert not dr._has_keys(pd.DataFrame([_row()]), "p_full")


def test_every_rule_applies_the_second_look_where_the_main_band_names_nothing():
    none_row = _row(lag_improvement=0.03)
    ev = [e for e in json.loads(none_row["evidence"]) if e["physics"] == "none"]
    look = {"corner_period_s": 300.0, "oscillatory_disturbance": {
        "physics": "oscillatory_disturbance", "p_value": 1e-5, "improvement": 0.4,
        "at_bound": False, "parameters": {"period": 700.0}}}
    row = none_row.copy()
    row["evidence"], row["slow_line"] = json.dumps(ev), json.dumps(look)
    for rule in (dr.shipped, dr.winner_gated, dr.bic_only, dr.sensor_lag_own_resolution):
        assert rule(row) == "oscillatory_disturbance", rule.__name__
    assert dr.holm_gate(row, 0.05, 0.1) == "oscillatory_disturbance"
    # not where the line is no slower than the corner, nor where the main band names
    fast = row.copy()
    fast["slow_line"] = json.dumps({**look, "corner_period_s": 800.0})
    assert dr.shipped(fast) == "none"
    named = _row()
    named["slow_line"] = json.dumps(look)
    assert dr.shipped(named) == "sensor_lag"


def _valve_row(p_validation: float, p_identification: float | None,
               improvement: float = 0.2) -> pd.Series:
    ev = [{"physics": "none", "p_value": 1.0, "improvement": 0.0, "score": 9.0,
           "at_bound": False, "parameters": {}, "p_identification": None},
          {"physics": "deadband", "p_value": p_validation, "improvement": improvement,
           "score": 0.0, "at_bound": False, "parameters": {"deadband": 2.0},
           "p_identification": p_identification},
          {"physics": "stiction", "p_value": p_validation, "improvement": improvement,
           "score": 3.0, "at_bound": False, "parameters": {"S": 2.0, "J": 0.0},
           "p_identification": p_identification}]
    return pd.Series({"evidence": json.dumps(ev), "slip_jump_p": 1.0,
                      "dead_time_own_resolution": True, "class": "deadband", "level": 2})


def test_valve_identification_test_replaces_the_validation_test_for_valves_only():
    # the validation test fails, the identification's passes: only the alternative names
    assert dr.shipped(_valve_row(0.3, 1e-6)) == "none"
    assert dr.valve_identification_test(_valve_row(0.3, 1e-6)) == "deadband"
    # the NRMSE gate still applies
    assert dr.valve_identification_test(_valve_row(0.3, 1e-6, improvement=0.02)) == "none"
    # and so does the identification's own verdict
    assert dr.valve_identification_test(_valve_row(1e-6, 0.3)) == "none"
    # evidence stored without the identification's p: the shipped rule
    assert dr.valve_identification_test(_valve_row(1e-6, None)) == "deadband"


def test_calibration_reports_the_identification_test_alone_where_stored():
    rows = [_valve_row(0.3, p) for p in (1e-6, 0.5, 0.2, 0.01)]
    df = pd.DataFrame(rows).assign(**{"class": "none"})
    cal = dr.calibration(df)
    assert cal[f"valve identification test alone, alpha {dr.ALPHA:g}"].startswith("2/4")
    old = pd.DataFrame([_row()]).assign(**{"class": "none"})
    assert not any(k.startswith("valve identification") for k in dr.calibration(old))


def test_stored_band_dof_scales_the_main_bands_gate():
    # a lag improving the validation NRMSE by 15 %: named with the gate as set, not
    # where the stored band holds 25 independent samples (gate 0.2); rows stored before
    # the degrees of freedom were (NaN) keep the gate as set
    row = _row(lag_improvement=0.15, delay_p=0.2)
    assert dr.shipped(row) == "sensor_lag"
    assert dr.shipped(pd.concat([row, pd.Series({"band_dof": 25.0})])) == "none"
    assert dr.shipped(pd.concat([row, pd.Series({"band_dof": 400.0})])) == "sensor_lag"
    assert dr.shipped(pd.concat([row, pd.Series({"band_dof": float("nan")})])) == "sensor_lag"


def test_without_band_gate_reads_the_gate_as_set():
    row = pd.concat([_row(lag_improvement=0.15, delay_p=0.2), pd.Series({"band_dof": 25.0})])
    assert dr.shipped(row) == "none"
    assert dr.without_band_gate(row) == "sensor_lag"


def test_stored_rows_are_re_decided_with_the_checks_after_the_comparison():
    import concealed

    ev = json.dumps([{"physics": "none", "p_value": 1.0, "improvement": 0.0, "score": 0.0,
                      "improvement_kstep": 0.0, "p_full": 1.0, "p_k_step": 1.0,
                      "p_identification": None, "at_bound": False, "parameters": {}}])
    base = {"evidence": ev, "slip_jump_p": None, "cycle_reproduced": False,
            "dead_time_own_resolution": True, "slow_line": "", "band_dof": 150.0}
    pick = concealed.decide(pd.Series(base), 0.05, 0.1)
    assert pick == "none"  # a row stored before the checks keeps its verdict
    held = concealed.decide(pd.Series({**base, "op_held": True, "gain_flagged": True}),
                            0.05, 0.1)
    assert held == "saturation"  # the OP hold is read first, as diagnose does
    gain = concealed.decide(pd.Series({**base, "op_held": "False", "gain_flagged": "True"}),
                            0.05, 0.1)
    assert gain == "valve_characteristic"
    assert concealed.after_comparison(pd.Series({"gain_flagged": True}), "stiction") == \
        "stiction"


def _line_row(p_value: float, p_k_step: float) -> pd.Series:
    ev = [{"physics": "none", "p_value": 1.0, "improvement": 0.0, "score": 9.0,
           "at_bound": False, "parameters": {}, "p_k_step": 1.0},
          {"physics": "oscillatory_disturbance", "p_value": p_value, "improvement": 0.3,
           "score": 0.0, "at_bound": False, "parameters": {"period": 500.0},
           "p_k_step": p_k_step}]
    return pd.Series({"evidence": json.dumps(ev), "slip_jump_p": float("nan"),
                      "dead_time_own_resolution": True, "class": "none", "level": 1})


def test_line_kstep_names_a_line_only_where_its_kstep_test_also_rejects():
    # the shipped test takes the smaller p-value: a line that only the one-step test
    # supports is named there, and not by the alternative
    assert dr.shipped(_line_row(1e-6, 0.2)) == "oscillatory_disturbance"
    assert dr.line_kstep(_line_row(1e-6, 0.2)) == "none"
    assert dr.line_kstep(_line_row(1e-6, 0.01)) == "oscillatory_disturbance"


def test_every_alternative_applies_the_line_test_as_the_shipped_rule_does():
    row = _row(lag_improvement=0.2)
    # the lag's improvement lies at the residual's line: the line test renames it
    row["line_shares"] = json.dumps({"sensor_lag": 1.5})
    assert dr.shipped(row) == "oscillatory_disturbance"
    assert dr.winner_gated(row) == "oscillatory_disturbance"
    assert dr.line_kstep(row) == "oscillatory_disturbance"


def test_read_benchmark_pools_files_and_wants_every_one(tmp_path, monkeypatch):
    monkeypatch.setattr(dr, "OUT", tmp_path)
    pd.DataFrame({"class": ["none"], "level": [1]}).to_csv(tmp_path / "x.csv", index=False)
    pd.DataFrame({"class": ["stiction"], "level": [2]}).to_csv(tmp_path / "y.csv",
                                                               index=False)
    both = dr.read_benchmark(("x.csv", "y.csv"))
    assert list(both["class"]) == ["none", "stiction"]
    assert list(dr.read_benchmark("x.csv")["class"]) == ["none"]
    assert dr.read_benchmark(("x.csv", "z.csv")) is None
