"""Would a closed-loop parametric bootstrap calibrate the slip-jump test?

``slip_jump_calibration.md`` and ``slip_jump_nuisance.md`` show the likelihood-ratio test
of ``J = 0`` (stiction against a dead band, the closed-loop valve identification's
profile likelihood, χ²₁) rejecting on a third of the holdout family's level-2 dead bands
at alpha 0.05. The statistic's null distribution is not χ²₁ there: the slip jump is
searched over a rugged criterion and three stop rules, and the noise model is an AR
approximation. The calibrated alternative is to simulate the null (Efron & Tibshirani,
*An Introduction to the Bootstrap*, 1993, ch. 16; the AR sieve of Bühlmann, *Bernoulli*
3 (1997) 123): the loop as the dead-band hypothesis says it is — the given FOPDT (gain
and dead-time shift as the dead band's fit chose them) behind a play operator of the
fitted width, under the given PI on the recorded set point, with an output disturbance
resampled from the dead band's own residual — and ask how often the identification
finds a slip jump as significant as the recording's where, by construction, there is
none.

Per recording (a model given): the identification of
:func:`stictionbench.diagnosis.hammerstein.fit_hammerstein` as ``diagnose`` runs it with a
model; its statistic of ``J = 0``; the restricted fit
(:func:`~stictionbench.diagnosis.hammerstein._dead_band_fit`); ``B`` null recordings,
each identified the same way; ``p_boot = (1 + #{null statistic ≥ observed}) / (B + 1)``,
an exact Monte Carlo test at level ``1/(B + 1)`` multiples (Davison & Hinkley, *Bootstrap
Methods*, 1997, ch. 4.2).

Recordings: level-2 dead bands (the size: a calibrated test rejects about alpha of them)
and sticky valves (the power), a model given: the holdout family's seen blocks 16000 and
17000, and the three tuning families (``concealed.py``'s generators, 4 seeds each). The
bootstrap is the package's (``diagnose --slip-jump-bootstrap B``, not the default); no
parameter of it is set on these recordings.

Run: ``.venv/bin/python experiments/slip_jump_bootstrap.py [--B 19] [--jobs 2]`` (about
4 min on 2 cores). Outputs ``reports/concealed/slip_jump_bootstrap.{md,csv}``.
"""

from __future__ import annotations

import argparse
import math
import sys
import tempfile
from pathlib import Path

import numpy as np
import pandas as pd

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "experiments"))

from stictionbench.io import atomic_path, write_text  # noqa: E402
from stictionbench.rates import rate_text  # noqa: E402
from stictionbench.reports.tables import to_markdown  # noqa: E402

OUT = ROOT / "reports" / "concealed"
BLOCKS = (16000, 17000)
SEEDS_PER_BLOCK = 12
#: the tuning families' seeds per family and class (``make concealed``'s), level 2
FAMILY_SEEDS = 4
VALVES = ("deadband", "stiction")
LEVEL = 2
ALPHA = 0.05


def case(cls: str, seed: int, B: int, family: str = "holdout") -> dict:
    """One recording: its J = 0 statistic, asymptotic and bootstrap p-values (the
    package's :func:`stictionbench.diagnosis.slip_bootstrap.bootstrap_slip_jump`, as
    ``diagnose --slip-jump-bootstrap B`` runs it), and the null statistics' count over
    χ²₁'s 5 % point."""
    import concealed
    import holdout_family as hf

    from stictionbench.diagnosis import hammerstein as H
    from stictionbench.diagnosis import load_model, slip_bootstrap
    from stictionbench.io import read_recording

    with tempfile.TemporaryDirectory() as tmp:
        job = (hf.generate(cls, LEVEL, seed, Path(tmp)) if family == "holdout" else
               concealed.generate(cls, LEVEL, seed, Path(tmp), family))
        rec, m = read_recording(job["csv"]), load_model(job["model"])
    h = H.fit_hammerstein(rec, alpha=ALPHA, linear=(m.gain, m.time_constant, m.dead_time),
                          fix_process=True, hp_factor=H.HP_FACTOR)
    row = {"family": family, "class": cls, "level": LEVEL, "seed": seed,
           "valve_model": job.get("valve_model", family),
           "S": h.S, "J": h.J, "stop_rule": h.stop_rule,
           "statistic": float(h.tests["slip_jump_zero"]["statistic"]),
           "p_asymptotic": float(h.tests["slip_jump_zero"]["p_value"]),
           "sticky": bool(h.sticky), "width0": math.nan, "null_q95": math.nan,
           "null_reject_asymptotic": math.nan, "p_boot": math.nan}
    if h.S <= 0:
        return row  # no valve identified: nothing to test
    b = slip_bootstrap.bootstrap_slip_jump(rec, m, h, B=B, hp_factor=H.HP_FACTOR,
                                           seed=seed, keep_null=True)
    null = np.asarray(b["null"])
    row.update(width0=b["dead_band_width"], null_q95=b["null_q95"],
               null_reject_asymptotic=int((null > 3.841).sum()), p_boot=b["p_bootstrap"])
    return row


