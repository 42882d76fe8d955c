"""The published stiction detectors on randomised simulated flow loops: detectability
against the valve's stick band, false alarms by cause.

The shared real loops are mostly flow loops (ISDB CHEM, the refinery's FIC tags), and two
detectors apply only there: Yamashita with PV standing in for MV, and Hägglund's shape
analysis, whose premise (the control error follows the valve because the process is
fast against the oscillation) holds only in flow loops. This experiment checks every
published detector on flow loops made by :func:`stictionbench.simulate`, an independent
source that no threshold was set on, randomised over what plants vary:

- process: gain 0.5–2, time constant 0.3–5 s, dead time 0.2–2 s;
- PI: gain 0.1–0.6 over the process gain, integral time 2–30 s, executing every 0.1, 0.2,
  0.5 or 1 s (the historian keeps one sample a second);
- transmitter: white noise 0.01–0.3 PV units, first-order lag 0–2 s (coloured noise);
- load: a first-order random walk of standard deviation 0–1 PV units;
- sticky valves: Kano, He and Choudhury two-parameter models, stick band ``S`` of 0.25,
  0.5, 1, 2, 4 and 8 % with slip jump ``J/S`` of 0.25–1;
- healthy loops: an ideal valve under a load only; under a sinusoidal disturbance of
  period 20–300 s and amplitude 0.5–5; a dead band (backlash) of 0.5–4 % (a valve fault,
  but not stiction: ISDB labels it so); and a tightly tuned PI (gain 1.5–3 over the
  process gain, integral time 0.5–2 s), oscillating on its own.

Every loop is given only ``t, SP, PV, OP`` (MV withheld) and the loop type ``F``. Per
method, and for the shipped consensus of ``batch`` (``conf/consensus/default.yaml``,
trained on the shared real loops, so out of sample here): the detection rate at each
stick band, the false-alarm rate by healthy cause, and the inconclusive rates, with
Wilson 95 % intervals; a figure of detection against ``S``. Nothing is tuned here: each
detector runs with its paper's defaults.

Run: ``.venv/bin/python experiments/flow_loops.py [--per-cell 12] [--jobs 2]``; writes
``reports/real/flow_loops.md``, ``.csv`` and ``.png``.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np
import pandas as pd

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

import stictionbench as sb  # noqa: E402
from stictionbench.io import write_text  # noqa: E402
from stictionbench.rates import rate_text, wilson  # noqa: E402
from stictionbench.realdata.compare import METHODS, PUBLISHED  # noqa: E402
from stictionbench.realdata.consensus import Consensus, fit, score  # noqa: E402
from stictionbench.reports.figures import new_figure, save_png  # noqa: E402
from stictionbench.reports.tables import to_markdown  # noqa: E402

#: stick bands S (% of span) of the sticky valves
BANDS = (0.25, 0.5, 1.0, 2.0, 4.0, 8.0)
STICKY = ("kano", "he", "choudhury")
HEALTHY = ("load", "sinusoid", "deadband", "tight")
#: every published method (the two that fit a Hammerstein model share one fit per loop)
DETECTORS = PUBLISHED
#: the methods and the shipped consensus of ``batch``, in the order of the tables
COLUMNS = (*DETECTORS, "consensus")
DURATION = 3000.0
SEED0 = 20000
#: the controlled check: ideal-valve loops under a load (drawn as ``load``), one of load
#: and transmitter noise set on a grid, the other held at the middle of its range
CONTROLLED = {"load": "disturbance.load_std", "noise": "sensor.noise_std"}
GRID = {"load": (0.05, 0.3, 1.0), "noise": (0.01, 0.05, 0.2)}
HELD = {"load": 0.3, "noise": 0.05}
CONTROLLED_LOOPS = 24


def draw(kind: str, i: int) -> tuple[list[str], dict]:
    """The overrides of loop ``i`` of ``kind`` (a sticky valve name or a healthy cause)
    and its drawn parameters; every draw comes from its own seeded generator."""
    rng = np.random.default_rng([SEED0, (STICKY + HEALTHY).index(kind), i])
    K = float(np.exp(rng.uniform(np.log(0.5), np.log(2.0))))
    tau = float(np.exp(rng.uniform(np.log(0.3), np.log(5.0))))
    theta = float(rng.uniform(0.2, 2.0))
    rate = float(rng.choice([0.1, 0.2, 0.5, 1.0]))
    kc = float(rng.uniform(0.1, 0.6)) / K
    ti = float(np.exp(rng.uniform(np.log(2.0), np.log(30.0))))
    if kind == "tight":
        kc, ti = float(rng.uniform(1.5, 3.0)) / K, float(rng.uniform(0.5, 2.0))
    p = {"kind": kind, "K": K, "tau": tau, "theta": theta, "pi_period": rate, "kc": kc,
         "ti": ti}
    return loop_draw(kind, i, rng, p, (K, tau, theta), BANDS, (20.0, 300.0))


def loop_draw(kind: str, i: int, rng: np.random.Generator, p: dict,
              process: tuple[float, float, float], bands: tuple[float, ...],
              sine_periods: tuple[float, float]) -> tuple[list[str], dict]:
    """The overrides of loop ``i`` of ``kind`` and its parameters ``p``, once its process
    (``process``: gain, time constant, dead time) and PI (``p``: ``pi_period``, ``kc``,
    ``ti``) are drawn: the transmitter's noise and lag and the load are drawn next from
    ``rng``, then the disturbance and valve (:func:`fault_overrides`); the set point is
    constant. Shared by the flow, level and pressure loops' draws."""
    gain, tau, theta = process
    p.update(noise=float(np.exp(rng.uniform(np.log(0.01), np.log(0.3)))),
             sensor_lag=float(rng.choice([0.0, 0.5, 2.0])), load=float(rng.uniform(0.0, 1.0)),
             S=0.0, J=0.0)
    ov = [f"process.gain={gain:.6g}", f"process.time_constant={tau:.6g}",
          f"process.dead_time={theta:.6g}", f"controller.kc={p['kc']:.6g}",
          f"controller.ti={p['ti']:.6g}", f"controller.sample_time={p['pi_period']:g}",
          "sensor=noisy", f"sensor.time_constant={p['sensor_lag']:g}",
          f"sensor.noise_std={p['noise']:.6g}", "setpoint=constant"]
    return ov + fault_overrides(kind, i, rng, p, bands, sine_periods), p


