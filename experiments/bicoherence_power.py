"""Can the bicoherence test see a sticky valve's limit cycle at the lengths plants give?

``choudhury`` in the real-loop comparison (:mod:`stictionbench.realdata.panel`) answered
"Gaussian (NGI ≤ 0): no nonlinearity" on 13 of the 14 ISDB loops, nine of them labelled
stiction, and on every refinery window. Is that answer evidence against a sticky valve?
Two suspected causes of a Gaussian answer on a limit cycle, each checked by varying it:

- **too few segments**: each squared bicoherence is significant above
  ``c_α = χ²₂(α)/(2K)`` with ``K`` segments (0.21 at K = 14, a 1000-sample record with
  the published nfft 128 and 50 % overlap), and ``NGI = Σ_{bic² > c_α} bic² / L − c_α``
  (:func:`stictionbench.estimators.bicoherence.nonlinearity_indices`) exceeds zero only
  when a share of the whole principal domain larger than ``c_α`` is significant. Varied:
  the record length, 751 to 4096 samples with the estimator's defaults (which use at most
  4096), and 16384 and 32768 samples with that cap lifted (K up to 511);
- **a symmetric cycle**: a stick-slip limit cycle of a self-regulating loop is nearly
  symmetric (odd harmonics), and third-order statistics see only quadratic phase
  coupling (``reports/REPLICATION.md`` §7). Varied: the same sticky records at 4096
  samples read through a quadratic sensor ``x + b·σ·(z² − 1)`` (``b`` 0.1–0.4), which
  makes the cycle asymmetric; reported: the skewness of each PV.

Loops whose answer is known: the paper's FOPDT loop under PI at a constant set point
(regulatory operation, measurement noise and a random-walk load), with a two-parameter
(Kano) stick-slip valve of S = 3–9 % and J = S/2 (a self-sustained limit cycle: the sticky
valves), and with a linear valve in the well-tuned and the tightly tuned loop (the linear
loops). Every record is cut to its last N samples and tested with the published defaults
(nfft 128, 50 % overlap, α = 0.05, NGI > 0.001 and NLI > 0.01). Per length: the share of
sticky valves found non-Gaussian (the test's power), the share found nonlinear, and the
same shares on the linear loops (its false rate), with Wilson 95 % intervals. Nothing is
tuned on the real loops; the rule drawn from it
(:func:`stictionbench.realdata.panel._choudhury`: a Gaussian answer is inconclusive,
not "no stiction") is then scored on them.

Run: ``.venv/bin/python experiments/bicoherence_power.py [--seeds 8] [--jobs 2]``; writes
``bicoherence_power.md``, ``.csv`` and ``.png`` to ``--out`` (default ``reports/real/``).
"""

from __future__ import annotations

import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pandas as pd  # noqa: E402
from scipy.stats import skew  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "experiments"))

from fast_loops import parse_args, run_loops  # noqa: E402

import stictionbench as sb  # noqa: E402
from stictionbench.estimators import make  # noqa: E402
from stictionbench.estimators.oscillation import acf_oscillation  # noqa: E402
from stictionbench.io import write_text  # noqa: E402
from stictionbench.rates import rate_text, wilson  # noqa: E402
from stictionbench.reports.tables import to_markdown  # noqa: E402

#: record lengths (samples at 1 s): ISDB records run 1000–18000, refinery windows 751;
#: the estimator's defaults use at most 4096 samples, lifted for the longer ones
LENGTHS = (751, 1000, 2000, 4096, 16384, 32768)
CAP = 4096
#: (case, valve keywords, label): sticky valves in the well-tuned loop, linear loops
LOOPS = [("linear", {"valve": "kano", "valve__S": s, "valve__J": s / 2}, f"kano S={s:g}")
         for s in (3.0, 6.0, 9.0)] + [("linear", {}, "linear"), ("tight", {}, "tight")]
SEED0 = 500


#: quadratic read-out ``b`` of the asymmetry check, in standard deviations of the record
ASYMMETRY = (0.1, 0.2, 0.4)