def table(df: pd.DataFrame) -> pd.DataFrame:
    rows = []
    for (hold, cls), g in df.groupby([df.family == "holdout", "class"], sort=False):
        t = g[g.p_boot.notna()]
        rows.append({"recordings of": "holdout family" if hold else "tuning families",
                     "valve (truth)": cls, "recordings": len(g),
                     "a valve identified": len(t),
                     f"asymptotic p < {ALPHA:g}": rate_text(int((t.p_asymptotic < ALPHA).sum()),
                                                             len(t)),
                     f"bootstrap p ≤ {ALPHA:g}": rate_text(int((t.p_boot <= ALPHA).sum()),
                                                          len(t))})
    return pd.DataFrame(rows)


def report(df: pd.DataFrame, B: int) -> str:
    t = df[df.p_boot.notna()]
    n_null = int(t.get("null_reject_asymptotic", pd.Series(dtype=float)).sum())
    db = t[t["class"] == "deadband"]
    st = t[t["class"] == "stiction"]
    return "\n".join([
        "# A closed-loop parametric bootstrap of the slip-jump test",
        "",
        "Generated by `experiments/slip_jump_bootstrap.py` (the method in its docstring): "
        f"level-{LEVEL} dead bands and sticky valves, a model given — the holdout "
        f"family's seen blocks {', '.join(map(str, BLOCKS))} and the three tuning "
        f"families ({FAMILY_SEEDS} seeds each) — with {B} null recordings each (the "
        "dead-band hypothesis's loop with a sieve resample of its residual; "
        "`diagnose --slip-jump-bootstrap`). The bootstrap has no parameter set on any "
        "of these recordings. Wilson 95 % intervals; the default decision is unchanged.",
        "",
        to_markdown(table(df)),
        "",
        f"- null recordings on which the identification rejects J = 0 by χ²₁ at 0.05: "
        f"{rate_text(n_null, B * len(t))} — the asymptotic test's size where the "
        "null is true by construction;",
        f"- all recordings, dead bands: asymptotic "
        f"{rate_text(int((db.p_asymptotic < ALPHA).sum()), len(db))}"
        f", bootstrap {rate_text(int((db.p_boot <= ALPHA).sum()), len(db))}; sticky "
        f"valves: asymptotic {rate_text(int((st.p_asymptotic < ALPHA).sum()), len(st))}, "
        f"bootstrap {rate_text(int((st.p_boot <= ALPHA).sum()), len(st))};",
        f"- the null statistic's 95th percentile, per recording: median "
        f"{t.null_q95.median():.2g}, range {t.null_q95.min():.2g}–{t.null_q95.max():.2g} "
        "(χ²₁: 3.84).",
        ""])


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--B", type=int, default=19)
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--seeds", type=int, default=SEEDS_PER_BLOCK)
    ap.add_argument("--report-only", action="store_true")
    a = ap.parse_args(argv)
    if a.report_only:
        df = pd.read_csv(OUT / "slip_jump_bootstrap.csv")
    else:
        import concealed
        import slip_jump_bootstrap as me
        from joblib import Parallel, delayed
        from tqdm import tqdm

        todo = [delayed(me.case)(c, s, a.B) for c in VALVES for b in BLOCKS
                for s in range(b, b + a.seeds)]
        todo += [delayed(me.case)(c, s, a.B, f) for f in concealed.FAMILIES for c in VALVES
                 for s in range(FAMILY_SEEDS)]
        df = pd.DataFrame(list(tqdm(Parallel(n_jobs=a.jobs, return_as="generator")(todo),
                                    total=len(todo), desc="bootstrap")))
        with atomic_path(OUT / "slip_jump_bootstrap.csv") as tmp:
            df.to_csv(tmp, index=False, lineterminator="\n", float_format="%.6g")
    text = report(df, a.B)
    write_text(OUT / "slip_jump_bootstrap.md", text)
    print(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