def fault_overrides(kind: str, i: int, rng: np.random.Generator, p: dict,
                    bands: tuple[float, ...], sine_periods: tuple[float, float]
                    ) -> list[str]:
    """The disturbance and valve overrides of loop ``i`` of ``kind`` (drawn from ``rng``
    after the loop's process and PI; ``p`` gets the drawn values): a sinusoid of period
    log-uniform in ``sine_periods`` on top of the load, or the load alone; a sticky
    valve with ``S = bands[i % len(bands)]``, a dead band, or an ideal valve."""
    load = p["load"]
    if kind == "sinusoid":
        amp = float(rng.uniform(0.5, 5.0))
        per = float(np.exp(rng.uniform(np.log(sine_periods[0]), np.log(sine_periods[1]))))
        ov = ["disturbance=sinusoidal", f"disturbance.amplitude={amp:.6g}",
              f"disturbance.period={per:.6g}", f"disturbance.load_std={load:.6g}",
              "disturbance.load_time_constant=300.0"]
        p.update(sine_amplitude=amp, sine_period=per)
    else:
        ov = ["disturbance=load", f"disturbance.load_std={load:.6g}",
              "disturbance.load_time_constant=300.0"]
    if kind in STICKY:
        S = float(bands[i % len(bands)])
        J = S * float(rng.uniform(0.25, 1.0))
        ov += [f"valve={kind}", f"valve.S={S:g}", f"valve.J={J:.6g}"]
        p.update(S=S, J=J)
    elif kind == "deadband":
        d = float(rng.uniform(0.5, 4.0))
        ov += ["valve=deadband", f"valve.deadband={d:.6g}"]
        p.update(deadband=d)
    else:
        ov += ["valve=linear"]
    return ov