def bicoherence_row(x: np.ndarray, op: np.ndarray) -> dict:
    """The bicoherence test on ``x`` under both readings of NGI, and the record's
    oscillation and skewness."""
    n = x.size
    cut = sb.Recording.from_arrays(np.arange(n, dtype=float), x, op, warn=False)
    kw = {"max_samples": None if n > CAP else CAP}
    r = make("bicoherence", **kw).estimate(cut, x="PV")
    # the other reading of NGI: the mean over the significant bic² only
    alt = make("bicoherence", ngi_average="significant", **kw).estimate(cut, x="PV")
    d = r.diagnostics
    return {"samples": n, "segments": int(d["k_segments"]),
            "bic2_threshold": float(d["bic2_threshold"]), "ngi": float(d["ngi"]),
            "nli": float(d["nli"]), "non_gaussian": bool(d["non_gaussian"]),
            "nonlinear": bool(r.decision),
            "oscillating": bool(acf_oscillation(x - x.mean()).oscillating),
            "skewness": float(skew(x)),
            "non_gaussian_significant_mean": bool(alt.diagnostics["non_gaussian"]),
            "nonlinear_significant_mean": bool(alt.decision)}


def run_one(k: int, seed: int) -> list[dict]:
    """One simulated loop (``LOOPS[k]``), tested at every length of :data:`LENGTHS`, and
    at :data:`CAP` samples read through a quadratic sensor ``x + b·σ·(z² − 1)``
    (``z`` the standardised record) for every ``b`` of :data:`ASYMMETRY`: a cycle made
    asymmetric, with the quadratic phase coupling third-order statistics can see."""
    case, kw, what = LOOPS[k]
    rec = sb.simulate(case, duration=float(max(LENGTHS) + 400), seed=SEED0 + seed,
                      sample_time=1.0, sensor="noisy", setpoint="constant",
                      disturbance="load", disturbance__load_std=0.5, **kw)
    pv, op = np.asarray(rec.PV, float), np.asarray(rec.OP, float)
    base = {"loop": what, "sticky": "kano" in what, "seed": seed}
    rows = [base | {"asymmetry": 0.0} | bicoherence_row(pv[-n:], op[-n:]) for n in LENGTHS]
    x = pv[-CAP:]
    z = (x - x.mean()) / x.std()
    rows += [base | {"asymmetry": b} | bicoherence_row(x + b * x.std() * (z * z - 1), op[-CAP:])
             for b in ASYMMETRY]
    return rows


def asymmetry_table(df: pd.DataFrame) -> pd.DataFrame:
    """Per loop kind and quadratic read-out ``b`` (at :data:`CAP` samples): the share
    called non-Gaussian and nonlinear, and the median |skewness|."""
    g = df[df.samples == CAP]
    rows = []
    for (sticky, b), x in g.groupby(["sticky", "asymmetry"]):
        rows.append({"loops": "sticky valves" if sticky else "linear loops",
                     "quadratic read-out b": b,
                     "median abs(skewness)": round(float(x.skewness.abs().median()), 2),
                     "non-Gaussian (NGI > 0.001)": rate_text(int(x.non_gaussian.sum()), len(x)),
                     "nonlinear (NGI and NLI)": rate_text(int(x.nonlinear.sum()), len(x))})
    return pd.DataFrame(rows).sort_values(["loops", "quadratic read-out b"],
                                          ascending=[False, True])


def summarise(df: pd.DataFrame) -> pd.DataFrame:
    rows = []
    for (sticky, n), g in df.groupby(["sticky", "samples"]):
        rows.append({"loops": "sticky valves" if sticky else "linear loops", "samples": n,
                     "segments K": int(g.segments.median()),
                     "c_α": round(float(g.bic2_threshold.median()), 3),
                     "oscillating": rate_text(int(g.oscillating.sum()), len(g)),
                     "non-Gaussian (NGI > 0.001)": rate_text(int(g.non_gaussian.sum()), len(g)),
                     "nonlinear (NGI and NLI)": rate_text(int(g.nonlinear.sum()), len(g)),
                     "median NGI": round(float(g.ngi.median()), 4),
                     "median NLI": round(float(g.nli.median()), 3),
                     "median abs(skewness)": round(float(g.skewness.abs().median()), 2)})
    return pd.DataFrame(rows).sort_values(["loops", "samples"], ascending=[False, True])


def figure(df: pd.DataFrame, path: Path) -> None:
    fig, ax = plt.subplots(figsize=(7, 4))
    for sticky, style in ((True, "o-"), (False, "s--")):
        g = df[df.sticky == sticky].groupby("samples").non_gaussian
        n, k = g.size(), g.sum()
        ci = np.array([wilson(int(a), int(b)) for a, b in zip(k, n, strict=True)])
        lo, hi = ci[:, 0], ci[:, 1]
        p = k / n
        ax.errorbar(n.index, p, yerr=[p - lo, hi - p], fmt=style,
                    capsize=3, label="sticky valves (power)" if sticky
                    else "linear loops (false rate)")
    ax.set_xscale("log")
    ax.axvline(CAP, color="grey", lw=0.8, ls=":")
    ax.set_xlabel("record length (samples; the defaults use at most 4096, lifted beyond)")
    ax.set_ylabel("share called non-Gaussian")
    ax.set_ylim(-0.05, 1.05)
    ax.set_title("Choudhury's Gaussianity test (NGI > 0.001) against record length")
    ax.legend()
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=100)
    plt.close(fig)


