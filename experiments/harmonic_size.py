"""The harmonic F-test's scan (:func:`stictionbench.diagnosis.harmonic.line_test`) checked
by varying what its size and power depend on: the time–half-bandwidth product NW, the
record's length N and the noise's spectrum, with a line's amplitude varied for power.

Why: ``diagnose(..., line_test=True)`` waives the disturbance's 10 % NRMSE gate where the
scan finds a line (``experiments/harmonic_line.py``), so the scan's false-alarm rate is
the option's. The test's reference distribution, F(2, 2K−2) at each frequency, assumes a
spectrum flat across the tapers' band ±W = ±NW/(N·Ts) (Thomson 1982; Percival & Walden
1993, §10.11); the scan's Bonferroni correction over every grid point is ours. A closed
loop's residual is not flat: it drifts (load) and may carry a resonant peak (an
underdamped loop). Nothing is tuned here; the defaults (NW = 4, K = 7, 4× zero padding)
are Thomson's and stay whatever this shows.

Design (seeds explicit, one per cell): noise kinds *white*; *ar1* (AR(1), φ = 0.9);
*drift* (a random walk through a first-order lag plus white noise, the shape of a drifting
load on PV); *quantised* (white, rounded to steps of one standard deviation); *resonant*
(AR(2) with poles at radius 0.97 and period 40 samples plus white noise: an underdamped
loop's peak, wider than the tapers' band at every N here). N ∈ {600, 1500, 3000} at
Ts = 1 s, NW ∈ {2, 3, 4, 5}; the scan from 4 cycles per record to a period of 6 samples.
Size: 300 records per cell, the rate of scan p < 0.05. Power: a sinusoid of amplitude
A × (the noise's standard deviation) at a period log-uniform in [8, N/8] samples and a
random phase, in *ar1* and *resonant* noise, 150 records per cell; found = scan p < 0.05
and the period within 5 %.

**Prediction, written before the run.** Size at most 5 % (the Wilson interval reaching
below 0.05) for white, ar1, drift and quantised noise at every NW and N; for the
resonant noise the size above 5 % at N = 600 for NW ≥ 4 (there the peak is the least
resolved against the band). Power rises with A, N and (weakly) with smaller NW; at
N = 3000 and NW = 4 a line of A = 0.2 is found at least half the time in ar1 noise.

Run: ``.venv/bin/python experiments/harmonic_size.py [--jobs 2] [--reuse]``; writes
``reports/concealed/harmonic_size.{md,csv,png}`` (a few minutes on 2 cores).
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pandas as pd
from scipy.signal import lfilter

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "experiments"))

from fresh_recordings import jobs_reuse_args, publish, run  # noqa: E402

from stictionbench.diagnosis.harmonic import line_test  # noqa: E402
from stictionbench.rates import rate_text, wilson  # noqa: E402
from stictionbench.reports.figures import new_figure, save_png  # noqa: E402
from stictionbench.reports.tables import to_markdown  # noqa: E402

OUT = ROOT / "reports" / "concealed" / "harmonic_size"
NOISES = ("white", "ar1", "drift", "quantised", "resonant")
POWER_NOISES = ("ar1", "resonant")
LENGTHS = (600, 1500, 3000)
NWS = (2.0, 3.0, 4.0, 5.0)
AMPLITUDES = (0.05, 0.1, 0.15, 0.2, 0.3, 0.5)
SIZE_REPS, POWER_REPS, SEED = 300, 150, 20261203
ALPHA = 0.05


def noise(kind: str, n: int, rng: np.random.Generator) -> np.ndarray:
    """A line-free series of ``kind`` (see the module docstring), unit variance."""
    e = rng.normal(size=n + 500)
    if kind == "white":
        x = e
    elif kind == "ar1":
        x = lfilter([1.0], [1.0, -0.9], e)
    elif kind == "drift":
        x = lfilter([0.1], [1.0, -0.9], np.cumsum(e) * 0.05) + rng.normal(size=n + 500)
    elif kind == "quantised":
        x = np.round(e)
    elif kind == "resonant":
        r, w0 = 0.97, 2 * np.pi / 40
        x = lfilter([1.0], [1.0, -2 * r * np.cos(w0), r * r], e) * 0.1 \
            + rng.normal(size=n + 500)
    else:
        raise ValueError(f"unknown noise kind {kind!r}")
    x = x[500:]
    return (x - x.mean()) / x.std()


#: the planted line's period range (samples) by band: the whole scan, its fast and its
#: slow end (the check added after the run, see :func:`cases`)
BANDS = {"all": lambda n: (8.0, n / 8.0), "short": lambda n: (8.0, 30.0),
         "long": lambda n: (n / 30.0, n / 8.0)}


def cell(study: str, kind: str, n: int, nw: float, amp: float, reps: int,
         seed: int, band: str = "all") -> dict:
    """One cell: ``reps`` records, the rate the scan calls a line (size) or finds the
    planted one (power), its period log-uniform over ``band``."""
    rng = np.random.default_rng(seed)
    t = np.arange(n, dtype=float)
    p_lo, p_hi = BANDS[band](n)
    hits = 0
    for _ in range(reps):
        x = noise(kind, n, rng)
        period = float(np.exp(rng.uniform(np.log(p_lo), np.log(p_hi))))
        if amp > 0:
            x = x + amp * np.sin(2 * np.pi * t / period + rng.uniform(0, 2 * np.pi))
        lt = line_test(x, 1.0, 4.0 / n, 1.0 / 6.0, nw=nw)
        ok = lt is not None and lt.p_value < ALPHA
        if amp > 0:
            ok = ok and abs(lt.period_s - period) / period < 0.05
        hits += bool(ok)
    lo, hi = wilson(hits, reps)
    return {"study": study, "noise": kind, "n": n, "nw": nw, "amplitude": amp,
            "band": band, "records": reps, "hits": hits, "rate": hits / reps, "lo": lo, "hi": hi}


def cases(size_reps: int = SIZE_REPS, power_reps: int = POWER_REPS) -> list[tuple]:
    """Every cell with its own seed (the cell's index from :data:`SEED`)."""
    todo = [("size", k, n, nw, 0.0, size_reps) for k in NOISES for n in LENGTHS
            for nw in NWS]
    todo += [("power", k, n, nw, a, power_reps) for k in POWER_NOISES for n in LENGTHS
             for nw in NWS for a in AMPLITUDES]
    # added after the run, to check its explanation of the low power in red noise (a
    # line competes with the noise's spectrum at its own frequency, high at long
    # periods): the period's band varied alone, white against ar1, N = 3000, NW = 4
    band = [("band", k, 3000, 4.0, a, power_reps, b) for k in ("white", "ar1")
            for a in AMPLITUDES for b in ("short", "long")]
    return ([(*c, SEED + i) for i, c in enumerate(todo)]
            + [(*c[:6], SEED + len(todo) + i, c[6]) for i, c in enumerate(band)])


def prediction(df: pd.DataFrame) -> tuple[bool, str]:
    s = df[df.study == "size"]
    smooth = s[s.noise != "resonant"]
    over = smooth[smooth.lo > ALPHA]
    res = s[(s.noise == "resonant") & (s.n == 600) & (s.nw >= 4)]
    p = df[(df.study == "power") & (df.noise == "ar1") & (df.n == 3000) & (df.nw == 4)
           & (df.amplitude == 0.2)]
    held = over.empty and bool((res.rate > ALPHA).all()) and float(p.rate.iloc[0]) >= 0.5
    text = (f"smooth noise cells whose size interval lies above 0.05: {len(over)} of "
            f"{len(smooth)} (predicted 0); resonant noise at N = 600, NW ≥ 4: size "
            + ", ".join(f"{r.rate:.3f}" for r in res.itertuples())
            + " (predicted above 0.05); ar1, N = 3000, NW = 4, A = 0.2: found "
            f"{p.rate.iloc[0]:.2f} (predicted at least 0.5)")
    return held, text


def size_table(df: pd.DataFrame) -> pd.DataFrame:
    s = df[df.study == "size"]
    rows = []
    for (kind, n), g in s.groupby(["noise", "n"], sort=False):
        row = {"noise": kind, "N": n}
        for r in g.itertuples():
            row[f"NW {r.nw:g}"] = rate_text(r.hits, r.records)
        rows.append(row)
    return pd.DataFrame(rows)


def power_table(df: pd.DataFrame) -> pd.DataFrame:
    p = df[df.study == "power"]
    rows = []
    for (kind, n, nw), g in p.groupby(["noise", "n", "nw"], sort=False):
        row = {"noise": kind, "N": n, "NW": f"{nw:g}"}
        for r in g.itertuples():
            row[f"A {r.amplitude:g}"] = f"{r.rate:.2f} [{r.lo:.2f}, {r.hi:.2f}]"
        rows.append(row)
    return pd.DataFrame(rows)


def band_table(df: pd.DataFrame) -> pd.DataFrame:
    """The check added after the run: power by the planted period's band."""
    p = df[df.study == "band"]
    rows = []
    for (kind, band), g in p.groupby(["noise", "band"], sort=False):
        row = {"noise": kind, "period band (samples)": "{:g}–{:g}".format(*BANDS[band](3000))}
        for r in g.itertuples():
            row[f"A {r.amplitude:g}"] = f"{r.rate:.2f} [{r.lo:.2f}, {r.hi:.2f}]"
        rows.append(row)
    return pd.DataFrame(rows)


def figure(df: pd.DataFrame, path: Path) -> None:
    p = df[df.study == "power"]
    fig, axes = new_figure(len(POWER_NOISES), len(LENGTHS), figsize=(10, 5.5),
                           sharex=True, sharey=True)
    for i, kind in enumerate(POWER_NOISES):
        for j, n in enumerate(LENGTHS):
            ax = axes[i, j]
            for nw in NWS:
                g = p[(p.noise == kind) & (p.n == n) & (p.nw == nw)]
                ax.errorbar(g.amplitude, g.rate, yerr=[g.rate - g.lo, g.hi - g.rate],
                            marker="o", ms=3, capsize=2, label=f"NW {nw:g}")
            ax.set_title(f"{kind} noise, N = {n}")
            ax.set_ylim(-0.02, 1.02)
            if i == len(POWER_NOISES) - 1:
                ax.set_xlabel("line amplitude / noise std")
            if j == 0:
                ax.set_ylabel("line found (p < 0.05, period ±5 %)")
    axes[0, 0].legend(loc="lower right")
    fig.suptitle("Thomson's harmonic F-test scan: detectability of a line")
    save_png(fig, path)


def report(df: pd.DataFrame) -> str:
    held, text = prediction(df)
    return "\n".join([
        "# The harmonic F-test's scan: size and power varied", "",
        "Generated by `experiments/harmonic_size.py` (design, prediction written before "
        "the run: its docstring). Size: the rate at which the scan (Bonferroni over every "
        "grid frequency, `line_test`) gives p < 0.05 on line-free noise; power: the rate "
        "it finds a planted sinusoid (p < 0.05, period within 5 %). Wilson 95 % "
        "intervals. Synthetic noise only; the rates on recordings are in "
        "[harmonic_line.md](harmonic_line.md).", "",
        "## The prediction", "", ("Held" if held else "Not held") + f": {text}.", "",
        "## Size (line-free noise)", "", to_markdown(size_table(df)), "",
        "## Power (a line of amplitude A × the noise's standard deviation)", "",
        to_markdown(power_table(df)), "",
        "## Added after the run: the period's band varied alone", "",
        "The prediction's power was wrong. Its explanation, written after the run: a "
        "line competes with the noise's spectrum at its own frequency, and red noise "
        "is high at long periods, so an amplitude measured against the noise's whole "
        "standard deviation overstates a slow line's visibility; and the F(2, 2K−2) "
        "reference has few degrees of freedom at small NW (F ≈ 400 needed at NW 2 for "
        "p < 0.05 after the scan's correction over ~2000 grid frequencies), so power "
        "rose with NW, not with smaller NW as predicted. The first part checked "
        "by varying the planted period's band alone, white against ar1 noise, N = 3000, "
        "NW = 4: if it holds, the two bands find alike in white noise and the long band "
        "far less in ar1.", "", to_markdown(band_table(df)), "",
        "![detectability](harmonic_size.png)", "",
    ]) + "\n"


def main(argv: list[str] | None = None) -> int:
    args = jobs_reuse_args(__doc__, "re-make the report and figure from the stored CSV",
                           argv)
    csv = OUT.with_suffix(".csv")
    if args.reuse and csv.exists():
        df = pd.read_csv(csv)
    else:
        df = run(cell, cases(), args.jobs)
    figure(df, OUT.with_suffix(".png"))
    publish(df, report(df), OUT)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