def one_loop(kind: str, i: int, consensus: Consensus, set_to: dict | None = None, *,
             drawn: tuple[list[str], dict] | None = None, loop_type: str = "F",
             seed0: int = SEED0, duration: float = DURATION,
             sample_time: float = 1.0) -> dict:
    """Every published method's call on flow loop ``i`` of ``kind``, and the
    ``consensus`` of their calls; ``set_to`` replaces drawn values (``load``, ``noise``)
    for the controlled check. ``drawn`` (overrides and parameters) and ``loop_type``
    replace this module's flow-loop draw for another kind of loop, simulated from
    ``seed0 + i`` for ``duration`` seconds recorded every ``sample_time``
    (``experiments/level_loops.py``)."""
    ov, p = drawn if drawn is not None else draw(kind, i)
    for key, value in (set_to or {}).items():
        tag = CONTROLLED[key]
        ov = [f"{tag}={value:g}" if o.startswith(tag + "=") else o for o in ov]
        p[key] = value
    r = sb.simulate("linear", duration=duration, seed=seed0 + i, sample_time=sample_time,
                    overrides=ov)
    label = "stiction" if kind in STICKY else "no_stiction"
    rec = sb.Recording.from_arrays(r.t, r.PV, r.OP, SP=r.SP, warn=False,
                                   meta={"label": label, "loop_type": loop_type})
    out = dict(p, label=label, i=i, pv_std=float(np.std(r.PV)))
    for m in DETECTORS:
        try:
            c = METHODS[m](rec, loop_type)
            out[m], out[m + "_reason"] = c.verdict, c.reason
        except Exception as exc:  # noqa: BLE001 - a method failing is a result to count
            out[m], out[m + "_reason"] = "inconclusive", " ".join(str(exc).split())[:60]
    out["consensus"], out["consensus_reason"] = consensus.decide(out)
    return out


def _rate(v: pd.Series, what: str) -> str:
    return rate_text(int((v == what).sum()), len(v))


def summarise(df: pd.DataFrame) -> tuple[pd.DataFrame, pd.DataFrame]:
    """Detection by stick band and false alarms by healthy cause, per method."""
    st = df[df["label"] == "stiction"]
    det = []
    for S, sub in st.groupby("S", sort=True):
        row = {"S %": S, "loops": len(sub)}
        for m in COLUMNS:
            row[m] = _rate(sub[m], "stiction")
        det.append(row)
    fa = []
    for kind in HEALTHY:
        sub = df[df["kind"] == kind]
        row = {"healthy loop": kind, "loops": len(sub)}
        for m in COLUMNS:
            row[m] = _rate(sub[m], "stiction")
        fa.append(row)
    return pd.DataFrame(det), pd.DataFrame(fa)


def overall(df: pd.DataFrame) -> pd.DataFrame:
    """Per method over all loops: detected, false alarms, inconclusive, the same two rates
    among the loops the method decided, and the balanced accuracy counting an
    inconclusive answer as wrong."""
    rows = []
    st, ns = df[df["label"] == "stiction"], df[df["label"] == "no_stiction"]
    for m in COLUMNS:
        d = int((st[m] == "stiction").sum())
        f = int((ns[m] == "stiction").sum())
        tn = int((ns[m] == "no_stiction").sum())
        rows.append({"method": m, "detected": rate_text(d, len(st)),
                     "false_alarms": rate_text(f, len(ns)),
                     "inconclusive": rate_text(int((df[m] == "inconclusive").sum()), len(df)),
                     "detected of decided": rate_text(d, int((st[m] != "inconclusive").sum())),
                     "false alarms of decided": rate_text(
                         f, int((ns[m] != "inconclusive").sum())),
                     "balanced_accuracy": round(0.5 * (d / len(st) + tn / len(ns)), 3)})
    return pd.DataFrame(rows)


def figure(df: pd.DataFrame, path: Path,
           title: str = "Published detectors on randomised simulated flow loops") -> None:
    """Detection against the stick band (left) and false alarms by healthy cause (right),
    with Wilson 95 % intervals."""
    fig, (ax, bx) = new_figure(1, 2, figsize=(11.0, 4.2))
    st = df[df["label"] == "stiction"]
    for j, m in enumerate(COLUMNS):
        g = st.groupby("S", sort=True)[m]
        k = g.apply(lambda v: int((v == "stiction").sum()))
        n = g.size()
        lo_hi = np.array([wilson(int(a), int(b)) for a, b in zip(k, n, strict=True)])
        line = ax.errorbar(k.index * (1 + 0.03 * j), k / n,
                           yerr=[k / n - lo_hi[:, 0], lo_hi[:, 1] - k / n], marker="o",
                           ms=3, capsize=2, label=m)
        rates, err = [], [[], []]
        for kind in HEALTHY:
            v = df.loc[df["kind"] == kind, m]
            f, lo, hi = (v == "stiction").mean(), *wilson(int((v == "stiction").sum()), len(v))
            rates.append(f)
            err[0].append(f - lo)
            err[1].append(hi - f)
        x = np.arange(len(HEALTHY)) + (j - len(COLUMNS) / 2) * 0.08
        bx.bar(x, rates, width=0.08, yerr=err, capsize=1.5, color=line[0].get_color())
    ax.set_xscale("log")
    ax.set_xlabel("stick band S, % of span (Kano, He, Choudhury valves)")
    ax.set_ylabel("sticky valves: stiction named")
    ax.set_ylim(-0.02, 1.02)
    ax.legend(fontsize=7, ncol=2)
    bx.set_xticks(np.arange(len(HEALTHY)), HEALTHY)
    bx.set_xlabel("healthy loops, by cause")
    bx.set_ylabel("healthy loops: stiction named (false alarm)")
    bx.set_ylim(0, 1.02)
    fig.suptitle(f"{title} (Wilson 95 %)")
    save_png(fig, path)


