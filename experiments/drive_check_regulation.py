"""Why the one-sided drive test fires where OP does drive PV: regulation, not lag 0.

``experiments/op_drives_pv.py`` measured a test that OP drives PV (Haugh's statistic over
the lags at which OP leads PV, each series pre-whitened by its own noise model; Pierce &
Haugh 1977) and found it firing on a sticky refinery flow loop and two sticky ISDB loops.
Its report offered two explanations, neither checked: a flow that answers within one
sample (the dependence at lag 0, which the one-sided test leaves out), and a limit cycle
flattened by the pre-whitening. This experiment checks them by varying what each depends
on, and tests a third that follows from the theory of feedback between time series.

The third explanation. In a loop whose controller is the only source of OP's movement
(constant set point, no dither), OP is a function of PV's past (and present). Then the
univariate innovation of PV at ``t + k`` (``k ≥ 1``) is orthogonal to PV's past and so to
OP's past: OP adds nothing to PV's prediction that PV's own past does not carry, and the
cross-correlation of the two pre-whitened series vanishes at every lag at which OP leads.
The test cannot reject "OP does not lead PV" however strongly the valve moves PV (Caines &
Chan, "Feedback between stationary stochastic processes", *IEEE TAC* 20 (1975) 498–508;
Ljung, *System Identification*, 2nd ed., ch. 13: a closed loop is informative only with an
external excitation or a nonlinear or switching controller). Set-point steps are such an
excitation; a sticky valve is a nonlinearity the linear pre-whitening cannot absorb.

Predictions, varied in simulation (a flow-like FOPDT loop, τ = 2 s, θ = 0.5 s, PI at
0.1 s, random-walk load, white PV noise, 30 000 s, recorded at 0.5 … 10 s by point
sampling, 10 seeds per cell):

- the regulation explanation: a healthy valve that moves PV fires often at a constant set
  point and (almost) never with set-point steps, at every sampling;
- the lag-0 explanation: firing grows with the sampling interval (the response completes
  within one sample once ``Ts ≫ θ + τ``), for a sticky valve too;
- the whitening explanation: each record is tested twice, pre-whitened as shipped (the
  noise model's BIC order) and by a fixed AR(30); on the real loops it is also checked by
  recording at half and a quarter of the rate (the whitening filter's order and the
  cycle's samples per period change with it);
- the controller's rate: a PI at 0.5 s and at 1 s with the record held at 1 s (the
  feedback argument is exact when OP is computed from the recorded PV alone).

Real loops: the 14 ISDB loops, the refinery windows and the factory loops of
``op_drives_pv.py`` (its recordings, ``pairing_check.py``'s loader), the test at the
recorded rate and decimated by 2 and 4 (point sampling, as a historian; at least 200
samples), beside the set point's travel in standard deviations of the control error
(:func:`stictionbench.diagnosis.process.setpoint_excitation`; 3 is the diagnosis's
threshold for an excited record).

Nothing here is tuned: α = 0.05, the pairing test's windows without a model.

Run: ``.venv/bin/python experiments/drive_check_regulation.py [--jobs 2] [--reuse]``;
writes ``reports/diagnose/drive_check_regulation.{md,csv,png}``.
"""

from __future__ import annotations

import contextlib
import sys
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pandas as pd

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "experiments"))

from fresh_recordings import jobs_reuse_args, publish, rate_line, stored_or_made  # noqa: E402

from stictionbench.rates import rate_text  # noqa: E402
from stictionbench.reports.tables import to_markdown  # noqa: E402

STEM = ROOT / "reports" / "diagnose" / "drive_check_regulation"
ALPHA = 0.05
SEEDS = 10
DURATION = 30600.0  # 3000 samples at 10 s after a 600 s start
SAMPLINGS = (0.5, 1.0, 2.0, 5.0, 10.0)
NOISES = (0.05, 0.5)
VALVES = ("linear", "sticky")
EXCITATIONS = ("constant", "steps")
DECIMATIONS = (1, 2, 4)
MIN_SAMPLES = 200
#: samples per simulated record at every sampling (the last ones): the test's power
#: grows with the record, so the record's length is held fixed while the rate varies
N_SAMPLES = 3000
#: the PI's period in the sampling grid; the periods tried at :data:`RATE_TS` recording
CONTROLLER_PERIOD = 0.1
CONTROLLER_PERIODS = (0.1, 0.5, 1.0)
RATE_TS = 1.0
#: the pre-whitenings compared: the shipped one (BIC order, None) and a long fixed AR
WHITENINGS: dict[str, int | None] = {"BIC (shipped)": None, "AR(30)": 30}
#: the flow-like loop: FOPDT and PI (seconds), the sticky valve's S and J (% of span)
LOOP = ("process.time_constant=2", "process.dead_time=0.5", "process.gain=1",
        "controller.kc=0.3", "controller.ti=2", "sensor=noisy", "sensor.time_constant=0.1",
        "disturbance=load", "disturbance.load_time_constant=30", "setpoint=constant",
        "sample_time=0.1")
