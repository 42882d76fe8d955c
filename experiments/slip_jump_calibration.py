"""Calibration of the slip-jump test: how often a true dead band (J = 0) rejects J = 0.

Stiction and dead band are nested (a dead band is the stick-slip valve with slip jump
``J = 0``, the play operator), and ``diagnose`` decides between them by the
likelihood-ratio test of ``J = 0`` from the closed-loop valve identification
(``tests.slip_jump_zero``; stiction when its p-value is under alpha = 0.05, the fitted J
is at least a tenth of S and the stiction fit beats the nominal model on its own:
``evidence.select``). ``holdout_pooled.md`` shows level-2 dead bands named stiction
several times as often as sticky valves are named a dead band.

Under ``J = 0`` a calibrated test rejects at rate alpha. This script reads the stored
p-values — no diagnosis is run — of every dead-band and stiction recording of the three
tuning families (``reports/concealed/results.csv``, ``make concealed``'s seeds) and of
the holdout family's pooled blocks (``reports/concealed/holdout_pooled.csv``), and
reports, per family and level, the rejection rate at alpha 0.05, 0.01 and 0.001 for the
dead bands (the size: alpha if calibrated) and for the sticky valves (the power), with
the final verdicts beside them. Nothing is tuned here; it is the measurement behind a
lead, not a rule.

One candidate cause is varied (:data:`RULE_BLOCKS`, diagnosed here): with a model given
the stick-slip valve is searched under three stop rules (``hammerstein.STOP_RULES``) and
the best one tested against the play operator, so the alternative is a choice among
non-nested models, not one extra parameter. The holdout family's dead-band and stiction
recordings of blocks 16000–19000 (seen blocks: a mechanism check, not a score) are
diagnosed as shipped and with the search restricted to the play operator's own rule
(``reversal``, Kano's), where J = 0 is exactly nested.

Run: ``.venv/bin/python experiments/slip_jump_calibration.py [--jobs 2]`` (about 3 min
on 2 cores; ``--stored-only`` runs no diagnosis and reads the variation's CSV). Outputs
``reports/concealed/slip_jump_calibration.{md,csv,png}`` and
``slip_jump_rules.csv``.
"""

from __future__ import annotations

import argparse
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
ALPHAS = (0.05, 0.01, 0.001)
VALVES = ("deadband", "stiction")
#: holdout blocks of the stop-rule variation (12 seeds per class and level each)
RULE_BLOCKS = (16000, 17000, 18000, 19000)
RULE_VARIANTS = {"shipped": "three stop rules searched (shipped)",
                 "reversal_only": "the play operator's rule only (reversal)"}


def rule_case(cls: str, level: int, seed: int, variant: str) -> dict:
    """One holdout recording diagnosed with its model, the stop rules searched by
    ``variant`` (:data:`RULE_VARIANTS`); set on every call, since a worker keeps the
    module state of its previous task."""
    import holdout_family as hf

    from stictionbench.diagnosis import diagnose, hammerstein, load_model
    from stictionbench.io import read_recording

    if not hasattr(hammerstein, "_shipped_searched_rules"):
        hammerstein._shipped_searched_rules = hammerstein.searched_rules
    hammerstein.searched_rules = (hammerstein._shipped_searched_rules
                                  if variant == "shipped" else lambda held: (0,))
    with tempfile.TemporaryDirectory() as tmp:
        job = hf.generate(cls, level, seed, Path(tmp))
        d = diagnose(read_recording(job["csv"]), load_model(job["model"]))
    hammerstein.searched_rules = hammerstein._shipped_searched_rules
    h = d.details.get("hammerstein") or {}
    return {"class": cls, "level": level, "seed": seed, "variant": variant,
            "valve_model": job["valve_model"], "stop_rule": h.get("stop_rule"),
            "slip_jump_p": d.tests.get("slip_jump_zero", {}).get("p_value"),
            "pick": d.missing_physics}


def rule_table(rules: pd.DataFrame) -> pd.DataFrame:
    rows = []
    for (variant, cls, lvl), g in rules.groupby(["variant", "class", "level"], sort=False):
        other = "stiction" if cls == "deadband" else "deadband"
        rows.append({"search": RULE_VARIANTS[variant], "valve (truth)": cls, "level": lvl,
                     "p < 0.05": rate_text(int((g.slip_jump_p < 0.05).sum()), len(g)),
                     f"named {cls}": rate_text(int((g.pick == cls).sum()), len(g)),
                     f"named {other}": rate_text(int((g.pick == other).sum()), len(g))})
    return pd.DataFrame(rows)


