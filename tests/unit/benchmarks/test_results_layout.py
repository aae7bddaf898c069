"""Where result files live: ``benchmarks/results/`` keeps what README and docs/ publish, a study's
own JSON and figures live beside its notes (``benchmarks/studies/<study>/results/``), and every
result path a page names exists."""
from __future__ import annotations

import re

from benchmarks import currency, report, report_kit
from tests.paths import ROOT

#: a result file named by its path from the repository root
RESULT_PATH = re.compile(r"benchmarks/(?:results|studies/\w+/results)/[\w.-]+\.(?:json|png)")


def _study(page) -> str | None:
    """The study a page belongs to (``benchmarks/studies/<study>/...``), None for a product page."""
    parts = page.relative_to(ROOT).parts
    return parts[2] if parts[:2] == ("benchmarks", "studies") else None


def test_a_result_only_a_study_reads_lives_with_that_study(monkeypatch):
    readers: dict[str, set] = {}
    where = report_kit.result_path

    def traced(name):
        readers.setdefault(name, set()).add(current)
        return where(name)

    monkeypatch.setattr(report_kit, "result_path", traced)
    for page in report.pages():
        for m in report.BLOCK.finditer(page.read_text()):
            current = _study(page)
            report.RENDERERS[m.group(2)]()
    misplaced = []
    for name, studies in sorted(readers.items()):
        path = where(name).relative_to(ROOT).as_posix()
        if None in studies:  # a product page reads it: it is published
            if not path.startswith("benchmarks/results/"):
                misplaced.append(f"{path}: published, belongs in benchmarks/results/")
        elif len(studies) == 1 and path != f"benchmarks/studies/{next(iter(studies))}/results/{name}.json":
            misplaced.append(f"{path}: read by the {next(iter(studies))} study only")
    assert not misplaced, "\n".join(misplaced)


def _named_paths(text: str) -> list[str]:
    """The result paths ``text`` names: anywhere outside its report blocks, and inside a block the
    file it is ``From`` (a block's recorded command names the paths of its day)."""
    froms = [m.group(1) for b in report.BLOCK.finditer(text) for m in re.finditer(r"From `([^`]+)`", b.group(3))]
    return RESULT_PATH.findall(report.BLOCK.sub("", text)) + [p for p in froms if RESULT_PATH.fullmatch(p)]


def _pending(path: str) -> bool:
    """Whether ``path`` is a file of a pending result of record (its JSON, figure or parts), which
    the command a page names makes: benchmarks/currency.py's PENDING."""
    name = path.rsplit("/", 1)[-1]
    return path.startswith("benchmarks/results/") and any(name.startswith(n) for n in currency.pending())


def test_every_result_path_a_page_or_script_names_exists():
    texts = [ROOT / "README.md", *(ROOT / "docs").rglob("*.md"), *(ROOT / "benchmarks").rglob("*.md"),
             *(ROOT / "benchmarks").rglob("*.py")]
    missing = sorted(f"{path.relative_to(ROOT)}: {p}" for path in texts for p in _named_paths(path.read_text())
                     if not (ROOT / p).exists() and not _pending(p))
    assert not missing, "\n".join(missing)
