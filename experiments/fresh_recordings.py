"""Recordings of the four generator families at seeds the benchmark never draws, diagnosed
in parallel, and the Wilson-interval bar charts of the experiments that compare a shipped
rule with its ablation on them (``disturbance_band.py``, ``dead_time_gate.py``).

The families: the three tuning families of ``concealed_families.py`` and the holdout
family of ``holdout_family.py``; each recording comes with the nominal model the benchmark
gives the diagnosis.
"""

from __future__ import annotations

import argparse
import contextlib
import importlib
import sys
from collections.abc import Callable, Iterable, Iterator
from pathlib import Path

import numpy as np
import pandas as pd

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "experiments"))

import concealed_families as cf  # noqa: E402
import holdout_family as hf  # noqa: E402

from stictionbench.diagnosis import NominalModel  # noqa: E402
from stictionbench.io import atomic_path, write_text  # noqa: E402
from stictionbench.rates import balanced_text, mcnemar_p, rate_text, wilson  # noqa: E402
from stictionbench.recording import Recording  # noqa: E402

FAMILIES = (*cf.FAMILIES, hf.FAMILY)
CLASSES = cf.CLASSES


def recording(family: str, cls: str, level: int,
              seed: int) -> tuple[cf.Case, NominalModel, Recording]:
    """One drawn recording of any of the four families, its case and its nominal model."""
    if family == hf.FAMILY:
        c, sig = hf.make_recording(cls, level, seed)
    else:
        c, sig = cf.make_recording(family, cls, level, seed)
    rec = Recording.from_arrays(sig["t"], sig["PV"], sig["OP"], SP=sig["SP"])
    return c, cf.nominal_model(c), rec


def jobs_reuse_args(doc: str, reuse_help: str, argv: list[str] | None = None,
                    flags: dict[str, str] | None = None) -> argparse.Namespace:
    """The command line of an experiment that diagnoses in parallel and can re-make its
    report from what an earlier run stored: ``--jobs`` (workers, default 2) and
    ``--reuse`` (``reuse_help`` says what it keeps), and any further on/off ``flags``
    (``{"--name": help}``); the description is ``doc``'s first line."""
    ap = argparse.ArgumentParser(description=doc.splitlines()[0])
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--reuse", action="store_true", help=reuse_help)
    for flag, text in (flags or {}).items():
        ap.add_argument(flag, action="store_true", help=text)
    return ap.parse_args(argv)


def seeds_jobs_args(doc: str, prog: str, seeds: int, argv: list[str] | None = None,
                    reuse_help: str | None = None) -> argparse.Namespace | None:
    """The command line of an experiment that draws ``--seeds`` loops per class (default
    ``seeds``) and diagnoses them on ``--jobs`` workers (default 2), and with
    ``reuse_help`` a ``--reuse`` flag (what it keeps); ``None``, after a one-line error on
    stderr naming ``prog``, when either number is below 1."""
    ap = argparse.ArgumentParser(description=doc.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=seeds, help="loops per class")
    ap.add_argument("--jobs", type=int, default=2)
    if reuse_help is not None:
        ap.add_argument("--reuse", action="store_true", help=reuse_help)
    a = ap.parse_args(argv)
    if a.seeds < 1 or a.jobs < 1:
        print(f"{prog}: --seeds and --jobs must be at least 1", file=sys.stderr)
        return None
    return a


def run_written(fn: Callable[[dict], dict], write: Callable[[int, Path], list[dict]],
                seeds: int, jobs: int) -> pd.DataFrame:
    """The recordings ``write(seeds, tmp)`` writes into a temporary folder, each passed to
    ``fn`` on ``jobs`` workers (:func:`run`); the folder is removed afterwards."""
    import tempfile

    with tempfile.TemporaryDirectory() as tmp:
        return run(fn, [(j,) for j in write(seeds, Path(tmp))], jobs)


def run(fn: Callable[..., dict], todo: list[tuple], jobs: int) -> pd.DataFrame:
    """``fn(*case)`` for every case on ``jobs`` workers, a progress bar by recording
    finished."""
    from joblib import Parallel, delayed
    from tqdm import tqdm

    gen = Parallel(n_jobs=jobs, return_as="generator")(delayed(fn)(*c) for c in todo)
    return pd.DataFrame(list(tqdm(gen, total=len(todo), desc="diagnose", unit="rec")))