def rule_lines(rules: pd.DataFrame) -> list[str]:
    """The stop-rule variation: its table and, as shipped, the dead bands' rejection
    rate by the rule chosen."""
    sh = rules[(rules.variant == "shipped") & (rules["class"] == "deadband")]
    by_rule = "; ".join(
        f"{r} {rate_text(int((g.slip_jump_p < 0.05).sum()), len(g))}"
        for r, g in sh.groupby("stop_rule"))
    ro = rules[(rules.variant == "reversal_only") & (rules["class"] == "deadband")]
    nested = sh.stop_rule == "reversal"
    nested_rate = float((sh.slip_jump_p[nested] < 0.05).mean()) if nested.any() else 0.0
    other_rate = float((sh.slip_jump_p[~nested] < 0.05).mean()) if (~nested).any() else 0.0
    by_model = "; ".join(
        f"{m} {stiction_named(g, 'reversal_only')} against {stiction_named(g, 'shipped')}"
        for m, g in rules[rules["class"] == "stiction"].groupby("valve_model"))
    return [
        "## One candidate varied: the choice among stop rules",
        "",
        "The holdout family's dead-band and stiction recordings of blocks "
        f"{', '.join(map(str, RULE_BLOCKS))} diagnosed as shipped and with the valve "
        "searched under the play operator's own stop rule only (where J = 0 is exactly "
        "nested); the p-values of this section are those of this run.",
        "",
        to_markdown(rule_table(rules)),
        "",
        f"- dead bands rejecting J = 0 at 0.05 as shipped, by the stop rule chosen: "
        f"{by_rule};",
        f"- with the reversal rule only: "
        f"{rate_text(int((ro.slip_jump_p < 0.05).sum()), len(ro))} (as shipped "
        f"{rate_text(int((sh.slip_jump_p < 0.05).sum()), len(sh))}).",
        "",
        "Reading: "
        + ("dead bands that chose another stop rule reject J = 0 more often than those "
           "that chose the nested one" if other_rate > nested_rate else
           "dead bands that chose another stop rule reject J = 0 no more often than "
           "those that chose the nested one")
        + (", and restricting the search lowers the rejection rate"
           if (ro.slip_jump_p < 0.05).sum() < (sh.slip_jump_p < 0.05).sum() else
           ", and restricting the search does not lower the rejection rate")
        + f", but not to alpha ({(ro.slip_jump_p < 0.05).mean():.0%} against 5 %): the "
        "choice among non-nested stop rules accounts for part of the excess at most. "
        "Sticky valves named stiction with the restricted search: "
        f"{stiction_named(rules, 'reversal_only')} against {stiction_named(rules, 'shipped')} "
        f"as shipped (by the valve model that made them: {by_model}), so the restriction "
        "is no remedy.",
        ""]


def stiction_named(rules: pd.DataFrame, variant: str) -> str:
    g = rules[(rules.variant == variant) & (rules["class"] == "stiction")]
    return f"{int((g.pick == 'stiction').sum())}/{len(g)}"


def load() -> pd.DataFrame:
    """Dead-band and stiction recordings with their slip-jump p-value and verdict."""
    fam = pd.read_csv(OUT / "results.csv")
    hold = pd.read_csv(OUT / "holdout_pooled.csv").assign(family="holdout")
    if "slip_jump_p" not in hold:
        raise SystemExit("holdout_pooled.csv has no slip_jump_p column: run "
                         "experiments/holdout_pooled.py first")
    cols = ["family", "class", "level", "seed", "slip_jump_p", "predicted_default"]
    df = pd.concat([fam[cols], hold[cols]], ignore_index=True)
    return df[df["class"].isin(VALVES) & df.slip_jump_p.notna()].reset_index(drop=True)


def table(df: pd.DataFrame) -> pd.DataFrame:
    rows = []
    for (family, lvl, cls), g in df.groupby(["family", "level", "class"], sort=True):
        n = len(g)
        r = {"family": family, "level": lvl, "valve (truth)": cls, "recordings": n}
        for a in ALPHAS:
            r[f"p < {a:g}"] = rate_text(int((g.slip_jump_p < a).sum()), n)
        other = "stiction" if cls == "deadband" else "deadband"
        sticky = g[g.predicted_default.isin(VALVES)]
        r["named a sticky valve"] = rate_text(len(sticky), n)
        r[f"of those, named {other}"] = rate_text(
            int((sticky.predicted_default == other).sum()), len(sticky))
        rows.append(r)
    return pd.DataFrame(rows)


def figure(df: pd.DataFrame, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 2, figsize=(9, 3.8), sharey=True)
    for ax, cls in zip(axes, VALVES, strict=True):
        for family, g in df[df["class"] == cls].groupby("family"):
            p = np.sort(g.slip_jump_p.to_numpy())
            ax.step(p, np.arange(1, p.size + 1) / p.size, where="post",
                    label=f"{family} ({p.size})")
        if cls == "deadband":
            x = np.logspace(-4, 0, 50)
            ax.plot(x, x, "k:", lw=1, label="calibrated (J = 0 true)")
        ax.set_xscale("log")
        ax.set_xlim(1e-4, 1)
        ax.set_xlabel("slip-jump p-value (J = 0)")
        ax.set_title(f"true {cls}")
        ax.axvline(0.05, color="grey", lw=0.8)
    axes[0].set_ylabel("fraction of recordings with p ≤ x")
    axes[0].legend(fontsize=7)
    fig.tight_layout()
    with atomic_path(path) as tmp:
        fig.savefig(tmp, dpi=120, format="png")
    plt.close(fig)


