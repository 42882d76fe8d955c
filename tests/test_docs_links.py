"""Every relative link of the README and of ``docs/`` leads to a file of the repository, and
every ``#anchor`` to a heading of the page it names (GitHub's heading slugs)."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PAGES = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]
LINK = re.compile(r"\]\(([^)\s]+)\)")


def _slug(heading: str) -> str:
    """GitHub's anchor of a Markdown heading: lower case, punctuation dropped, spaces to
    hyphens."""
    s = heading.strip().lower()
    s = re.sub(r"[^\w\- ]", "", s)
    return s.replace(" ", "-")


def _anchors(page: Path) -> set[str]:
    text = page.read_text(encoding="utf-8")
    return {_slug(m) for m in re.findall(r"^#+\s+(.*)$", text, flags=re.M)}


def _links() -> list[tuple[Path, str]]:
    out = []
    for page in PAGES:
        text = page.read_text(encoding="utf-8")
        text = re.sub(r"```.*?```", "", text, flags=re.S)  # code blocks hold no links
        out += [(page, target) for target in LINK.findall(text)
                if not re.match(r"[a-z]+://", target)]
    return out


def test_pages_have_links():
    assert len(PAGES) >= 3
    assert len(_links()) > 50


@pytest.mark.parametrize("page,target", _links(),
                         ids=lambda v: v.name if isinstance(v, Path) else v)
def test_link_resolves(page, target):
    path, _, anchor = target.partition("#")
    dest = (page.parent / path).resolve() if path else page
    assert dest.exists(), f"{page.relative_to(ROOT)}: {target} does not exist"
    if anchor and dest.suffix == ".md":
        assert anchor in _anchors(dest), f"{page.relative_to(ROOT)}: no heading #{anchor}"


def test_slug_follows_github():
    assert _slug("The linear-input gate") == "the-linear-input-gate"
    assert _slug("How hard are these sets against the judged one?") == \
        "how-hard-are-these-sets-against-the-judged-one"
