"""The product's front stays short (issue 37): the README within 6 KB with a results row for each
of the paper's six experiments, and each experiment page's first screen saying what it is, the
command that runs it, its generated results table and its figure; the rest is in the studies beside their scripts (benchmarks/studies/<experiment>/)."""
from __future__ import annotations


import pytest

from clients.experiments.catalog import CATALOG, PAPER
from tests.paths import ROOT

#: What a first screen holds: the page's opening lines, up to the end of its first results block.
FIRST_SCREEN_LINES = 40


def test_the_readme_is_at_most_6_kb_and_has_a_row_per_experiment():
    readme = (ROOT / "README.md").read_text()
    assert len(readme.encode()) <= 6 * 1024
    rows = [line for line in readme.splitlines() if line.startswith("| E")]
    assert [row.split()[1] for row in rows] == [e.ident for e in PAPER]


@pytest.mark.parametrize("entry", PAPER, ids=lambda e: e.ident)
def test_each_experiment_page_opens_with_its_command_results_and_figure(entry):
    lines = (ROOT / "docs" / "experiments" / entry.page).read_text().splitlines()
    head = "\n".join(lines[:FIRST_SCREEN_LINES])
    assert lines[0].startswith(f"# {entry.ident}: ")
    assert f"acnmp experiment {entry.name}" in head
    assert "<!-- BEGIN report:" in head  # a table generated from the JSON
    block_end = next(i for i, line in enumerate(lines) if line.startswith("<!-- END report:"))
    after = "\n".join(lines[:block_end + 6])
    assert "![" in after and "](../../benchmarks/results/" in after  # the figure, right after the table


@pytest.mark.parametrize("entry", [e for e in CATALOG if e.page], ids=lambda e: e.name)
def test_every_page_and_study_the_catalog_names_exists(entry):
    assert (ROOT / "docs" / "experiments" / entry.page).exists()
    for script in (entry.benchmark or "").split(","):
        if script.strip():
            assert (ROOT / script.strip()).exists(), script


#: The most a page may weigh (bytes), one limit for every page (issue 72: pages were kept at limits
#: of their own, each filled to the byte): docs/ holds what a user reads, reference the code holds
#: is generated into tables (benchmarks/blocks/reference.py), investigations live beside their
#: scripts (benchmarks/studies/<experiment>/), measurements in their own pages.
PAGE_LIMIT = 30 * 1024


def test_every_docs_page_stays_within_its_size():
    too_big = {str(page.relative_to(ROOT)): size for page in (ROOT / "docs").rglob("*.md")
               if (size := len(page.read_bytes())) > PAGE_LIMIT}
    assert not too_big, too_big


def test_every_code_fence_of_every_page_is_a_fence_line_of_its_own():
    """A closing ``` followed by text (examples/my_robot/README.md, issue 72: "``` Without
    installing, ...") opens a block instead, and the rest of the page renders as code: every fence
    line of every markdown file is ``` with at most a language name, and every block is closed."""
    import re
    import subprocess

    pages = subprocess.run(["git", "ls-files", "*.md"], cwd=ROOT, capture_output=True, text=True,
                           check=True).stdout.split()
    bad, unclosed = [], []
    for page in pages:
        fences = [(i + 1, line.strip()) for i, line in enumerate((ROOT / page).read_text().splitlines())
                  if line.strip().startswith("```")]
        bad += [f"{page}:{n}: {line[:40]}" for n, line in fences if not re.fullmatch(r"```[\w+.-]*", line)]
        if len(fences) % 2:
            unclosed.append(page)
    assert not bad and not unclosed, (bad, unclosed)
