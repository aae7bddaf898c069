"""Write the published numbers into the docs from the JSON results, so they cannot go stale.

Every page (README.md and docs/**/*.md) may hold blocks

    <!-- BEGIN report:NAME -->
    ...
    <!-- END report:NAME -->

whose body this script renders from ``benchmarks/results/*.json`` with the renderer ``NAME`` below.
Usage::

    python benchmarks/report.py          # rewrite every block in place
    python benchmarks/report.py --check  # exit 1 and list the blocks that differ (the test suite does this)
"""
from __future__ import annotations

import argparse
import re
import sys
from pathlib import Path

if __name__ == "__main__":  # as a script: the repository root on the path, for the benchmarks package
    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
from benchmarks import blocks  # noqa: E402,F401  (registers the renderers in report_kit.RENDERERS)
from benchmarks.report_kit import RENDERERS, ROOT  # noqa: E402

BLOCK = re.compile(r"(<!-- BEGIN report:([\w-]+) -->\n)(.*?)(<!-- END report:\2 -->)", re.S)


def pages() -> list[Path]:
    """Every markdown page that may hold report blocks: the README, docs/ and the studies' notes
    (benchmarks/studies/<experiment>/*.md)."""
    return [ROOT / "README.md", *sorted((ROOT / "docs").rglob("*.md")),
            *sorted((ROOT / "benchmarks" / "studies").rglob("*.md"))]


def render_page(text: str) -> str:
    """``text`` with every report block re-rendered; KeyError for an unknown renderer name."""

    def sub(m: re.Match) -> str:
        name = m.group(2)
        if name not in RENDERERS:
            raise KeyError(f"unknown report block {name!r} (known: {', '.join(sorted(RENDERERS))})")
        return m.group(1) + RENDERERS[name]().rstrip("\n") + "\n" + m.group(4)

    return BLOCK.sub(sub, text)


def stale_blocks() -> list[str]:
    """'page: block' for every block whose text differs from what the JSON results give."""
    out = []
    for page in pages():
        text = page.read_text()
        if BLOCK.search(text) is None:
            continue
        new = render_page(text)
        if new != text:
            old_blocks = {m.group(2): m.group(3) for m in BLOCK.finditer(text)}
            new_blocks = {m.group(2): m.group(3) for m in BLOCK.finditer(new)}
            out += [f"{page.relative_to(ROOT)}: {n}" for n in old_blocks if old_blocks[n] != new_blocks.get(n)]
    return out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--check", action="store_true", help="change nothing; exit 1 when a block is stale")
    args = ap.parse_args(argv)
    if args.check:
        stale = stale_blocks()
        for s in stale:
            print(f"stale: {s}")
        if stale:
            print("run: python benchmarks/report.py")
        return 1 if stale else 0
    for page in pages():
        text = page.read_text()
        new = render_page(text)
        if new != text:
            page.write_text(new)
            print(f"updated {page.relative_to(ROOT)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