def stored_or_made(stem: Path, reuse: bool,
                   make: Callable[[], pd.DataFrame]) -> pd.DataFrame | None:
    """An experiment's per-recording table: with ``reuse`` the stored ``stem.csv`` (None
    and a one-line message naming the experiment when it is missing: exit 2), else
    ``make()``."""
    csv = stem.with_suffix(".csv")
    if not reuse:
        return make()
    if not csv.is_file():
        print(f"{stem.name}: {csv} missing (run without --reuse)", file=sys.stderr)
        return None
    return pd.read_csv(csv)


def stored_or_run(stem: Path, reuse: bool, fn: Callable[..., dict],
                  todo: Callable[[], list[tuple]], jobs: int,
                  sort_by: list[str]) -> pd.DataFrame:
    """An experiment's per-recording table: with ``reuse`` the stored ``stem.csv`` (a
    one-line exit naming the experiment when it is missing), else ``fn`` on every case of
    ``todo()`` (:func:`run`), sorted by ``sort_by``."""
    csv = stem.with_suffix(".csv")
    if reuse:
        if not csv.exists():
            raise SystemExit(f"{stem.name}: {csv} missing (run without --reuse)")
        return pd.read_csv(csv)
    df = run(fn, todo(), jobs)
    return df.sort_values(sort_by, kind="stable").reset_index(drop=True)


def score_text(predicted: pd.Series, truth: pd.Series, digits: int = 1) -> str:
    """The score of 16 of verdicts ``predicted`` against classes ``truth``, classes
    weighted equally, with its 95 % interval (:func:`stictionbench.rates.balanced_text`)."""
    return balanced_text(predicted == truth, truth, digits=digits)


def called_physics(predicted: pd.Series, truth: pd.Series) -> str:
    """Rate text of the healthy (``none``) recordings among ``truth`` whose verdict
    ``predicted`` named physics."""
    healthy = truth == "none"
    return rate_text(int((healthy & (predicted != "none")).sum()), int(healthy.sum()))


def valve_verdicts(g: pd.DataFrame, suffix: str) -> dict[str, str]:
    """Rate texts of ``g``'s verdicts on a valve (``predicted``) and its slip-jump test
    (``slip_jump_p``): named stiction, named deadband, ``none`` and p < 0.05, each keyed
    ``"<what>, <suffix>"``."""
    return {f"{label}, {suffix}": rate_text(int(hit.sum()), len(g))
            for label, hit in (("named stiction", g.predicted == "stiction"),
                               ("named deadband", g.predicted == "deadband"),
                               ("none", g.predicted == "none"),
                               ("slip-jump p < 0.05", g.slip_jump_p < 0.05))}


def paired_change(w: pd.DataFrame, before: object, after: object, label: str) -> dict[str, str]:
    """``{label: "a / b (McNemar p = …)"}``: of the boolean table ``w`` (a row per loop),
    the loops true only in column ``after`` and only in column ``before``."""
    a = int((w[after] & ~w[before]).sum())
    b = int((w[before] & ~w[after]).sum())
    return {label: f"{a} / {b} (McNemar p = {mcnemar_p(a, b):.2g})"}


def on_substreams(g, *names: str) -> None:
    """Make each function ``names`` of the generator module ``g`` (its random generator
    first) draw from a sub-stream seeded by one draw of the stream it is handed, so every
    draw after it stays the same however many it makes."""
    for name in names:
        fn = getattr(g, name)

        def drawn(rng: np.random.Generator, *a, _fn=fn, **k):
            return _fn(np.random.default_rng(int(rng.integers(2**62))), *a, **k)

        setattr(g, name, drawn)


#: the folder of each independent generator under ``experiments/``
GENERATOR_FOLDERS = {"A": "blind_generator", "C": "blind_generator_c"}


