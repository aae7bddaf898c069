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
import json
import re
import sys
from pathlib import Path
from typing import Callable

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
RESULTS = ROOT / "benchmarks" / "results"
BLOCK = re.compile(r"(<!-- BEGIN report:([\w-]+) -->\n)(.*?)(<!-- END report:\2 -->)", re.S)
RENDERERS: dict[str, Callable[[], str]] = {}


def renderer(name: str):
    """Register ``fn() -> markdown`` as the renderer of blocks named ``name``."""

    def deco(fn):
        RENDERERS[name] = fn
        return fn

    return deco


def load(name: str) -> dict:
    """The result file ``benchmarks/results/<name>.json``."""
    return json.loads((RESULTS / f"{name}.json").read_text())


def source(result: dict, file: str) -> str:
    """One line naming the JSON file, its command and commit."""
    p = result.get("provenance") or {}
    commit = (p.get("commit") or "unknown")[:10] + (" (dirty tree)" if p.get("dirty") else "")
    return f"*From `benchmarks/results/{file}.json`: `{p.get('command', '?')}` at commit {commit}, " \
           f"{result.get('wall_time_s', float('nan')):.0f} s on {p.get('machine', {}).get('cpu_count', '?')} cores.*"


def fmt(x, digits: int = 3) -> str:
    """A number for a table: '-' for None, integers as such, floats to ``digits`` significant places."""
    if x is None:
        return "-"
    if isinstance(x, (int, np.integer)) or float(x).is_integer() and abs(x) >= 1:
        return f"{int(x)}"
    return f"{x:.{digits}g}"


def pct(x, digits: int = 0) -> str:
    """A rate in [0, 1] as a percentage with ``digits`` decimals (E3's test success, out of 1000
    environments, takes one: 94.8 % must not read as the 95 % target)."""
    return "-" if x is None else f"{100 * x:.{digits}f} %"


def frac(rate: float, n: int) -> str:
    """A rate over n runs as 'k/n'."""
    return f"{round(rate * n)}/{n}"


def table(header: list[str], rows: list[list]) -> str:
    """A markdown table."""
    lines = ["| " + " | ".join(header) + " |", "| " + " | ".join("---" for _ in header) + " |"]
    lines += ["| " + " | ".join(str(c) for c in r) + " |" for r in rows]
    return "\n".join(lines)


def pages() -> list[Path]:
    """Every markdown page that may hold report blocks."""
    return [ROOT / "README.md", *sorted((ROOT / "docs").rglob("*.md"))]


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


# --------------------------------------------------------------------------------------------------
# Renderers
# --------------------------------------------------------------------------------------------------
if __name__ == "__main__":
    # As a script this file is __main__; the renderers register on the importable module.
    sys.path.insert(0, str(ROOT))
    from benchmarks import report as _report  # noqa: E402

    sys.exit(_report.main())
else:
    from benchmarks import report_blocks  # noqa: E402,F401  (registers the renderers)
