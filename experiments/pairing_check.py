"""The pairing check: does the recording's OP drive its PV at all? Haugh's test of
independence, measured on recordings whose OP and PV belong together and on recordings
made with the wrong tag, before it becomes the default.

The question. A fuzz run of ``diagnose`` gave it a PV and an OP of independent white
noise. Without a model it named ``oscillatory_disturbance`` at 10 000 samples and
``valve_characteristic`` at 20 001 (likelihood-ratio p = 9e-7): the identified "process"
(gain −1.1, τ 1380 s) explains nothing, its comparison band holds four independent
samples, and the hypotheses fit noise there. A plant engineer meets the same when an
export pairs the OP of one loop with the PV of another (the wrong tag), or a record holds
none of the loop's dynamics.

The check (:func:`stictionbench.diagnosis.noise.series_independence`,
:func:`stictionbench.diagnosis.routes.pairing_answer`): each series pre-whitened by its own
noise model (the diagnosis's AR / integrated-AR family chosen by BIC), Haugh's statistic
``N² Σ r̂(k)²/(N − |k|)`` over lags −50 … 50 against χ²(101) (Haugh 1976; Box, Jenkins &
Reinsel §11.1). Any closed loop makes OP and PV dependent both ways (the process one way,
the controller the other), so where the data cannot reject independence at the
diagnosis's α = 0.05 (its published level, not tuned here), nothing is named
(``none``; what was named kept under ``details.op_pv_independent``). The test and its
warning are always reported; the diagnosis's answer changes only with
``pairing_check``.

Recordings:

1. **correctly paired**, the test alone (it changes nothing where it does not fire): the
   14 ISDB loops (block-averaged as ``isdb_diagnose.py``), the refinery windows of
   ``../shared/data/plant``, the two ``../shared/data/factory`` loops, and every
   recording of the 14 independent sets in ``.cache/blindgen`` (generators A–D, 2688
   recordings); where it fires on a simulated one, that recording is diagnosed with its
   model, both ways, to count right answers lost;
2. **the wrong tag**: fresh sets ``fresh_a``, ``fresh_c`` and ``fresh_d``, every third
   recording (64 per set), its own t, SP and PV with the OP of the recording at the same
   place in the next set (a ← c, c ← d, d ← a: another generator's loop, so no shared
   set-point schedule), cut to the shorter; diagnosed with the PV's model YAML and without
   a model;
3. **independent noise**: 24 pairs of white noise and 24 of an AR(1) PV (φ = 0.9) with a
   random-walk OP, 3000 samples, seeds 0–23; diagnosed without a model.

Every recording of 2 and 3 is diagnosed once with ``pairing_check`` off; the check's
answer is :func:`pairing_answer` applied to a copy (``diagnose`` applies it last, so this
is its answer with the check on; the smoke run below confirmed it on 4 recordings).

Seen before the predictions were written: a prototype of the statistic (lags ±20) on 40
recordings of ``fresh_a`` (all right pairs p < 1e-129) and on 40 same-generator
mispairings of them (it fired on 33); the three white-noise recordings of the fuzz
observation (it fired on all three; the diagnosis without it named physics on two).

Predictions (written before the run):

1. real loops: the check fires on none of the 14 ISDB loops, the refinery windows and the
   two factory loops;
2. simulated correct pairs: it fires on at most 0.5 % of the 2688 (13) and, where it
   fires, at most 3 answers named right with the model are lost;
3. the wrong tag: it fires on at least 70 % of the 192;
4. the wrong tag, check off: physics is named on at least 40 % with the model and at
   least 20 % without;
5. the wrong tag, check on: named physics falls by at least half in both modes;
6. independent noise: it fires on at least 85 % of the 48.

Decision (before the run): ``pairing_check`` becomes ``diagnose``'s default (CLI
``--no-pairing-check`` turns it off) if predictions 1, 2 and 5 hold; otherwise it stays
an option (``--pairing-check``).

Run: ``python experiments/pairing_check.py --jobs 2`` (about 10 minutes on 2 cores; it
needs the sets of ``make independent``). Writes ``reports/diagnose/pairing_check.{md,csv}``.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np
import pandas as pd

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "experiments"))

import two_stage_diagnose as ts  # noqa: E402
from detection_independent import fork  # noqa: E402  (one copy of it)

from stictionbench.io import write_text  # noqa: E402
from stictionbench.rates import rate_text  # noqa: E402
from stictionbench.reports.tables import to_markdown  # noqa: E402

OUT = ROOT / "reports" / "diagnose"
BLIND = ROOT / ".cache" / "blindgen"
FACTORY = ROOT.parent / "shared" / "data" / "factory"
#: the independent sets of ``.cache/blindgen`` read whole (correct pairs)
SETS = ("set_a", "set_b", "set_c", "set_d", "set_e", "set_f", "set_g", "set_h", "set_i",
        "set_x", "set_y", "fresh_a", "fresh_c", "fresh_d")
#: wrong-tag pairings: the PV's set and the set whose OP it is given
MISPAIRED = (("fresh_a", "fresh_c"), ("fresh_c", "fresh_d"), ("fresh_d", "fresh_a"))
MISPAIR_STEP = 3
NOISE_PAIRS = 24
NOISE_N = 3000
ALPHA = 0.05


def truth(name: str) -> pd.DataFrame:
    return pd.read_csv(BLIND / name / "truth.csv").sort_values("name").reset_index(drop=True)


def jobs() -> list[dict]:
    """Every recording of the three sources, as a job :func:`run` takes."""
    out: list[dict] = [{**j, "kind": "paired"} for j in ts.jobs()
                       if j["source"] in ("isdb", "refinery")]
    out += [{"kind": "paired", "source": "factory", "name": p.stem}
            for p in sorted(FACTORY.glob("*.csv"))]
    for s in SETS:
        if (BLIND / s / "truth.csv").is_file():
            out += [{"kind": "paired", "source": s, "name": r["name"], "class": r["class"],
                     "level": int(r["level"])} for _, r in truth(s).iterrows()]
    for pv_set, op_set in MISPAIRED:
        if not ((BLIND / pv_set / "truth.csv").is_file()
                and (BLIND / op_set / "truth.csv").is_file()):
            continue
        a, b = truth(pv_set), truth(op_set)
        for i in range(0, min(len(a), len(b)), MISPAIR_STEP):
            for mode in ("model", "no_model"):
                out.append({"kind": "wrong_tag", "source": pv_set, "op_source": op_set,
                            "name": a.loc[i, "name"], "op_name": b.loc[i, "name"],
                            "class": a.loc[i, "class"], "level": int(a.loc[i, "level"]),
                            "mode": mode})
    for noise in ("white", "ar1_randomwalk"):
        out += [{"kind": "noise", "source": noise, "seed": k, "mode": "no_model"}
                for k in range(NOISE_PAIRS)]
    return out


def recording(job: dict):
    """The recording of ``job`` and the model file to diagnose it with (or None)."""
    import stictionbench as sb
    from stictionbench.io import read_recording

    src = job["source"]
    if job["kind"] == "noise":
        rng = np.random.default_rng(job["seed"])
        t = np.arange(NOISE_N, dtype=float)
        if src == "white":
            pv, op = rng.normal(size=NOISE_N), 50 + 5 * rng.normal(size=NOISE_N)
        else:
            from scipy.signal import lfilter

            pv = lfilter([1.0], [1.0, -0.9], rng.normal(size=NOISE_N))
            op = 50 + np.cumsum(0.3 * rng.normal(size=NOISE_N))
        return sb.Recording.from_arrays(t, pv, op, warn=False), None
    if job["kind"] == "wrong_tag":
        a = read_recording(BLIND / src / f"{job['name']}.csv", warn=False)
        b = read_recording(BLIND / job["op_source"] / f"{job['op_name']}.csv", warn=False)
        n = min(len(a), len(b))
        rec = sb.Recording.from_arrays(a.t[:n], a.PV[:n], b.OP[:n],
                                       SP=None if a.SP is None else a.SP[:n], warn=False)
        model = BLIND / src / f"{job['name']}.model.yaml"
        return rec, (model if job["mode"] == "model" else None)
    if src == "factory":  # outages cut these records: their longest stretch, as diagnose
        from stictionbench.io import read_longest_stretch

        return read_longest_stretch(FACTORY / f"{job['name']}.csv", warn=False), None
    if src in SETS:
        return (read_recording(BLIND / src / f"{job['name']}.csv", warn=False),
                BLIND / src / f"{job['name']}.model.yaml")
    return ts.recording(job)[0], None


def run(job: dict) -> dict:
    """The test on every recording; the diagnosis (check off, and its answer with the
    check on) on the wrong-tag and noise recordings and on correct pairs it fires on."""
    from stictionbench.diagnosis import diagnose
    from stictionbench.diagnosis.model import load_model
    from stictionbench.diagnosis.routes import pairing_answer, pairing_test
    from stictionbench.errors import InputError

    rec, model_file = recording(job)
    row = {k: v for k, v in job.items()}
    t = pairing_test(rec, ALPHA)
    row.update(p_value=t["p_value"], statistic=t["statistic"], peak_lag=t["peak_lag"],
               fires=t["independent"], samples=len(rec))
    if job["kind"] == "paired" and not (t["independent"] and model_file is not None):
        return row
    model = load_model(model_file) if model_file is not None else None
    try:
        d = diagnose(rec, model)
    except InputError as exc:
        return {**row, "off": "unusable", "on": "unusable", "reason": str(exc)[-120:]}
    row["off"] = d.missing_physics
    row["on"] = pairing_answer(fork(d), ALPHA).missing_physics
    return row


def named(s: pd.Series) -> pd.Series:
    return ~s.isin(["none", "unusable"])


def report(df: pd.DataFrame) -> str:
    paired = df[df["kind"] == "paired"]
    real = paired[paired["source"].isin(["isdb", "refinery", "factory"])]
    sim = paired[~paired["source"].isin(["isdb", "refinery", "factory"])]
    wrong = df[df["kind"] == "wrong_tag"]
    noise = df[df["kind"] == "noise"]
    lines = [
        "# The pairing check: Haugh's test that OP and PV are independent",
        "",
        "Generated by `experiments/pairing_check.py` (design, predictions and decision in "
        "its docstring, written before the run). *fires*: the test cannot reject that OP "
        "and PV are independent at α = 0.05 (lags ±50, χ²(101)); *off* / *on*: "
        "`diagnose`'s answer with the check off and on. Wilson 95 % intervals. Nothing "
        "here was tuned: α is the diagnosis's level, the lags were fixed before the run.",
        "",
        "## Correctly paired recordings (the test alone)",
        "",
    ]
    rows = []
    for src, g in paired.groupby("source", sort=False):
        rows.append({"source": src, "recordings": len(g),
                     "fires": rate_text(int(g["fires"].sum()), len(g)),
                     "largest p": f"{g['p_value'].max():.2g}",
                     "median log10 p":
                         f"{np.median(np.log10(np.maximum(g['p_value'], 1e-300))):.0f}"})
    lines += [to_markdown(pd.DataFrame(rows)), ""]
    fired_sim = sim[sim["fires"]]
    if len(fired_sim):
        cols = [c for c in ("source", "name", "class", "level", "p_value", "peak_lag", "off",
                            "on") if c in fired_sim]
        lines += ["Simulated correct pairs the check fires on, diagnosed with their model:",
                  "", to_markdown(fired_sim[cols]), ""]
    lines += ["## The wrong tag and independent noise", ""]
    rows = []
    for (kind, mode), g in pd.concat([wrong, noise]).groupby(["kind", "mode"], sort=False):
        rows.append({"recordings": kind, "model": mode, "n": len(g),
                     "fires": rate_text(int(g["fires"].sum()), len(g)),
                     "named physics, off": rate_text(int(named(g["off"]).sum()), len(g)),
                     "named physics, on": rate_text(int(named(g["on"]).sum()), len(g))})
    lines += [to_markdown(pd.DataFrame(rows)), ""]
    if len(wrong):
        rows = []
        for src, g in wrong[wrong["mode"] == "model"].groupby("source", sort=False):
            rows.append({"PV from": src, "OP from": g["op_source"].iloc[0], "n": len(g),
                         "fires": rate_text(int(g["fires"].sum()), len(g)),
                         "named, off": int(named(g["off"]).sum()),
                         "named, on": int(named(g["on"]).sum())})
        lines += ["Wrong tag with the model, by set:", "", to_markdown(pd.DataFrame(rows)),
                  "", "Named with the check off, wrong tag (both modes): "
                  + ", ".join(f"{k} ×{v}" for k, v in
                              wrong.loc[named(wrong["off"]), "off"].value_counts().items()),
                  ""]
    lines += ["## The predictions", ""] + verdicts(real, sim, wrong, noise)
    lines += ["", "## Reading (added after the run, no prediction)", ""] + \
        reading(real, wrong)
    lines += ["", "## Does a sticking valve look like a wrong tag? Stiction size varied", "",
              "The paper's linear loop with a noisy sensor and a Kano valve (J = S/2), "
              "1500 s at 1 s, seed 2, S from 0 (linear valve) to 80 % of span; *moves*: "
              "the share of steps in which the valve position changed.", "",
              to_markdown(stuck_valve_sweep()), ""]
    return "\n".join(lines) + "\n"


#: stiction sizes of :func:`stuck_valve_sweep` (% of span; 0: the linear valve)
SWEEP_S = (0.0, 2.0, 5.0, 10.0, 20.0, 40.0, 80.0)


def stuck_valve_sweep() -> pd.DataFrame:
    """Haugh's p-value of OP and PV as the valve's stiction grows (computed, seeded)."""
    import stictionbench as sb
    from stictionbench.diagnosis.noise import series_independence

    rows = []
    for s in SWEEP_S:
        kw = {"valve": "kano", "valve__S": s, "valve__J": s / 2} if s else {}
        r = sb.simulate("linear", duration=1500.0, seed=2, sample_time=1.0, sensor="noisy",
                        **kw)
        t = series_independence(r.PV, r.OP)
        rows.append({"S (% of span)": s,
                     "moves": f"{np.mean(np.abs(np.diff(r.MV)) > 1e-9):.1%}",
                     "p_value": f"{t['p_value']:.2g}", "fires": t["p_value"] >= ALPHA})
    return pd.DataFrame(rows)


def reading(real: pd.DataFrame, wrong: pd.DataFrame) -> list[str]:
    """What the failed predictions come from, counted from the table."""
    fired = real[real["fires"]]
    left = wrong[~wrong["on"].isin(["none", "unusable"])]
    kept = left[left["fires"]]
    sat = int((kept["on"] == "saturation").sum())
    return [
        f"- The real windows it fires on ({', '.join(fired['name']) or 'none'}, largest p "
        f"{fired['p_value'].max() if len(fired) else float('nan'):.2g}) are labelled "
        "`stiction`: the refinery loop whose PV the screening calls dead. Its PV is one "
        "value throughout (a dead tag; `screen` calls it unusable, `diagnose` refuses a "
        "constant PV), so the statistic is 0. A sticking valve is not what the test "
        "sees: in closed loop the controller still answers PV, and the sweep below "
        "rejects independence at every stiction size.",
        f"- With the check on, {len(left)} wrong-tag diagnoses still name physics; "
        f"{len(kept)} of them are ones the check fired on, {sat} of those `saturation` "
        "read off OP held at a limit, which the check leaves alone by design (as the "
        "resolution floor does): the other loop's OP was clamped. The rest are the wrong "
        "tags it did not fire on.",
        "- Prediction 4 overestimated how often the wrong tag makes the diagnosis name "
        "physics (the fits of the hypotheses on an unrelated OP rarely pass the tests), "
        "so the check matters less than expected there; on independent noise it took the "
        "named physics from 7 of 48 to 0.",
    ]


def held(ok: bool) -> str:
    return "**held**" if ok else "**failed**"


def verdicts(real, sim, wrong, noise) -> list[str]:
    fired = sim[sim["fires"]]
    lost = int(((fired["off"] == fired["class"]) & (fired["on"] != fired["class"])).sum()) \
        if len(fired) else 0
    wm, wn = wrong[wrong["mode"] == "model"], wrong[wrong["mode"] == "no_model"]
    p1 = int(real["fires"].sum()) == 0
    p2 = len(fired) <= 0.005 * len(sim) and lost <= 3
    p3 = wrong["fires"].mean() >= 0.70 if len(wrong) else False
    off_m, off_n = named(wm["off"]).mean(), named(wn["off"]).mean()
    on_m, on_n = named(wm["on"]).mean(), named(wn["on"]).mean()
    p4 = off_m >= 0.40 and off_n >= 0.20
    p5 = on_m <= off_m / 2 and on_n <= off_n / 2
    p6 = noise["fires"].mean() >= 0.85
    out = [
        f"1. real loops: fires on none ({int(real['fires'].sum())} of {len(real)}): "
        f"{held(p1)}",
        f"2. simulated correct pairs: at most 0.5 % ({len(fired)} of {len(sim)}) and at "
        f"most 3 right answers lost ({lost}): {held(p2)}",
        f"3. wrong tag: fires on at least 70 % ({wrong['fires'].mean():.0%}): {held(p3)}",
        f"4. wrong tag, check off: named at least 40 % with the model ({off_m:.0%}) and "
        f"20 % without ({off_n:.0%}): {held(p4)}",
        f"5. wrong tag, check on: named falls by at least half ({off_m:.0%} → {on_m:.0%} "
        f"with the model, {off_n:.0%} → {on_n:.0%} without): {held(p5)}",
        f"6. independent noise: fires on at least 85 % ({noise['fires'].mean():.0%}): "
        f"{held(p6)}",
        "",
        "Decision (1, 2 and 5): " + ("met — the check becomes the default."
                                     if p1 and p2 and p5 else
                                     "not met — the check stays an option."),
    ]
    return out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--report-only", action="store_true",
                    help="rewrite the report from the stored CSV")
    ap.add_argument("--smoke", type=int, default=0, metavar="N",
                    help="run N jobs of each kind only and print them (no files written)")
    a = ap.parse_args(argv)
    csv = OUT / "pairing_check.csv"
    if a.report_only:
        df = pd.read_csv(csv, keep_default_na=False)
        df["fires"] = df["fires"].astype(str) == "True"
    else:
        if not (BLIND / "fresh_a" / "truth.csv").is_file():
            print("pairing_check: the independent sets are missing; run `make independent` "
                  "first", file=sys.stderr)
            return 2
        import pairing_check as this  # by reference: the workers import the module
        from joblib import Parallel, delayed
        from tqdm import tqdm

        js = jobs()
        if a.smoke:
            seen: dict[str, int] = {}
            picked = []
            for j in js:
                key = f"{j['kind']}:{j.get('mode', '')}"
                if seen.get(key, 0) < a.smoke:
                    seen[key] = seen.get(key, 0) + 1
                    picked.append(j)
            print(pd.DataFrame([this.run(j) for j in picked]).to_string())
            return 0
        rows = list(tqdm(Parallel(n_jobs=a.jobs, return_as="generator")(
            delayed(this.run)(j) for j in js), total=len(js), desc="pairing", unit="rec"))
        df = pd.DataFrame(rows)
        write_text(csv, df.to_csv(index=False))
    write_text(OUT / "pairing_check.md", report(df))
    print((OUT / "pairing_check.md").read_text(encoding="utf-8"))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
