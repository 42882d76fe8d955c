"""Sweep throughput: wall time against the number of runs, with 1 and 2 joblib workers.

N runs spread evenly over the grid of ``conf/sweep/default.yaml`` (every valve, S,
tuning, noise and disturbance level) are launched through the same code as
``stictionbench sweep`` (plan → Hydra multirun with the joblib launcher, batches of runs
per Hydra job → one JSON row per run), into a temporary directory, for N in
:data:`SIZES`. Baseline, measured in the same session: the same runs in a plain Python
loop (:func:`stictionbench.sweep.runner.execute`: no Hydra, no joblib, no files). The
ratios show what Hydra, joblib and the per-run files cost and what the second worker
buys; the fit ``wall = a + b·N`` shows that the cost is linear in N.

Each runner is measured in its own child process with single-threaded BLAS (as joblib's
loky workers run): a BLAS pool of 2 threads in a process that shares 2 cores with others
slows the estimators' small solves by orders of magnitude, and pytest's own process is
not a clean place to time. In each child a 4-run warm-up comes first (imports, numba
caches, the loky pool), so the sizes are timed in the steady state; the warm-up itself
is reported as the cold start.

Writes ``reports/benchmarks/sweep.md`` and ``reports/benchmarks/sweep_scaling.png``.
Nothing is asserted about speed, only that every run finished.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

from stictionbench.io import write_text

ROOT = Path(__file__).resolve().parents[1]
REPORT = ROOT / "reports" / "benchmarks" / "sweep.md"
FIGURE = REPORT.with_name("sweep_scaling.png")
SIZES = (32, 96, 192)
REPEATS = 3  # each size is timed this many times; the median is reported
WORKERS = (1, 2)
SINGLE_THREAD = {k: "1" for k in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS",
                                  "MKL_NUM_THREADS", "NUMBA_NUM_THREADS")}


def _spread(runs: list, n: int) -> list:
    """``n`` runs spread evenly over the grid."""
    return [runs[i] for i in np.linspace(0, len(runs) - 1, n).round().astype(int)]


def _child(workers: int, sizes: list[int], tmp: str) -> dict:
    """In a child process: warm-up, then the wall time of each size (0 workers = loop)."""
    from stictionbench.sweep.launch import launch
    from stictionbench.sweep.plan import make_plan
    from stictionbench.sweep.runner import execute

    tmp_dir = Path(tmp)

    def sweep(n: int, tag: str) -> float:
        if workers == 0:
            runs = _spread(make_plan("default", []).runs, n)
            t0 = time.perf_counter()
            for r in runs:
                assert execute(r.id, r.spec)["status"] == "ok"
            return time.perf_counter() - t0
        plan = make_plan("default", [f"n_jobs={workers}", "progress=false",
                                     f"out_dir={tmp_dir / tag}", f"work_dir={tmp_dir / 'w'}"])
        counts = launch(plan, _spread(plan.runs, n))
        assert counts["ran"] == n and counts["errors"] == 0, counts
        return float(counts["wall_s"])

    cold = sweep(4, f"{workers}-cold")
    walls = {str(n): float(np.median([sweep(n, f"{workers}-{n}-{k}") for k in range(REPEATS)]))
             for n in sizes}
    return {"cold": cold, "walls": walls}


def _measure(workers: int, tmp: Path) -> dict:
    code = ("import json, sys; sys.path.insert(0, sys.argv[1]); import test_bench_sweep as m; "
            "print(json.dumps(m._child(int(sys.argv[2]), json.loads(sys.argv[3]), sys.argv[4])))")
    out = subprocess.run(
        [sys.executable, "-c", code, str(Path(__file__).parent), str(workers),
         json.dumps(list(SIZES)), str(tmp / f"child{workers}")],
        capture_output=True, text=True, env={**os.environ, **SINGLE_THREAD}, timeout=900,
        cwd=tmp)
    assert out.returncode == 0, out.stderr[-2000:]
    return json.loads(out.stdout.strip().splitlines()[-1])


def _loop_child(half: int, start: float) -> float:
    """In a child: wait until ``start`` (shared clock), run every other of the
    ``max(SIZES)`` runs (``half`` = 0 or 1) in a plain loop; return its wall time."""
    from stictionbench.sweep.plan import make_plan
    from stictionbench.sweep.runner import execute

    runs = _spread(make_plan("default", []).runs, max(SIZES))[half::2]
    for r in runs[:2]:  # warm
        execute(r.id, r.spec)
    time.sleep(max(0.0, start - time.time()))
    t0 = time.perf_counter()
    for r in runs:
        assert execute(r.id, r.spec)["status"] == "ok"
    return time.perf_counter() - t0


def _machine_ceiling(tmp: Path) -> float:
    """Wall time of the largest size split over two independent plain-loop processes
    started together (no Hydra, no joblib): what 2 cores give this workload at best."""
    code = ("import sys; sys.path.insert(0, sys.argv[1]); import test_bench_sweep as m; "
            "print(m._loop_child(int(sys.argv[2]), float(sys.argv[3])))")
    walls = []
    for _ in range(REPEATS):
        start = time.time() + 8.0  # both children imported and warm by then
        procs = [subprocess.Popen([sys.executable, "-c", code, str(Path(__file__).parent),
                                   str(h), repr(start)], stdout=subprocess.PIPE, text=True,
                                  env={**os.environ, **SINGLE_THREAD}, cwd=tmp)
                 for h in (0, 1)]
        outs = [p.communicate(timeout=900)[0] for p in procs]
        walls.append(max(float(o.strip().splitlines()[-1]) for o in outs))
    return float(np.median(walls))


def _fit(n: np.ndarray, t: np.ndarray) -> tuple[float, float, float]:
    b, a = np.polyfit(n, t, 1)
    pred = a + b * n
    r2 = 1.0 - float(np.sum((t - pred) ** 2) / np.sum((t - t.mean()) ** 2))
    return float(a), float(b), r2


def test_sweep_throughput(benchmark, tmp_path):
    """Wall time of N-run sweeps, 1 and 2 workers, against a plain loop of the same runs."""
    res = benchmark.pedantic(
        lambda: {w: _measure(w, tmp_path) for w in (0, *WORKERS)}, rounds=1, iterations=1)
    ceiling_wall = _machine_ceiling(tmp_path)
    ns = np.array(SIZES, float)
    walls = {w: np.array([res[w]["walls"][str(n)] for n in SIZES]) for w in res}
    fits = {w: _fit(ns, walls[w]) for w in walls}
    n_max = max(SIZES)
    speedup = walls[1][-1] / walls[2][-1]
    slope_speedup = fits[1][1] / fits[2][1]
    ceiling = walls[0][-1] / ceiling_wall
    overhead = walls[1][-1] / walls[0][-1]
    benchmark.extra_info.update(speedup_2_vs_1_worker=speedup, slope_speedup=slope_speedup,
                                machine_ceiling=ceiling,
                                ratio_1_worker_vs_loop=overhead,
                                ms_per_run_2_workers=1e3 * fits[2][1])

    names = {0: "plain loop (baseline)", 1: "Hydra + joblib, 1 worker",
             2: "Hydra + joblib, 2 workers"}
    rows = []
    for w in walls:
        a, b, r2 = fits[w]
        rows.append(f"| {names[w]} | " + " | ".join(f"{t:.2f} s" for t in walls[w])
                    + f" | {1e3 * b:.1f} | {a:.2f} | {r2:.4f} | {res[w]['cold']:.1f} s |")
    lines = [
        "# Sweep throughput (`conf/sweep/default.yaml`)\n",
        "Written by `benchmarks/test_bench_sweep.py`: N runs spread over the `default` grid, "
        "launched like `stictionbench sweep` (Hydra multirun, joblib launcher, one batch of "
        "runs per worker and Hydra job, one JSON row per run), warm, each runner in its own "
        "process "
        f"with single-threaded BLAS; {os.cpu_count()} CPU(s). Baseline: the same runs in a "
        "plain Python loop.\n",
        "| runner | " + " | ".join(f"N = {n}" for n in SIZES)
        + " | ms per run (slope b) | intercept a (s) | R² of wall = a + b·N "
        "| warm-up, 4 runs (cold start) |",
        "|---" * (len(SIZES) + 5) + "|",
        *rows,
        "",
        f"- 2 workers vs 1 worker, N = {n_max}: **{speedup:.2f}×** faster (wall, median of "
        f"{REPEATS}); per-run cost (slopes b): **{slope_speedup:.2f}×**",
        f"- Machine ceiling: the same {n_max} runs as two independent plain loops started "
        f"together take {ceiling_wall:.2f} s, **{ceiling:.2f}×** faster than one loop; the "
        f"sweep's 2 workers reach {speedup / ceiling:.0%} of what 2 cores give this "
        "workload here",
        f"- 1 worker (Hydra + joblib + result files) vs plain loop, N = {n_max}: "
        f"**{overhead:.2f}×** the time",
        f"- Linear in N (R² ≥ {min(f[2] for f in fits.values()):.3f}); at "
        f"{1e3 * fits[2][1]:.1f} ms per run on 2 workers the 1440 runs of `default` take "
        f"about {fits[2][0] + 1440 * fits[2][1]:.0f} s plus the cold start.",
        "",
        "![Sweep wall time against the number of runs](sweep_scaling.png)\n",
    ]
    write_text(REPORT, "\n".join(lines))
    _plot(ns, walls, fits, names)
    print("\n" + "\n".join(lines))


def _plot(ns, walls, fits, names) -> None:
    from stictionbench.reports.figures import new_figure, save_png

    fig, ax = new_figure()
    grid = np.linspace(0, ns.max(), 50)
    for w, ts in walls.items():
        a, b, _r2 = fits[w]
        (line,) = ax.plot(ns, ts, "o", label=f"{names[w]}: {1e3 * b:.1f} ms/run")
        ax.plot(grid, a + b * grid, "-", lw=0.8, color=line.get_color())
    ax.set_xlabel("runs in the sweep (N)")
    ax.set_ylabel("wall time (s)")
    ax.set_title("Sweep wall time against the number of runs (warm)")
    ax.set_xlim(0, None)
    ax.set_ylim(0, None)
    ax.legend()
    save_png(fig, FIGURE)