def remake(gen: str, seed: int, cls: str, out: Path, loop: Callable[[dict], dict],
           substreams: tuple[str, ...] = (), name: str | None = None,
           level: int = 1) -> tuple[str, int]:
    """Generator ``gen``'s (``"A"`` or ``"C"``) recording of ``cls`` at ``level`` re-made
    from ``seed`` with its drawn loop passed through ``loop``, written (CSV and model
    YAML) to ``out``: its name and the loop's draw attempts (generator C draws once).

    Generator A draws from one stream: its functions ``substreams`` are put on
    sub-streams (:func:`on_substreams`) so the draws after them stay the same, and its
    recording is written as ``name``. Generator C draws a stream per purpose and names
    its recording itself; a ``name`` given must be the one it makes."""
    g = generator_module(GENERATOR_FOLDERS[gen])
    draw_loop = g.draw_loop
    g.draw_loop = lambda arg: loop(draw_loop(arg))
    if gen == "A":
        on_substreams(g, *substreams)
        res, nominal, tr, _ = g.make_recording(seed, level, cls)
        g.write_recording(str(out), name, res, nominal)
        return name, int(tr["attempts"])
    res = g.make_recording(seed, level, cls)
    if name is not None and res["name"] != name:
        raise RuntimeError(f"generator C seed {seed} does not make {name}")
    g.write_recording(str(out), res)
    return res["name"], 1


def remade_verdict(gen: str, seed: int, cls: str, name: str, loop: Callable[[dict], dict],
                   substreams: tuple[str, ...] = (), level: int = 1) -> dict:
    """:func:`remake`'s recording (at ``level``, default 1) diagnosed with its model YAML
    at the package's defaults: the loop's draw attempts, the verdict, the slip-jump
    test's p-value and the in-band degrees of freedom."""
    import tempfile

    from stictionbench.diagnosis import diagnose, load_model
    from stictionbench.io import read_recording

    with tempfile.TemporaryDirectory() as tmp:
        d = Path(tmp)
        _, attempts = remake(gen, seed, cls, d, loop, substreams, name, level)
        r = diagnose(read_recording(str(d / f"{name}.csv"), warn=False),
                     load_model(d / f"{name}.model.yaml"))
    return {"attempts": attempts, "predicted": r.missing_physics,
            "slip_jump_p": r.tests.get("slip_jump_zero", {}).get("p_value"),
            "band_dof": r.details.get("band_dof")}


def stored_experiment(doc: str, stem: Path, fn: Callable[..., dict],
                      todo: Callable[[], list[tuple]], sort_by: list[str],
                      report: Callable[[pd.DataFrame], str], argv: list[str] | None = None,
                      figure: Callable[[pd.DataFrame, Path], None] | None = None) -> int:
    """An experiment's whole command line: ``--jobs`` and ``--reuse``
    (:func:`jobs_reuse_args`), its per-recording table (:func:`stored_or_run`), its
    figure ``stem.png`` when it has one, and its report (:func:`publish`)."""
    args = jobs_reuse_args(doc, "re-make the report from the stored CSV", argv)
    df = stored_or_run(stem, args.reuse, fn, todo, args.jobs, sort_by)
    if figure is not None:
        figure(df, stem.with_suffix(".png"))
    publish(df, report(df), stem)
    return 0


def set_cases(sets: dict[str, tuple[str, ...]], classes: tuple[str, ...],
              variants: tuple, keep: Callable[[pd.Series], bool] | None = None,
              level: int = 1) -> list[tuple]:
    """``(generator, set, name, seed, class, variant)`` for every recording of ``classes``
    at ``level`` in the independent sets ``sets`` (generator → its sets, read from their
    stored ``reports/concealed/independent_set_S.csv``) that ``keep`` accepts, once per
    variant."""
    todo = []
    for gen, names in sets.items():
        for s in names:
            d = pd.read_csv(ROOT / "reports" / "concealed" / f"independent_set_{s}.csv")
            d = d[d["class"].isin(classes) & (d.level == level)]
            todo += [(gen, s, r["name"], int(r.seed), r["class"], v)
                     for _, r in d.iterrows() if keep is None or keep(r) for v in variants]
    return todo