STICKY = ("valve=kano", "valve.S=3", "valve.J=1")
#: set-point steps of ±5 % every 1500 s (20 in the record), off the sampling grid
STEP_EVERY, STEP_SIZE, FIRST_STEP = 1500.0, 5.0, 103.7


def _overrides(valve: str, excitation: str, noise: float) -> list[str]:
    ov = [*LOOP, f"sensor.noise_std={noise}"]
    ov += list(STICKY) if valve == "sticky" else ["valve=linear"]
    if excitation == "steps":
        times = np.arange(FIRST_STEP, DURATION, STEP_EVERY)
        steps = [[round(float(t), 1), STEP_SIZE * (-1) ** i] for i, t in enumerate(times)]
        ov.append("setpoint.steps=" + str(steps).replace(" ", ""))
    return ov


def _sampled(rec, k: int, last: int | None = None):
    """``rec`` point-sampled every ``k``-th sample, its ``last`` samples (all: None)."""
    from stictionbench.recording import Recording

    cut = slice(-last if last else None, None)
    sp = None if rec.SP is None else rec.SP[::k][cut]
    return Recording.from_arrays(rec.t[::k][cut], rec.PV[::k][cut], rec.OP[::k][cut], SP=sp)


@contextlib.contextmanager
def _whitening(order: int | None) -> Iterator[None]:
    """Each series pre-whitened by the shipped noise model (BIC order, integrated where
    BIC says: ``order`` None) or by a Yule–Walker AR of fixed ``order`` (statsmodels'
    Levinson–Durbin); patched inside the worker, where the test runs."""
    from statsmodels.tsa.stattools import acovf, levinson_durbin

    from stictionbench.diagnosis import noise

    if order is None:
        yield
        return

    def fixed(x: np.ndarray, max_order: int) -> tuple[np.ndarray, float, float]:
        x = np.asarray(x, float) - float(np.mean(x))
        _, _, _, sig, phis = levinson_durbin(acovf(x, fft=True, nlag=order), nlags=order,
                                             isacov=True)
        return np.r_[1.0, -np.asarray(phis, float)[1:order + 1, order]], float(sig[order]), 0.0

    saved = noise._ar_fit, noise.fit_noise_model
    shipped = noise.fit_noise_model
    noise._ar_fit = fixed
    noise.fit_noise_model = lambda x, **_: shipped(x, max_order=order, allow_integrated=False)
    try:
        yield
    finally:
        noise._ar_fit, noise.fit_noise_model = saved


def _tests(r, dead_time: float | None = None,
           time_constant: float | None = None) -> dict[str, dict]:
    """The pairing test on ``r`` under each pre-whitening of :data:`WHITENINGS`."""
    from stictionbench.diagnosis.routes import pairing_test

    out = {}
    for name, order in WHITENINGS.items():
        with _whitening(order):
            out[name] = pairing_test(r, ALPHA, dead_time, time_constant)
    return out


def sim_one(job: dict) -> list[dict]:
    """One simulated loop recorded at every sampling of :data:`SAMPLINGS`."""
    from stictionbench.diagnosis.process import setpoint_excitation
    from stictionbench.sim import simulate

    hc = job.get("controller_period", CONTROLLER_PERIOD)
    ov = _overrides(job["valve"], job["excitation"], job["noise"])
    if hc != CONTROLLER_PERIOD:  # the controller's rate varied, recorded at RATE_TS only
        ov = [o for o in ov if not o.startswith("sample_time=")]
        ov += [f"controller.sample_time={hc}", f"sample_time={RATE_TS}"]
    rec = simulate("linear", duration=DURATION, seed=job["seed"], overrides=ov)
    kind = "sim" if hc == CONTROLLER_PERIOD else "rate"
    rows = []
    for ts in (SAMPLINGS if kind == "sim" else (RATE_TS,)):
        r = _sampled(rec, round(ts / float(rec.Ts)), N_SAMPLES)
        for whitening, t in _tests(r, 0.5, 2.0).items():
            rows.append({**job, "kind": kind, "whitening": whitening,
                         "controller_period": hc, "Ts": ts, "p_op_leads": t["p_op_leads"],
                         "fires": not t["op_drives_pv"], "peak_lag": t["peak_lag"],
                         "setpoint_excitation": setpoint_excitation(r),
                         "mv_pp": float(np.ptp(rec.MV))})
    return rows