#: healthy loops whose valve is ideal: what moves PV is the disturbance, not the valve
IDEAL_VALVE = ("load", "sinusoid")


def false_alarms_by(df: pd.DataFrame, column: str, edges: list[float]) -> pd.DataFrame:
    """False alarms of each method on the ideal-valve healthy loops (:data:`IDEAL_VALVE`),
    by bins of ``column`` (closed on the right)."""
    h = df[df["kind"].isin(IDEAL_VALVE)]
    bins = pd.cut(h[column], edges, include_lowest=True)
    rows = []
    for m in COLUMNS:
        row = {"method": m}
        for b, v in h[m].groupby(bins, observed=False):
            row[f"{column} {max(b.left, 0.0):g}–{b.right:g}"] = _rate(v, "stiction")
        rows.append(row)
    return pd.DataFrame(rows)


def controlled(rows: list[dict]) -> pd.DataFrame:
    """Stiction named on the ideal-valve loops of the controlled check, per varied factor
    and value, for the methods that read PV for MV and the consensus."""
    df = pd.DataFrame(rows)
    out = []
    for (factor, value), g in df.groupby(["varied", "value"], sort=False):
        held = "noise" if factor == "load" else "load"
        row = {"varied": factor, "value": value, "held": f"{held} {HELD[held]:g}",
               "loops": len(g)}
        for m in ("kano", "yamashita", "consensus"):
            k = int((g[m] == "stiction").sum())
            row[m] = rate_text(k, len(g))
        out.append(row)
    return pd.DataFrame(out)


def consensus_text(c: Consensus) -> str:
    """``"horch + he, share ≥ 0.67, ≥ 1 vote(s)"``."""
    return f"{' + '.join(c.methods)}, share ≥ {c.threshold:.2f}, ≥ {c.min_votes} vote(s)"


def trained_here(df: pd.DataFrame, real: Path, name: str = "these simulated flow loops"
                 ) -> tuple[Consensus, pd.DataFrame]:
    """The consensus fitted on these simulated loops (:func:`~stictionbench.realdata.
    consensus.fit`, the search that trains the shipped one) and its scores here
    (in-sample) and on the real loops of ``real/comparison_<dataset>.csv`` (written by
    ``stictionbench compare``; out of sample: no real loop took part in the fit)."""
    c = fit(df)
    rows = [{"scored_on": name, "out_of_sample": False,
             **score(c, df)}]
    for f in sorted(real.glob("comparison_*.csv")):
        loops = pd.read_csv(f).set_index("loop")
        rows.append({"scored_on": f.stem.removeprefix("comparison_"), "out_of_sample": True,
                     **score(c, loops)})
    return c, pd.DataFrame(rows)