def main(argv=None) -> int:
    a = parse_args("bicoherence_power", __doc__, argv, seeds=8,
                   out=ROOT / "reports" / "real")
    if a is None:
        return 2
    jobs = [(k, s) for k in range(len(LOOPS)) for s in range(a.seeds)]
    rows = [r for rs in run_loops(run_one, jobs, a.jobs, "loops") for r in rs]
    df = pd.DataFrame(rows).sort_values(["loop", "seed", "samples"]).reset_index(drop=True)
    asym = asymmetry_table(df)
    df_len = df[df.asymmetry == 0.0]
    tab = summarise(df_len)
    out = Path(a.out)
    figure(df_len, out / "bicoherence_power.png")
    sticky = df_len[df_len.sticky]
    linear = df_len[~df_len.sticky]
    skewed = df[df.sticky & (df.asymmetry == max(ASYMMETRY))]
    short = sticky[sticky.samples <= CAP]
    long_ = sticky[sticky.samples > CAP]
    lines = [
        "# The bicoherence test's power against record length", "",
        "Generated by `experiments/bicoherence_power.py` (`make real`; the design is in its "
        f"docstring): {a.seeds} seeds per loop, the paper's loop at a constant set point "
        "with noise and a random-walk load; sticky valves are Kano valves of S = 3, 6 and "
        "9 % with J = S/2, linear loops the well-tuned and the tightly tuned PI. The "
        "estimator runs with its published defaults (nfft 128, 50 % overlap, α = 0.05, "
        f"NGI > 0.001, NLI > 0.01, at most {CAP} samples; the cap lifted for the longer "
        "records).", "",
        "- sticky valves called non-Gaussian at 751–4096 samples (the lengths of the real "
        f"records after the cap): {rate_text(int(short.non_gaussian.sum()), len(short))}",
        "- the same limit cycles at 16384 and 32768 samples with the cap lifted (K up to "
        f"511 segments): {rate_text(int(long_.non_gaussian.sum()), len(long_))}; median "
        f"|skewness| of their PV {float(sticky.skewness.abs().median()):.2f}. More segments "
        "do not give the test its power.",
        "- the cycles' symmetry, varied: the same 4096-sample sticky records read through "
        f"a quadratic sensor (b = {max(ASYMMETRY):g}) are called non-Gaussian in "
        f"{rate_text(int(skewed.non_gaussian.sum()), len(skewed))} (table below): the test "
        "sees quadratic phase coupling when there is some, and a nearly symmetric "
        "stick-slip cycle has little (third-order statistics miss odd-harmonic coupling; "
        "`reports/REPLICATION.md` §7). The linear loops read the same way mostly stay "
        "Gaussian, though their skewness grows more: the test responds to the coupling "
        "of a cycle's harmonics, not to skewness.",
        "- the other reading of NGI (the mean over the significant bic² only, "
        "`ngi_average=\"significant\"`, as the algorithm notes word it) calls almost every loop "
        "nonlinear: sticky valves "
        f"{rate_text(int(sticky.nonlinear_significant_mean.sum()), len(sticky))}, linear "
        f"loops {rate_text(int(linear.nonlinear_significant_mean.sum()), len(linear))} "
        "(that mean exceeds c_α by construction, so only NLI decides): it does not separate "
        "them either.",
        "- a Gaussian answer is therefore no evidence against a sticky valve: `choudhury` "
        "in `stictionbench compare` / `batch` answers *inconclusive*, not *no stiction*; "
        "a non-Gaussian but linear answer (NLI ≤ 0.01) still counts against stiction.", "",
        "![power](bicoherence_power.png)", "", to_markdown(tab), "",
        "Symmetry varied (4096 samples; a quadratic read-out x + b·σ·(z² − 1)):", "",
        to_markdown(asym), ""]
    write_text(out / "bicoherence_power.md", "\n".join(lines))
    write_text(out / "bicoherence_power.csv",
               df.to_csv(index=False, lineterminator="\n", float_format="%.6g"))
    print("\n".join(lines))
    return 0


if __name__ == "__main__":
    sys.exit(main())