def set_truths(sets: Iterable[str], prog: str,
               data: Path = ROOT / ".cache" / "blindgen") -> dict[str, pd.DataFrame] | None:
    """Each independent set's ``truth.csv`` (``data/set_S``), by set; ``None`` after one
    line on stderr naming the first that is missing (the caller exits 2)."""
    out = {}
    for s in sets:
        truth = data / f"set_{s}" / "truth.csv"
        if not truth.exists():
            print(f"{prog}: {truth} missing (make independent draws it)", file=sys.stderr)
            return None
        out[s] = pd.read_csv(truth)
    return out


@contextlib.contextmanager
def comparison_patched(fn: Callable) -> Iterator[None]:
    """``diagnose``'s first stage (``_compare_intersample``) replaced by ``fn`` for the
    ``with`` block, the shipped one restored after: how the experiments try a different
    reconstruction of OP in the whole diagnosis."""
    mod = importlib.import_module("stictionbench.diagnosis.diagnose")
    shipped = mod._compare_intersample
    mod._compare_intersample = fn
    try:
        yield
    finally:
        mod._compare_intersample = shipped


def drawn_alike(df: pd.DataFrame, column: str) -> pd.DataFrame:
    """The rows of loops (``generator``, ``name``) present at every value of ``column``
    and drawn in as many attempts at each (a loop a screen redrew at one value is not the
    same loop)."""
    by = df.groupby(["generator", "name"])
    return df[(by.attempts.transform("nunique") == 1)
              & (by[column].transform("nunique") == df[column].nunique())]


def generator_module(folder: str):
    """A freshly loaded copy of the independent generator ``experiments/FOLDER/generate.py``
    (its own module object: an experiment may patch its functions)."""
    import importlib.util

    spec = importlib.util.spec_from_file_location(folder, ROOT / "experiments" / folder
                                                  / "generate.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def publish(df: pd.DataFrame, text: str, stem: Path, *, float_format: str | None = None,
            echo: bool = True) -> None:
    """An experiment's outputs: ``stem.csv`` (the per-recording table, its floats written
    with ``float_format`` when given) and ``stem.md`` (the report), each written
    atomically; the report printed with ``echo``, else the report's path."""
    stem.parent.mkdir(parents=True, exist_ok=True)
    with atomic_path(stem.with_suffix(".csv")) as tmp:
        df.to_csv(tmp, index=False, float_format=float_format)
    write_text(stem.with_suffix(".md"), text)
    print(text if echo else f"wrote {stem.with_suffix('.md')}")


def rate_bars(ax, groups: Iterable[pd.DataFrame], hit: Callable[[pd.DataFrame, str], int],
              series: list[tuple[str, str, str]]) -> None:
    """Side-by-side bars of ``hit(group, column) / len(group)`` with Wilson 95 % error
    bars, one bar per ``(column, colour, legend label)`` in ``series`` at each group."""
    groups = list(groups)
    x = np.arange(len(groups))
    width = 0.76 / len(series)
    for k, (column, colour, label) in enumerate(series):
        rates, err = [], [[], []]
        for g in groups:
            n, h = len(g), hit(g, column) if len(g) else 0
            r = h / n if n else np.nan
            w = wilson(h, n) if n else (np.nan, np.nan)
            rates.append(r)
            err[0].append(r - w[0])
            err[1].append(w[1] - r)
        ax.bar(x + (k - (len(series) - 1) / 2) * width, rates, width, yerr=err, color=colour,
               capsize=3, label=label)


def rate_line(ax, hit: pd.Series, x: pd.Series, fmt: str, label: str) -> None:
    """The rate of ``hit`` (booleans) at each value of ``x``, drawn as a line with Wilson
    95 % error bars."""
    by = hit.groupby(x)
    k, n = by.sum(), by.size()
    rate = (k / n).to_numpy()
    lo, hi = np.array([wilson(int(a), int(b)) for a, b in zip(k, n, strict=True)]).T
    ax.errorbar(k.index, rate, yerr=[rate - lo, hi - rate], fmt=fmt, capsize=3, label=label)


if __name__ == "__main__":
    cf.library_main(__doc__, __file__)