def reasons(df: pd.DataFrame, top: int = 4) -> pd.DataFrame:
    """The most frequent reasons each method gave, with their counts."""
    rows = []
    for m in COLUMNS:
        vc = df[m + "_reason"].value_counts().head(top)
        rows.append({"method": m, "reasons (count)": "; ".join(f"{r} ({c})"
                                                              for r, c in vc.items())})
    return pd.DataFrame(rows)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--per-cell", type=int, default=12,
                    help="loops per (valve model, stick band) and 3x that per healthy cause")
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--out", default=str(ROOT / "reports" / "real"))
    ap.add_argument("--real", default=str(ROOT / "reports" / "real"),
                    help="folder of stictionbench compare's comparison_<dataset>.csv")
    a = ap.parse_args(argv)
    from joblib import Parallel, delayed
    from tqdm import tqdm

    jobs = [(k, i) for k in STICKY for i in range(a.per_cell * len(BANDS))]
    jobs += [(k, i) for k in HEALTHY for i in range(3 * a.per_cell)]
    cons = Consensus.load()
    rows = list(tqdm(Parallel(n_jobs=a.jobs, return_as="generator")(
        delayed(one_loop)(k, i, cons) for k, i in jobs), total=len(jobs), desc="flow loops"))
    df = pd.DataFrame(rows)
    cjobs = [(f, v, i) for f in GRID for v in GRID[f] for i in range(CONTROLLED_LOOPS)]
    crows = list(tqdm(Parallel(n_jobs=a.jobs, return_as="generator")(
        delayed(one_loop)("load", 1000 + i, cons,
                          {f: v, **{h: HELD[h] for h in HELD if h != f}})
        for f, v, i in cjobs), total=len(cjobs), desc="controlled"))
    for r, (f, v, _) in zip(crows, cjobs, strict=True):
        r.update(varied=f, value=v)
    ctl = controlled(crows)
    det, fa = summarise(df)
    tot = overall(df)
    sim_c, sim_scores = trained_here(df, Path(a.real))
    out = Path(a.out)
    figure(df, out / "flow_loops.png")
    lines = [
        "# Published detectors on randomised simulated flow loops", "",
        f"Generated by `experiments/flow_loops.py` (`make real`): {len(df)} simulated flow "
        f"loops ({int((df['label'] == 'stiction').sum())} with a sticky valve, "
        f"{int((df['label'] == 'no_stiction').sum())} healthy), randomised over process, "
        "PI tuning and execution rate, noise level and colour, load, valve model and effect "
        "size (the ranges are in the script's docstring). Loop type `F`, MV withheld, each "
        "detector with its paper's defaults; no threshold was set on these loops. "
        f"`consensus` is the shipped verdict of `batch` (`conf/consensus/default.yaml`: "
        f"{' + '.join(cons.methods)}, share ≥ {cons.threshold:.2f}), trained on the shared "
        "real loops: its numbers here are out of sample. Rates with Wilson 95 % intervals.",
        "",
        "![detection against the stick band](flow_loops.png)", "",
        "## Overall", "", to_markdown(tot), "",
        "## Stiction named, by stick band S (% of span)", "", to_markdown(det), "",
        "## Stiction named on healthy loops, by cause", "", to_markdown(fa), "",
        "## A consensus trained on these loops, scored on the real loops", "",
        "The same search that trains the shipped consensus on the real loops "
        "(`stictionbench.realdata.consensus.fit`: method subset, share and votes by "
        "balanced accuracy), run on these simulated loops instead: "
        f"{consensus_text(sim_c)}. Its scores on the real loops are out of sample (the real "
        "verdicts come "
        "from `stictionbench compare`, the same calls as in "
        "[comparison.md](comparison.md)); balanced accuracy by loop, an inconclusive "
        "verdict counted as not flagged.", "",
        to_markdown(sim_scores), "",
        "## Why the methods answered as they did", "", to_markdown(reasons(df)), "",
        "## False alarms on ideal valves, against the load and against the noise", "",
        "Yamashita's premise here is that PV stands in for the unrecorded MV. In a flow "
        "loop under load that fails: the PI holds the flow at its set point by moving the "
        "valve against the load, so OP moves while PV stays within its noise band, the "
        "'OP moves, valve steady' pattern of a stuck valve. If that is the cause, its "
        "false alarms on ideal-valve loops (causes `load` and `sinusoid`) grow with the "
        "load's standard deviation (PV units). The other candidate is the transmitter "
        "noise, whose band reads as steady and can hide small valve moves. The two tables "
        "bin the same loops by each; both vary at random across the loops, and so do the "
        "tuning and the PI rate, so neither table is a controlled experiment.", "",
        to_markdown(false_alarms_by(df, "load", [0.0, 0.2, 0.5, 1.0])), "",
        to_markdown(false_alarms_by(df, "noise", [0.0, 0.03, 0.1, 0.3])), "",
        "The controlled check: ideal-valve loops under a load, drawn as `load` (seeds "
        f"{SEED0 + 1000}–{SEED0 + 999 + CONTROLLED_LOOPS}, the same {CONTROLLED_LOOPS} "
        "processes, tunings and PI rates in every cell), with either the load or the "
        "transmitter noise set on a grid and the other held; stiction named by the two "
        "methods that read PV for MV and by the shipped consensus:", "",
        to_markdown(ctl), "",
        "Healthy causes: `load` an ideal valve under a random-walk load; `sinusoid` an "
        "external sinusoidal disturbance of period 20–300 s; `deadband` a backlash valve "
        "(a valve fault without slip jump); `tight` an over-tuned PI oscillating on its own.",
        "",
    ]
    write_text(out / "flow_loops.md", "\n".join(lines))
    write_text(out / "flow_loops.csv", df.to_csv(index=False, lineterminator="\n",
                                                 float_format="%.6g"))
    print("\n".join(lines))
    return 0


if __name__ == "__main__":
    sys.exit(main())
