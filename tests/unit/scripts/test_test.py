"""scripts/test.sh and the slow marker: the README's inner loop (`--fast`) is tests/unit without the
slow tests, `--slow` runs the slow ones, and a `-m` expression of one's own (pytest's `-m` replaces
any other) no longer brings the slow tests in: they run only when the expression names them."""
from __future__ import annotations

import os
import subprocess

import pytest
from tests.paths import ROOT

pytest_plugins = ["pytester"]


def _pytest_argv(*args: str) -> list[str]:
    """The pytest arguments scripts/test.sh would run with ``args`` (its dry run)."""
    out = subprocess.run(["bash", str(ROOT / "scripts" / "test.sh"), *args], capture_output=True, text=True,
                         env={**os.environ, "ACNMP_TEST_DRY_RUN": "1"}, check=True).stdout.splitlines()
    return out[out.index("pytest") + 1:]


@pytest.mark.parametrize("args, want, unwanted", [
    (["--fast"], ["tests/unit", "--fast"], ["-m"]),
    (["--slow"], ["-m", "slow"], ["tests/unit"]),
    (["--fast", "-k", "wire"], ["tests/unit", "--fast", "-k", "wire"], ["-m"]),
    (["-m", "not e2e", "tests/unit/services/transport/test_wire.py"], ["-m", "not e2e", "tests/unit/services/transport/test_wire.py"], ["slow"]),
])
def test_the_script_turns_its_options_into_pytest_arguments(args, want, unwanted):
    argv = _pytest_argv(*args)
    assert argv[:6] == ["-q", "-n", str(len(os.sched_getaffinity(0)) + 1), "--dist", "worksteal", "--durations=5"]
    rest = argv[6:]
    assert rest == want and not set(unwanted) & set(rest)


@pytest.fixture
def project(pytester, monkeypatch):
    """A project with the suite's selection hook and its two markers: two slow tests, two others
    (no plugins of the environment: loading them took seconds per run)."""
    monkeypatch.setenv("PYTEST_DISABLE_PLUGIN_AUTOLOAD", "1")
    pytester.makeini("[pytest]\nmarkers =\n    slow: minutes\n    e2e: processes\n")
    pytester.makeconftest("from tests.selection import add_options, deselect\n\n"
                          "def pytest_addoption(parser):\n    add_options(parser)\n\n"
                          "def pytest_collection_modifyitems(config, items):\n    deselect(config, items)\n")
    pytester.makepyfile(test_x="import pytest\n\n"
                               "def test_quick(): pass\n\n"
                               "def test_heavy(): pass\n\n"
                               "@pytest.mark.e2e\ndef test_process(): pass\n\n"
                               "@pytest.mark.slow\ndef test_long(): pass\n\n"
                               "@pytest.mark.slow\n@pytest.mark.parametrize('n', [1, 2])\ndef test_sizes(n): pass\n")
    return pytester


def _collected(pytester, *args: str) -> set[str]:
    result = pytester.runpytest_inprocess("--collect-only", "-q", "-p", "no:cacheprovider", *args)
    return {line.split("::", 1)[1] for line in result.outlines if "::" in line}


def test_a_marker_expression_of_ones_own_leaves_the_slow_tests_out_unless_it_names_them(project):
    slow = {"test_long", "test_sizes[1]", "test_sizes[2]"}
    default = {"test_quick", "test_heavy", "test_process"}
    assert _collected(project) == default
    assert _collected(project, "-m", "not e2e") == default - {"test_process"}  # the README's old loop ran the slow ones
    assert _collected(project, "-m", "slow") == slow
    assert _collected(project, "-m", "slow or not slow") == slow | default
    assert _collected(project, "test_x.py::test_long") == {"test_long"}  # a slow test named by its node id runs
    assert _collected(project, "test_x.py::test_sizes") == {"test_sizes[1]", "test_sizes[2]"}


def test_fast_leaves_out_the_heavy_tests_listed_too(project, monkeypatch):
    from tests import selection

    monkeypatch.setattr(selection, "HEAVY", ("test_x.py::test_heavy",))
    assert _collected(project, "--fast") == {"test_quick", "test_process"}
    assert _collected(project, "--fast", "-m", "not e2e") == {"test_quick"}
    assert _collected(project, "--fast", "test_x.py::test_heavy") == {"test_heavy"}  # asked for by name
    assert "test_heavy" in _collected(project)  # the default suite runs it


def test_every_heavy_entry_names_a_test_that_exists():
    """A renamed file or test would silently come back into the inner loop."""
    from tests import selection

    for entry in selection.HEAVY:
        path, _, name = entry.partition("::")
        assert (ROOT / path).is_file(), entry
        assert not name or f"def {name}" in (ROOT / path).read_text(), entry
