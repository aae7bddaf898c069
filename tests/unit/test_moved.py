"""Issue 65, friction 6: a plugin written against the modules as they were documented before the
library was laid out by concept (``acnmp_core.demo_io``, ``acnmp_core.adapt_job``, ...) failed with
ModuleNotFoundError and no hint; every old name now imports, as the new module itself, with a
DeprecationWarning naming the new path (acnmp_core/moved.py)."""
from __future__ import annotations

import importlib
import subprocess
import sys
import textwrap

import pytest

from acnmp_core.moved import MODULES, PACKAGES
from tests.paths import ROOT


@pytest.mark.parametrize("old, new", sorted(MODULES.items()))
def test_an_old_module_name_is_the_new_module_with_a_warning_naming_it(old, new, monkeypatch):
    monkeypatch.delitem(sys.modules, old, raising=False)  # imported afresh, as in a new process
    with pytest.warns(DeprecationWarning, match=f"{old} moved to {new};"):
        module = importlib.import_module(old)
    assert module is importlib.import_module(new)


@pytest.mark.parametrize("package", sorted(PACKAGES))
def test_the_names_of_a_module_that_became_a_package_are_found_with_a_warning(package, monkeypatch):
    names, _ = PACKAGES[package]
    pkg = importlib.import_module(package)
    for name in names:
        monkeypatch.delitem(vars(pkg), name, raising=False)  # as before anything asked for it
        with pytest.warns(DeprecationWarning, match=rf"{package}\.{name} moved to acnmp_core\.[\w.]+\.{name};"):
            value = getattr(pkg, name)
        assert value is not None and getattr(pkg, name) is value
    with pytest.raises(AttributeError, match="has no attribute 'never_there'"):
        pkg.never_there


def test_a_plugin_written_against_the_old_modules_runs_and_is_told_where_they_went(tmp_path):
    (tmp_path / "old_plugin.py").write_text(textwrap.dedent("""
        from acnmp_core.demo_io import DemoArrays, load_demos
        from acnmp_core.adapt_job import AdaptJob
        from acnmp_core.data import DemoSet
        print(DemoArrays.__module__, AdaptJob.__module__, DemoSet.__module__)
    """))
    run = subprocess.run([sys.executable, "-W", "default::DeprecationWarning", "-c", "import old_plugin"],
                         cwd=tmp_path, env={"PYTHONPATH": f"{tmp_path}:{ROOT}", "PATH": "/usr/bin:/bin"},
                         capture_output=True, text=True)
    assert run.returncode == 0, run.stderr
    assert run.stdout.split() == ["acnmp_core.data.demo_io", "acnmp_core.jobs.adapt", "acnmp_core.data.demos"]
    for line in ("acnmp_core.demo_io moved to acnmp_core.data.demo_io", "acnmp_core.adapt_job moved to acnmp_core.jobs.adapt",
                 "acnmp_core.data.DemoSet moved to acnmp_core.data.demos.DemoSet"):
        assert line in run.stderr and "old_plugin.py" in run.stderr, run.stderr  # the plugin's own line is named
