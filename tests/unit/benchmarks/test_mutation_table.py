"""The mutation check's table (benchmarks/mutation/mutants.py) stays applicable: each mutant's text
is found exactly once in its file, the mutated file still parses, and each file has its tests; a
change to the learner that moves a mutant's text fails here, so the table is kept with the code."""
from __future__ import annotations

import ast

from benchmarks.mutation.mutants import MUTANTS, SCOPE, TESTS
from tests.paths import ROOT


def test_every_mutant_applies_once_and_parses():
    ids = [m.id for m in MUTANTS]
    assert len(ids) == len(set(ids)), "a mutant id is given twice"
    for m in MUTANTS:
        text = (ROOT / m.file).read_text()
        assert text.count(m.find) == 1, f"{m.id}: its text is found {text.count(m.find)} times in {m.file}"
        mutated = text.replace(m.find, m.replace)
        assert mutated != text, m.id
        ast.parse(mutated, filename=m.file)


def test_every_file_has_existing_tests_and_the_issue_breaks_are_in_the_table():
    assert set(SCOPE) <= set(TESTS) and {m.file for m in MUTANTS} <= set(TESTS)
    assert all((ROOT / path).exists() for paths in TESTS.values() for path in paths)
    # issue 67's breaks of the learner (8, the LeRobot export, is not the learner's)
    assert {m.issue for m in MUTANTS if m.issue is not None} == {1, 2, 3, 4, 5, 6, 7, 9}
