"""Every option of a command line explains itself: the benchmarks' mains and every ``acnmp``
subcommand (``acnmp experiment ...`` included) give each option a help line."""
from __future__ import annotations

import argparse
import ast

from tests.paths import ROOT


def _options_without_help(path) -> list[str]:
    """``path:line --option`` for each ``add_argument("--option", ...)`` call in ``path`` with no
    ``help=`` (a ``**kwargs`` call may carry one and counts as explained)."""
    out = []
    for node in ast.walk(ast.parse(path.read_text())):
        if (isinstance(node, ast.Call) and isinstance(node.func, ast.Attribute) and node.func.attr == "add_argument"
                and node.args and isinstance(node.args[0], ast.Constant) and str(node.args[0].value).startswith("-")
                and not any(k.arg in ("help", None) for k in node.keywords)):
            out.append(f"{path.relative_to(ROOT)}:{node.lineno} {node.args[0].value}")
    return out


def test_every_option_of_a_benchmark_main_has_a_help_line():
    missing = [m for path in sorted((ROOT / "benchmarks").rglob("*.py")) for m in _options_without_help(path)]
    assert not missing, "options without help:\n" + "\n".join(missing)


def test_every_option_of_every_acnmp_subcommand_has_a_help_line():
    from clients.cli import build_parser

    missing = []

    def walk(parser, path):
        for action in parser._actions:
            if isinstance(action, argparse._SubParsersAction):
                for name, sub in action.choices.items():
                    walk(sub, [*path, name])
            elif action.option_strings and action.help is None:
                missing.append(f"{' '.join(path)} {action.option_strings[0]}")

    walk(build_parser(), ["acnmp"])
    assert not missing, "options without help:\n" + "\n".join(missing)