def real_one(job: dict) -> list[dict]:
    """One real loop at its recorded rate and decimated by :data:`DECIMATIONS`."""
    import pairing_check as pc

    from stictionbench.diagnosis.process import setpoint_excitation

    rec, _ = pc.recording(job)
    rows = []
    for k in DECIMATIONS:
        if len(rec) // k < MIN_SAMPLES:
            continue
        r = _sampled(rec, k) if k > 1 else rec
        for whitening, t in _tests(r).items():
            rows.append({"kind": "real", "whitening": whitening, "source": job["source"],
                         "name": job["name"], "decimation": k, "Ts": float(r.Ts),
                         "samples": len(r), "p_op_leads": t["p_op_leads"],
                         "fires": not t["op_drives_pv"], "peak_lag": t["peak_lag"],
                         "setpoint_excitation": setpoint_excitation(r)})
    return rows


def _job(kind: str, job: dict) -> list[dict]:
    return sim_one(job) if kind == "sim" else real_one(job)


def _run_all(todo: list[tuple[str, dict]], jobs: int) -> pd.DataFrame:
    """Every case on ``jobs`` workers, a progress bar by loop finished; one row per
    sampling of each loop."""
    from joblib import Parallel, delayed
    from tqdm import tqdm

    gen = Parallel(n_jobs=jobs, return_as="generator")(delayed(_job)(*c) for c in todo)
    return pd.DataFrame([r for rows in tqdm(gen, total=len(todo), desc="loops", unit="loop")
                         for r in rows])


def cases() -> list[tuple[str, dict]]:
    import pairing_check as pc

    sims = [("sim", {"valve": v, "excitation": e, "noise": n, "seed": s})
            for v in VALVES for e in EXCITATIONS for n in NOISES for s in range(SEEDS)]
    sims += [("sim", {"valve": "linear", "excitation": "constant", "noise": n, "seed": s,
                      "controller_period": hc})
             for hc in CONTROLLER_PERIODS if hc != CONTROLLER_PERIOD
             for n in NOISES for s in range(SEEDS)]
    real = [("real", j) for j in pc.jobs()
            if j["kind"] == "paired" and j["source"] in ("isdb", "refinery", "factory")]
    return sims + real


