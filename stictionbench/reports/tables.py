"""Tables: a pandas DataFrame written as Markdown and CSV, atomically and reproducibly."""

from __future__ import annotations

import math
from pathlib import Path

import pandas as pd

from ..io import write_text


def _fmt(v: object, digits: int = 4) -> str:
    if isinstance(v, bool) or v is None:
        return str(v)
    if isinstance(v, float):
        if math.isnan(v):
            return "—"
        if v != 0 and (abs(v) < 1e-3 or abs(v) >= 1e5):
            return f"{v:.{digits}g}"
        return f"{v:.{digits}g}" if abs(v) < 1 else f"{v:.{digits}g}"
    return str(v)


def to_markdown(df: pd.DataFrame, digits: int = 4) -> str:
    """Render a DataFrame as a GitHub Markdown table (no optional dependency)."""
    cols = [str(c) for c in df.columns]
    lines = ["| " + " | ".join(cols) + " |", "|" + "|".join("---" for _ in cols) + "|"]
    for row in df.itertuples(index=False):
        lines.append("| " + " | ".join(_fmt(v, digits).replace("|", "\\|") for v in row) + " |")
    return "\n".join(lines) + "\n"


def write_table(df: pd.DataFrame, stem: str | Path, *, title: str = "", note: str = "",
                digits: int = 4) -> tuple[Path, Path]:
    """Write ``stem.md`` (title, table, note) and ``stem.csv``.

    Floats in the CSV carry 8 significant digits: enough for every number the reports
    compute, few enough that the last-digit differences of another machine's BLAS and
    libm (1e-12 relative) do not change the bytes.
    """
    stem = Path(stem)
    md = (f"# {title}\n\n" if title else "") + to_markdown(df, digits) + (
        f"\n{note.strip()}\n" if note else "")
    write_text(stem.with_suffix(".md"), md)
    write_text(stem.with_suffix(".csv"), csv_text(df))
    return stem.with_suffix(".md"), stem.with_suffix(".csv")


def magnitude(v: float, digits: int = 3) -> float:
    """``v`` to ``digits`` significant digits: for numbers that carry an order of
    magnitude and no more, such as the condition number of an ill-conditioned solve
    (its trailing digits change with the BLAS build and thread count).

    Examples
    --------
    >>> magnitude(444082960000.0)
    444000000000.0
    """
    return float(f"{float(v):.{digits}g}")


def csv_text(df: pd.DataFrame) -> str:
    r"""A DataFrame as CSV text with floats rounded to 8 significant digits.

    Examples
    --------
    >>> csv_text(pd.DataFrame({"x": [0.05689361171846, 1.0]}))
    'x\n0.056893612\n1.0\n'
    """
    return df.to_csv(index=False, lineterminator="\n", float_format=_float8)


def _float8(v: float) -> str:
    return repr(float(f"{v:.8g}"))