def report(df: pd.DataFrame, tab: pd.DataFrame, rules: pd.DataFrame | None = None) -> str:
    db = df[df["class"] == "deadband"]
    fam, hold = db[db.family != "holdout"], db[db.family == "holdout"]
    st = df[df["class"] == "stiction"]
    lines = [
        "# Calibration of the slip-jump test (stiction against dead band)",
        "",
        "Generated by `experiments/slip_jump_calibration.py` (the question in its "
        "docstring): the stored p-value of the likelihood-ratio test of J = 0 for every "
        "dead-band and stiction recording of the three tuning families (`results.csv`, "
        "`make concealed`'s seeds) and the holdout family's pooled blocks "
        "(`holdout_pooled.csv`), diagnosed with the model given. Under J = 0 (a true dead "
        "band) a calibrated test rejects at rate alpha. Wilson 95 % intervals; nothing is "
        "tuned here.",
        "",
        "![p-values](slip_jump_calibration.png)",
        "",
        to_markdown(tab),
        "",
        f"- true dead bands rejecting J = 0 at alpha 0.05: tuning families "
        f"{rate_text(int((fam.slip_jump_p < 0.05).sum()), len(fam))}, holdout family "
        f"{rate_text(int((hold.slip_jump_p < 0.05).sum()), len(hold))}; at alpha 0.001: "
        f"{rate_text(int((fam.slip_jump_p < 0.001).sum()), len(fam))} and "
        f"{rate_text(int((hold.slip_jump_p < 0.001).sum()), len(hold))};",
        f"- true sticky valves rejecting J = 0 at alpha 0.05, all families: "
        f"{rate_text(int((st.slip_jump_p < 0.05).sum()), len(st))}.",
        "",
        "Reading: the test is not calibrated — a dead band rejects J = 0 several times "
        "as often as alpha — as the likelihood-ratio tests against the nominal model are "
        "not ([lr_calibration.md](lr_calibration.md)). Candidates, not varied here: the "
        "Gaussian likelihood of innovations whitened by a fitted AR model counts a "
        "misspecified noise model and the error of a discrete valve replay as white "
        "noise, and a slip jump is one more parameter to absorb them; the holdout "
        "family's dead band is a play operator run at 0.1 s under a PI at 1 s; and the "
        "choice among stop rules (varied in the next section). The "
        "decision's other conditions (J at least a tenth "
        "of S, the stiction fit significant on its own) hold the final dead band → "
        "stiction rate below the raw rejection rate. A calibrated test of J = 0 (a "
        "parametric bootstrap of the play-operator loop, or a noise model checked on "
        "validation) is a lead; a smaller alpha for J alone, set on the tuning families, "
        "would not move there, since their dead bands are rarely named stiction.",
        ""]
    if rules is not None:
        lines += rule_lines(rules)
    return "\n".join(lines)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--stored-only", action="store_true",
                    help="no diagnosis: the stored p-values, and the rule variation "
                         "from slip_jump_rules.csv when present")
    a = ap.parse_args(argv)
    df = load()
    tab = table(df)
    rules = None
    if a.stored_only:
        if (OUT / "slip_jump_rules.csv").is_file():
            rules = pd.read_csv(OUT / "slip_jump_rules.csv")
    else:
        # the tasks by reference to this module imported by name (see band_magnitude.py)
        import slip_jump_calibration as me
        from joblib import Parallel, delayed
        from tqdm import tqdm

        todo = [delayed(me.rule_case)(c, lvl, s, v) for v in RULE_VARIANTS for c in VALVES
                for lvl in (1, 2) for b in RULE_BLOCKS for s in range(b, b + 12)]
        rules = pd.DataFrame(list(tqdm(Parallel(n_jobs=a.jobs, return_as="generator")(todo),
                                       total=len(todo), desc="stop rules")))
        with atomic_path(OUT / "slip_jump_rules.csv") as tmp:
            rules.to_csv(tmp, index=False, lineterminator="\n", float_format="%.6g")
    with atomic_path(OUT / "slip_jump_calibration.csv") as tmp:
        df.to_csv(tmp, index=False, lineterminator="\n", float_format="%.6g")
    figure(df, OUT / "slip_jump_calibration.png")
    text = report(df, tab, rules)
    write_text(OUT / "slip_jump_calibration.md", text)
    print(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