def _figure(sim: pd.DataFrame, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from stictionbench.io import atomic_path

    fig, axes = plt.subplots(len(WHITENINGS), len(NOISES), figsize=(10, 7), sharey=True,
                             sharex=True, squeeze=False)
    styles = {("linear", "constant"): "o-", ("linear", "steps"): "o--",
              ("sticky", "constant"): "s-", ("sticky", "steps"): "s--"}
    for row, whitening in zip(axes, WHITENINGS, strict=True):
        for ax, noise in zip(row, NOISES, strict=True):
            for i, ((valve, exc), fmt) in enumerate(styles.items()):
                g = sim[(sim.whitening == whitening) & (sim.noise == noise)
                        & (sim.valve == valve) & (sim.excitation == exc)]
                label = (f"{'healthy' if valve == 'linear' else 'sticky'} valve, "
                         f"{'set-point steps' if exc == 'steps' else 'constant SP'}")
                # each series a little apart on the log axis, so that none hides another
                rate_line(ax, g["fires"].astype(bool), g["Ts"] * 1.06 ** (i - 1.5), fmt,
                          label)
            ax.set_xscale("log")
            ax.axhline(ALPHA, color="grey", lw=0.8, ls=":")
            ax.set_title(f"PV noise σ = {noise} %, pre-whitening {whitening}", fontsize=9)
        row[0].set_ylabel("drive test fires")
    for ax in axes[-1]:
        ax.set_xlabel("recorded sample time (s)")
    axes[0][0].legend(fontsize=8)
    fig.suptitle("The one-sided drive test on a flow loop whose valve moves PV "
                 f"({N_SAMPLES} samples at each rate; Wilson 95 %)")
    fig.tight_layout()
    with atomic_path(path) as tmp:
        fig.savefig(tmp, dpi=110, format="png")
    plt.close(fig)


def _cell(g: pd.DataFrame) -> str:
    return rate_text(int(g["fires"].astype(bool).sum()), len(g))


def _sim_section(sim: pd.DataFrame, rate: pd.DataFrame) -> list[str]:
    rows = []
    for (whitening, valve, exc, noise), g in sim.groupby(
            ["whitening", "valve", "excitation", "noise"], sort=False):
        row = {"pre-whitening": whitening, "valve": valve, "set point": exc,
               "PV noise": noise}
        for ts, h in g.groupby("Ts"):
            row[f"Ts {ts:g} s"] = _cell(h)
        rows.append(row)
    shipped, long_ = list(WHITENINGS)
    hi, lo = max(NOISES), min(NOISES)

    def part(w: str, valve: str, exc: str, noise: float | None = None,
             ts: tuple[float, ...] = SAMPLINGS, frame: pd.DataFrame = sim) -> str:
        g = frame[(frame.whitening == w) & (frame.valve == valve) & (frame.excitation == exc)
                  & frame.Ts.isin(ts)]
        return _cell(g if noise is None else g[g.noise == noise])

    def by_rate(w: str) -> str:
        return "; ".join(
            f"PI every {hc:g} s: " + ", ".join(
                f"σ = {n:g} % {_cell(rate[(rate.whitening == w) & (rate.noise == n) & (rate.controller_period == hc)])}"  # noqa: E501
                for n in NOISES) for hc in CONTROLLER_PERIODS if hc != CONTROLLER_PERIOD)

    def spread(w: str, valve: str, exc: str) -> str:
        g = sim[(sim.whitening == w) & (sim.valve == valve) & (sim.excitation == exc)]
        r = g.groupby(["noise", "Ts"])["fires"].mean()
        return f"{100 * r.min():.0f}–{100 * r.max():.0f} %"

    coarse = (max(SAMPLINGS),)
    finer = tuple(t for t in SAMPLINGS if t < max(SAMPLINGS))
    return [
        "## 1. A flow loop whose valve moves PV, recorded at five rates", "",
        f"FOPDT τ = 2 s, θ = 0.5 s, PI at {CONTROLLER_PERIOD:g} s, random-walk load, "
        f"{SEEDS} seeds per cell, point-sampled, the last {N_SAMPLES} samples at each "
        "rate (the record's length held, so the rate is not confounded with the test's "
        f"power). The valve moves in every run (MV peak to peak {sim['mv_pp'].min():.1f}–"
        f"{sim['mv_pp'].max():.1f} %). Each record tested twice: pre-whitened as shipped "
        f"(the noise model's BIC order) and by a fixed {long_} (Yule–Walker).", "",
        to_markdown(pd.DataFrame(rows)), "",
        "![drive test by sampling](drive_check_regulation.png)", "",
        f"The controller's rate varied with the record's held at {RATE_TS:g} s (healthy "
        f"valve, constant set point; PI every {CONTROLLER_PERIOD:g} s is the table's "
        f"{RATE_TS:g} s column): {shipped}: {by_rate(shipped)}. {long_}: {by_rate(long_)}.",
        "", "Reading (each explanation against the parameter it depends on):", "",
        f"- **Feedback, by the set point.** With the long pre-whitening a healthy valve at "
        f"a constant set point fires on {part(long_, 'linear', 'constant')} of the "
        f"loop-rates ({spread(long_, 'linear', 'constant')} by cell), with set-point steps "
        f"on {part(long_, 'linear', 'steps')}. That is the docstring's argument: with "
        "nothing but the controller moving OP, OP is a function of PV's past, and the "
        "test cannot see a valve that moves PV by several per cent. Set-point steps are "
        "the excitation it needs.",
        f"- **The shipped pre-whitening, by its order.** As shipped the same healthy "
        f"loops fire on {part(shipped, 'linear', 'constant', hi)} with PV noise σ = "
        f"{hi:g} % but on {part(shipped, 'linear', 'constant', lo)} with σ = {lo:g} % "
        f"({long_}: {part(long_, 'linear', 'constant', hi)} and "
        f"{part(long_, 'linear', 'constant', lo)}), and with a PI at the record's own "
        f"rate ({RATE_TS:g} s) the shipped test rarely fires where the long one does "
        "(above). The BIC order leaves PV's residuals predictable, and OP's past then "
        "'leads' them: much of what the shipped test finds in regulation is the "
        "whitening's shortfall, not the valve. Haugh's test assumes each series "
        "whitened.",
        f"- **Lag 0, by the sampling.** A sticky valve almost never fires, at any rate "
        f"(shipped {part(shipped, 'sticky', 'constant')} and "
        f"{part(shipped, 'sticky', 'steps')}; {long_} {part(long_, 'sticky', 'constant')} "
        f"and {part(long_, 'sticky', 'steps')}: its nonlinearity is information a linear "
        "whitening leaves), so the lag-0 explanation offered for the sticky refinery "
        "flow loop is not reproduced. Lag 0 is seen once: the healthy valve with "
        f"set-point steps and σ = {lo:g} % at {max(SAMPLINGS):g} s only (shipped "
        f"{part(shipped, 'linear', 'steps', lo, coarse)}; finer rates "
        f"{part(shipped, 'linear', 'steps', lo, finer)}), where the loop's response "
        "(θ + 2τ = 4.5 s) ends within one sample.", ""]


def report(df: pd.DataFrame) -> str:
    sim = df[df.kind == "sim"].copy()
    rate = df[df.kind == "rate"].copy()
    real = df[df.kind == "real"].copy()
    shipped, long_ = list(WHITENINGS)
    lines = ["# Why the drive test fires where OP drives PV: feedback and whitening, "
             "not lag 0", "",
             "Made by `experiments/drive_check_regulation.py` (design and the theory in its "
             "docstring). *fires*: the one-sided Haugh test cannot reject, at α = 0.05, "
             "that OP leads PV at no lag (`tests.op_pv_dependence.op_drives_pv` false). "
             "Wilson 95 % intervals.", "", *_sim_section(sim, rate)]

    lines += ["## 2. Real loops at their rate and decimated", "",
              f"The pairing test without a model (its fixed window), at the recorded rate "
              f"and at 2× and 4× the sample time where at least {MIN_SAMPLES} samples "
              "remain, pre-whitened both ways; the set point's travel in standard "
              "deviations of the control error beside it.", ""]
    real["fires"] = real["fires"].astype(bool)
    wide = real.pivot_table(index=["source", "name"], columns=["whitening", "decimation"],
                            values="fires", aggfunc="first")
    at1 = real[(real.decimation == 1) & (real.whitening == shipped)]
    tab = pd.DataFrame({"set-point travel (σ of error)":
                        at1.set_index(["source", "name"])["setpoint_excitation"].round(1)})
    for w in WHITENINGS:
        for k in DECIMATIONS:
            if (w, k) in wide:
                tab[f"{w.split(' ')[0]} ×{k}"] = wide[(w, k)].map(
                    {True: "fires", False: "—"}).fillna("n/a")
    lines += [to_markdown(tab.reset_index()), ""]
    for w in WHITENINGS:
        one = real[(real.decimation == 1) & (real.whitening == w)]
        excited = one.setpoint_excitation >= 3.0
        both = wide[w].dropna(subset=[1, 2]) if (w, 2) in wide else wide.iloc[:0]
        flips = int((both[1].astype(bool) != both[2].astype(bool)).sum())
        lines.append(
            f"- {w}: fires on {_cell(one)} at the recorded rate (set-point travel ≥ 3 σ: "
            f"{_cell(one[excited])}; less: {_cell(one[~excited])}); the verdict at the "
            f"recorded rate and at half the rate differ on {rate_text(flips, len(both))} "
            "of the loops with both.")
    lines += ["", "## What this says", "",
              "- *fires* is not evidence that OP does not drive PV. With each series "
              "whitened, a regulatory loop whose valve moves PV fires on most records at "
              "every rate (section 1), as the feedback argument says: its OP carries no "
              "information about PV's future that PV's own past lacks. The loops at rest "
              "of `saturation_bounds` (constant set point) are in that condition too, so "
              "their firing cannot be credited to the valve at rest.",
              "- Where the shipped test does not fire in regulation, much of what it found "
              "is the BIC whitening's shortfall; its verdicts depend on the PV noise, the "
              "controller's rate and, on real windows, the sampling and the whitening "
              "(section 2).",
              "- Neither explanation offered for the real sticky loops holds: simulated "
              "sticky valves never fire, and the refinery loop that fires is set-point "
              "excited.",
              "- The test stays reported and changes no verdict "
              "(`routes.DRIVE_CHECK = False`); `docs/diagnosis.md` says what *fires* "
              "means and does not.", ""]
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    args = jobs_reuse_args(__doc__, "report from the stored drive_check_regulation.csv", argv)
    df = stored_or_made(STEM, args.reuse, lambda: _run_all(cases(), args.jobs))
    if df is None:
        return 2
    _figure(df[df.kind == "sim"], STEM.with_suffix(".png"))
    publish(df, report(df), STEM)
    return 0


if __name__ == "__main__":
    sys.exit(main())
