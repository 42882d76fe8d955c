"""Model-free diagnosis of the labelled ISDB loops (issues 6 and 10, "Real data").

For every labelled loop of ``../shared/data/isdb/labels.csv`` (stiction and the
non-stiction ones: dead zone, external disturbance, no stiction): run ``diagnose``
without a nominal model (a FOPDT is identified from the recording and, for the valve
hypotheses, re-identified jointly with the valve: closed-loop Hammerstein
identification), write its report to ``reports/diagnose/isdb/<loop>/`` and collect a
summary: which physics won, the fitted S and J with their intervals, the slip-jump test,
and how much the stiction hypothesis improves the validation fit. Long records are
block-averaged to at most 4000 samples. The package's default thresholds were set on a
simulated family (``experiments/concealed.py``), never on these loops: every number here
is out of sample.

Run: ``.venv/bin/python experiments/isdb_diagnose.py [--data ../shared/data/isdb]``.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import time
from pathlib import Path

import pandas as pd

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "experiments"))

from stictionbench.diagnosis import diagnose  # noqa: E402
from stictionbench.diagnosis.evidence import BAND_DOF  # noqa: E402
from stictionbench.diagnosis.report import write_report  # noqa: E402
from stictionbench.io import write_text  # noqa: E402
from stictionbench.rates import wilson  # noqa: E402
from stictionbench.realdata.datasets import load_csv_dir  # noqa: E402
from stictionbench.realdata.verdict import decimate_mean  # noqa: E402
from stictionbench.recording import Recording  # noqa: E402
from stictionbench.reports.tables import to_markdown  # noqa: E402


def _speed_check() -> list[str]:
    """The check of the explanation above, from ``experiments/fast_loops.py`` (simulated
    loops at seven speeds, diagnosed with and without the true model), when it has run."""
    csv = ROOT / "reports" / "diagnose" / "fast_loops.csv"
    if not csv.is_file():
        return ["(Run `experiments/fast_loops.py` for the check of this explanation.)"]
    from fast_loops import findings
    return ["Checked by varying the loop speed and whether the model is given "
            "([fast_loops.md](../fast_loops.md)); an earlier version of this report blamed "
            "the loops' speed (\"τ of a few samples, the valve hidden between samples\"), "
            "which this check refutes:", "", *findings(pd.read_csv(csv)),
            *_excitation_check()]


def _priors_check() -> list[str]:
    """Two remedies varied on these loops (``experiments/isdb_priors.py``, run before this
    script by ``make real``), when that experiment has run."""
    csv, flow = (ROOT / "reports" / "diagnose" / f for f in ("isdb_priors.csv",
                                                             "isdb_priors_flow.csv"))
    if not (csv.is_file() and flow.is_file()):
        return ["(Run `experiments/isdb_priors.py` for the high-pass and a flow loop's "
                "static process varied.)", ""]
    from isdb_priors import flow_findings, high_pass_findings
    return ["Two remedies, varied on these loops ([isdb_priors.md](../isdb_priors.md), "
            "in-sample): a lower slow-load high-pass, and for the flow loops a static "
            "process (\"PV stands in for MV\") in place of the re-identified FOPDT:", "",
            *high_pass_findings(pd.read_csv(csv)), *flow_findings(pd.read_csv(flow)), ""]


def _excitation_check() -> list[str]:
    """The cause, checked by varying it (``experiments/regulatory_bias.py``: set-point
    excitation and the PI's rate), when that experiment has run."""
    csv = ROOT / "reports" / "diagnose" / "regulatory_bias.csv"
    if not csv.is_file():
        return []
    from regulatory_bias import findings, summarise
    df = pd.read_csv(csv)
    return ["", "And the cause, checked by varying it ([regulatory_bias.md]"
            "(../regulatory_bias.md): set-point steps of growing size, and the PI at the "
            "historian's rate instead of 5× faster, on the slow loops):", "",
            *findings(df, summarise(df))]


def labelled_loops(prog: str, doc: str, out: Path, argv=None
                   ) -> tuple[dict[str, Recording], Path] | None:
    """The command line of the ISDB experiments (``--data``, ``--out``) and the labelled
    loops, block-averaged to the length ``diagnose`` is run on; ``None`` (said on stderr)
    when the data are absent."""
    ap = argparse.ArgumentParser(prog=prog, description=doc.splitlines()[0])
    ap.add_argument("--data", default=str(ROOT.parent / "shared" / "data" / "isdb"))
    ap.add_argument("--out", default=str(out))
    a = ap.parse_args(argv)
    data = Path(a.data)
    if not data.is_dir():
        print(f"{prog}: {data} not present; nothing to do", file=sys.stderr)
        return None
    return labelled(data), Path(a.out)


def labelled(data: Path) -> dict[str, Recording]:
    """The labelled loops of the ISDB folder ``data``, block-averaged to the length
    ``diagnose`` is run on."""
    recs, _ = load_csv_dir(data, warn=False)
    return {name: decimate_mean(rec) for name, rec in recs.items() if rec.meta.get("label")}


def main(argv=None) -> int:
    got = labelled_loops("isdb_diagnose", __doc__, ROOT / "reports" / "diagnose" / "isdb",
                         argv)
    if got is None:
        return 2
    loops, out = got
    rows = []
    for name, r in loops.items():
        t0 = time.perf_counter()
        d = diagnose(r)
        seconds = time.perf_counter() - t0
        write_report(d, out / name)
        rk = {x["physics"]: x for x in d.ranking}
        iv = d.fits["stiction"].intervals
        cyc = d.tests.get("closed_loop_cycle", {})
        lr = cyc.get("log_ratios", {})
        rows.append({
            "loop": name, "label": r.meta["label"], "Ts_s": r.Ts, "samples": len(r),
            "diagnosis": d.missing_physics,
            "nrmse_nominal": d.fit["nominal"],
            "nrmse_stiction": rk["stiction"]["nrmse_validation"],
            "stiction_improvement": rk["stiction"]["improvement"],
            "stiction_significant": rk["stiction"]["significant"],
            "S": d.fits["stiction"].params.get("S"), "J": d.fits["stiction"].params.get("J"),
            "S_interval": json.dumps([round(x, 3) for x in iv.get("S", [])]),
            "J_interval": json.dumps([round(x, 3) for x in iv.get("J", [])]),
            "slip_jump_p": d.tests.get("slip_jump_zero", {}).get("p_value"),
            "seconds": round(seconds, 2),
            "mismatch_detected": d.mismatch_detected,
            "windows": len(d.mismatch_windows),
            "band_hz": json.dumps([round(x, 5) for x in d.mismatch_band_hz]),
            "model_tau_s": d.model.time_constant, "model_theta_s": d.model.dead_time,
            "cycle_reproduced": bool(cyc.get("reproduced", False)),
            "cycle_check": cyc.get("reason", "no valve identification"),
            "cycle_period_s": cyc.get("recorded", {}).get("period"),
            "cycle_period_sim_s": cyc.get("simulated", {}).get("period"),
            "cycle_pv_amp_ratio": math.exp(lr["pv_amplitude"]) if lr else None,
            "cycle_op_amp_ratio": math.exp(lr["op_amplitude"]) if lr else None,
            "band_dof": round(float(d.details["band_dof"]), 1),
        })
        print(f"{name} ({r.meta['label']}): {d.missing_physics}; stiction improvement "
              f"{rk['stiction']['improvement']:.0%}")
    df = pd.DataFrame(rows)
    seconds_col = df.pop("seconds")
    st = df[df.label == "stiction"]
    other = df[df.label != "stiction"]
    improved = st[st.stiction_improvement > 0]
    named = int((st.diagnosis == "stiction").sum())
    sticky = int(st.diagnosis.isin(("stiction", "deadband")).sum())
    false = other[other.diagnosis == "stiction"]
    lo, hi = wilson(named, len(st))
    cyc = df[df.cycle_reproduced]
    short = df[df.band_dof < BAND_DOF]
    missed = st[st.diagnosis != "stiction"]
    missed_short = missed[missed.band_dof < BAND_DOF]
    lines = [
        "# Model-free diagnosis of the labelled ISDB loops", "",
        f"- stiction loops named `stiction` (with fitted S, J): **{named} of {len(st)}** "
        f"(Wilson 95 % {lo:.0%}–{hi:.0%}; goal ≥ 8 of 10);",
        f"- non-stiction loops named `stiction`: **{len(false)} of {len(other)}**"
        + (f" ({', '.join(false.loop)})" if len(false) else "") + " (goal 0);",
        f"- stiction loops named a sticky valve (stiction, or a dead band: its slip-jump "
        f"interval reaches 0): {sticky} of {len(st)};",
        f"- the identified valve, closed with the PI identified from the recording, "
        f"reproduces the recorded oscillation by itself (period within 30 %, PV and OP "
        f"amplitudes and PV's waveform within a factor 2: `tests.closed_loop_cycle`) "
        f"on {len(cyc)} loops"
        + (f" ({', '.join(cyc.loop)})" if len(cyc) else "") + "; where it does, a "
        "significant valve is named over an external line or a travel limit "
        "([limit_cycles.md](../limit_cycles.md) checks that rule on regulatory loops "
        "nobody tuned it on).",
        "",
        "Each loop: `diagnose` without `--model` (FOPDT identified from OP → PV; for the "
        "valve hypotheses the process is re-identified from the estimated valve output). "
        "Per-loop figures and summaries in the sub-folders.", "",
        f"- mismatch located (time windows and band) in {int(df.mismatch_detected.sum())} "
        f"of {len(df)} loops;",
        f"- on the stiction loops the stiction model improves the validation fit in "
        f"{len(improved)} of {len(st)} (median improvement where positive "
        f"{improved.stiction_improvement.median():.0%});",
        f"- records short for their loop (fewer than {BAND_DOF:g} independent validation "
        f"samples in the comparison band, `band_dof`; `diagnose` warns, "
        f"[slow_loops_named.md](../../concealed/slow_loops_named.md)): {len(short)} of "
        f"{len(df)}" + (f" ({', '.join(short.loop)})" if len(short) else "")
        + f"; among the stiction loops not named `stiction`: {len(missed_short)} of "
        f"{len(missed)}.", "",
        to_markdown(df.round(4)), "",
        "Why this is weaker than on simulated data: without MV and without a trusted "
        "model, the process must be identified from OP and PV in closed loop, through the "
        "very valve that sticks, and these records have no set-point steps: OP is the "
        "controller's answer to the unmeasured load, which biases the identified process. "
        "Several records are also mean-removed or heavily filtered. The batch verdicts "
        "(`reports/real/isdb/`) use the PV–OP cycle instead; "
        "[two_stage_isdb.md](../two_stage_isdb.md) asks what detection by those methods "
        "followed by this identification's S and J would name.", "",
        *_priors_check(), *_speed_check(), ""]
    write_text(out / "summary.md", "\n".join(lines))
    write_text(out / "summary.csv", df.to_csv(index=False, lineterminator="\n"))
    # timings differ from run to run: printed, never written (byte-identical reports);
    # the speed requirement is measured by benchmarks/test_bench_diagnose.py
    print(f"time per loop: median {seconds_col.median():.1f} s, max {seconds_col.max():.1f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())
