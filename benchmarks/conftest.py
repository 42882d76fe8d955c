"""Everything under benchmarks/ is a pytest-benchmark suite: marked so `make test` skips it.

At the end of a session that ran benchmarks, :func:`pytest_sessionfinish` writes
``reports/benchmarks.md``: the pytest-benchmark timings of this session (with each
benchmark's ratios from ``extra_info``), then every suite's own report
``reports/benchmarks/*.md`` (each states its baseline and ratio) with its figures.
"""

from __future__ import annotations

import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
SUITES = ROOT / "reports" / "benchmarks"
SUMMARY = ROOT / "reports" / "benchmarks.md"


def pytest_collection_modifyitems(items):
    for item in items:
        item.add_marker(pytest.mark.benchmark)


def _fmt_s(v: float) -> str:
    if v >= 1.0:
        return f"{v:.3g} s"
    if v >= 1e-3:
        return f"{v * 1e3:.3g} ms"
    return f"{v * 1e6:.3g} µs"


def _timings(session) -> list[str]:
    bs = getattr(session.config, "_benchmarksession", None)
    benches = [b for b in getattr(bs, "benchmarks", []) or [] if b]
    if not benches:
        return []
    lines = ["## Timings of this session (pytest-benchmark)\n",
             "| benchmark | min | median | rounds | ratios and baselines (extra_info) |",
             "|---|---|---|---|---|"]
    for b in sorted(benches, key=lambda b: b.fullname):
        st = b.stats
        extra = ", ".join(
            f"{k} = {v:.3g}" if isinstance(v, float) else f"{k} = {v}"
            for k, v in sorted(b.extra_info.items())
            if isinstance(v, (int, float, str)) and not isinstance(v, bool))
        lines.append(f"| `{b.name}` | {_fmt_s(st.min)} | {_fmt_s(st.median)} | {st.rounds} "
                     f"| {extra or '—'} |")
    return lines + [""]


def _suite(path: Path) -> str:
    """A suite's report, headings one level down, relative image links re-rooted."""
    text = path.read_text(encoding="utf-8")
    text = re.sub(r"^(#+) ", lambda m: "#" + m.group(1) + " ", text, flags=re.M)
    return re.sub(r"\]\((?!https?:|/)([^)]+)\)", rf"]({SUITES.name}/\1)", text)


def pytest_sessionfinish(session, exitstatus):
    ran = [i for i in getattr(session, "items", [])
           if Path(str(i.fspath)).resolve().is_relative_to(Path(__file__).parent)]
    if not ran or session.config.option.collectonly:
        return
    from stictionbench.io import write_text

    suites = sorted(SUITES.glob("*.md")) if SUITES.is_dir() else []
    files = sorted({Path(str(i.fspath)).name for i in ran})
    parts = [
        "# Benchmarks\n",
        "Written by `make bench` (`benchmarks/conftest.py` collects the suites' reports). "
        "Every suite measures its baseline in the same run and states the ratio. "
        f"This session ran: {', '.join(f'`{f}`' for f in files)}; the sections below "
        "come from each suite's last run.\n",
        *_timings(session),
    ]
    parts += [_suite(p) for p in suites]
    write_text(SUMMARY, "\n".join(parts).rstrip() + "\n")
