"""The library's public API as editors and type checkers see it: explicit exports and ``py.typed``.

A real type checker (mypy) reads a two-line user script: a correct use passes, and a wrong argument
type is reported. With the names exported only through the module's ``__getattr__`` (as before),
mypy typed them ``Any`` and reported nothing.
"""
from __future__ import annotations

import ast
import importlib
import pkgutil
import importlib.resources
import os
import subprocess
import sys
from pathlib import Path

import pytest

import acnmp_core
from tests.paths import ROOT


# torch, numpy and friends are typed but large; the check is about acnmp_core's own names
MYPY_INI = """[mypy]
follow_imports = silent
[mypy-torch.*,numpy.*,matplotlib.*,tqdm.*]
follow_imports = skip
follow_imports_for_stubs = True
"""


def _mypy(tmp_path: Path, script: str) -> subprocess.CompletedProcess:
    pytest.importorskip("mypy", reason="mypy is in the test extras (scripts/setup.sh installs it)")
    (tmp_path / "user.py").write_text(script)
    (tmp_path / "mypy.ini").write_text(MYPY_INI)
    env = dict(os.environ, MYPYPATH=str(ROOT))
    return subprocess.run([sys.executable, "-m", "mypy", "--no-incremental", "--config-file", "mypy.ini",
                           "--cache-dir", str(tmp_path / "cache"), "user.py"],
                          cwd=tmp_path, env=env, capture_output=True, text=True)


def test_a_type_checker_passes_a_correct_user_script(tmp_path):
    r = _mypy(tmp_path, "from acnmp_core import CNMP, CNMPConfig, DemoSet, TrainConfig, train\n"
                        "def fit(demos: DemoSet) -> None:\n"
                        "    reveal_type(train(CNMP(CNMPConfig(n_outputs=2)), demos, TrainConfig(steps=10)))\n")
    assert r.returncode == 0, r.stdout + r.stderr
    assert 'Revealed type is "acnmp_core.model.training.TrainResult"' in r.stdout


def test_a_type_checker_reports_a_wrong_argument_to_the_public_api(tmp_path):
    r = _mypy(tmp_path, "from acnmp_core import CNMP, CNMPConfig\n"
                        "model: CNMP = CNMP(CNMPConfig(n_outputs='two'))\n")
    assert r.returncode == 1, r.stdout + r.stderr
    assert 'Argument "n_outputs" to "CNMPConfig" has incompatible type "str"; expected "int"' in r.stdout


def test_every_public_name_is_exported_explicitly_and_resolves():
    """``__all__``, the lazy table and the TYPE_CHECKING imports name the same things."""
    tree = ast.parse(Path(acnmp_core.__file__).read_text())
    typed = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.If) and getattr(node.test, "id", None) == "TYPE_CHECKING":
            for imp in node.body:
                typed |= {alias.name for alias in imp.names}
    assert set(acnmp_core.__all__) == typed == set(acnmp_core._EXPORTS)
    # every folder imported first: a subpackage named like a public name would take its place
    for info in pkgutil.iter_modules(acnmp_core.__path__):
        importlib.import_module(f"acnmp_core.{info.name}")
    for name in acnmp_core.__all__:
        assert getattr(acnmp_core, name).__name__ == name


def test_the_package_ships_its_py_typed_marker():
    assert importlib.resources.files("acnmp_core").joinpath("py.typed").is_file()
    assert '"py.typed"' in (ROOT / "pyproject.toml").read_text().split("[tool.setuptools.package-data]")[1]
