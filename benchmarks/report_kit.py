"""What the renderers of the docs blocks share (benchmarks/blocks/): the registry of renderers,
where a result file lives and the number formats. benchmarks/report.py finds the blocks and calls them."""
from __future__ import annotations

import functools
import json
from pathlib import Path
from typing import Callable

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
RESULTS = ROOT / "benchmarks" / "results"
STUDIES = ROOT / "benchmarks" / "studies"
RENDERERS: dict[str, Callable[[], str]] = {}


def renderers(fn: Callable[..., str], blocks: dict[str, tuple]) -> None:
    """Register ``fn(*args)`` as the renderer of each block of ``blocks`` ({block name: args}): one
    table's shape rendered from several result files."""
    for name, args in blocks.items():
        RENDERERS[name] = functools.partial(fn, *args)


def renderer(name: str):
    """Register ``fn() -> markdown`` as the renderer of blocks named ``name``."""

    def deco(fn):
        RENDERERS[name] = fn
        return fn

    return deco


def _find_result(name: str) -> Path | None:
    """``benchmarks/results/<name>.json`` if it exists, else the first study's
    ``benchmarks/studies/<study>/results/<name>.json``, else None."""
    published = RESULTS / f"{name}.json"
    if published.exists():
        return published
    return next(iter(sorted(STUDIES.glob(f"*/results/{name}.json"))), None)


def result_path(name: str) -> Path:
    """Where the result file ``<name>.json`` lives: ``benchmarks/results/`` (what README and docs/
    publish) or the one study that keeps it (``benchmarks/studies/<study>/results/``);
    FileNotFoundError naming both places when neither has it."""
    found = _find_result(name)
    if found is None:
        raise FileNotFoundError(f"no {name}.json in benchmarks/results/ nor in benchmarks/studies/*/results/")
    return found


def has_result(name: str) -> bool:
    """Whether the result file ``<name>.json`` exists in one of the places :func:`result_path` looks."""
    return _find_result(name) is not None


def load(name: str) -> dict:
    """The result file ``<name>.json`` (see :func:`result_path`)."""
    return json.loads(result_path(name).read_text())


def where(name: str) -> str:
    """The result file ``<name>.json`` as the pages name it: its path from the repository root."""
    return result_path(name).relative_to(ROOT).as_posix()


def shown_command(command: str) -> str:
    """A provenance command as a page shows it: a path inside the repository relative to it, and a
    file outside it (a scratch file only the machine that made the result had) as ``FILE`` with its
    suffix, ``--out``/``--json``'s as ``OUT``: the command a user runs in a clone, naming the files
    they choose."""
    import shlex

    words, out = shlex.split(command), []
    for i, w in enumerate(words):
        if w.startswith("/"):
            path = Path(w)
            if path.is_relative_to(ROOT):
                w = path.relative_to(ROOT).as_posix()
            else:
                w = ("OUT" if i and words[i - 1] in ("--out", "--json") else "FILE") + "".join(path.suffixes)
        out.append(w)
    return shlex.join(out)


def source(result: dict, file: str) -> str:
    """One line naming the JSON file, its command (:func:`shown_command`) and commit."""
    p = result.get("provenance") or {}
    commit = (p.get("commit") or "unknown")[:10] + (" (dirty tree)" if p.get("dirty") else "")
    made = {((part.get("provenance") or {}).get("commit") or "unknown")[:10] for part in result.get("parts", [])}
    if made:  # a merge of parts run side by side: where the numbers were made
        commit += f", its parts made at {', '.join(sorted(made))}"
    took = f"{result['wall_time_s']:.0f} s " if result.get("wall_time_s") is not None else ""
    return f"*From `{where(file)}`: `{shown_command(p.get('command', '?'))}` at commit {commit}, " \
           f"{took}on {p.get('machine', {}).get('cpu_count', '?')} cores.*"


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


def block(result: dict, file: str, header: list[str], rows: list[list], *notes: str) -> str:
    """A docs block: the table of ``rows`` under ``header``, each of ``notes`` a paragraph below it,
    and last the line naming the JSON ``file`` the ``result`` came from (:func:`source`)."""
    return "\n\n".join([table(header, rows), *notes, source(result, file)])


def table(header: list[str], rows: list[list]) -> str:
    """A markdown table."""
    lines = ["| " + " | ".join(header) + " |", "| " + " | ".join("---" for _ in header) + " |"]
    lines += ["| " + " | ".join(str(c) for c in r) + " |" for r in rows]
    return "\n".join(lines)
