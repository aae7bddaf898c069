"""The docs and the code agree on every error code: each code the code can answer with is in
``ERROR_CODES`` and in the table of docs/PROTOCOL.md section 3, and that table lists nothing else."""
from __future__ import annotations

import ast
import re

from services.transport.errors import CODES
from services.transport.wire import ERROR_CODES
from tests.paths import ROOT

PROTOCOL = ROOT / "docs" / "PROTOCOL.md"
#: Calls whose first argument is an error code.
CODE_CALLS = {"WireError", "ClientError", "error_payload", "_fail"}


def documented_codes() -> set[str]:
    """The codes of the table in docs/PROTOCOL.md section 3 ("Errors")."""
    text = PROTOCOL.read_text(encoding="utf-8")
    section = text.split("## 3. Errors", 1)[1].split("\n## ", 1)[0]
    return set(re.findall(r"^\| `([a-z_]+)` \|", section, flags=re.M))


def codes_in_source() -> dict[str, list[str]]:
    """Every literal code passed to a WireError/ClientError/error_payload/_fail call, or as the
    ``default=`` of ``wire_error``, in services/ and clients/ -> where it appears."""
    found: dict[str, list[str]] = {}
    for path in sorted([*ROOT.glob("services/**/*.py"), *ROOT.glob("clients/**/*.py")]):
        tree = ast.parse(path.read_text(encoding="utf-8"))
        for node in ast.walk(tree):
            if not isinstance(node, ast.Call):
                continue
            func = node.func
            name = func.id if isinstance(func, ast.Name) else func.attr if isinstance(func, ast.Attribute) else ""
            args = []
            if name in CODE_CALLS and node.args:
                args.append(node.args[0] if name != "_fail" or len(node.args) < 2 else node.args[1])
            if name == "wire_error":
                args += [kw.value for kw in node.keywords if kw.arg == "default"]
            for arg in args:
                if isinstance(arg, ast.Constant) and isinstance(arg.value, str):
                    found.setdefault(arg.value, []).append(f"{path.relative_to(ROOT)}:{node.lineno}")
    return found


def test_every_code_the_code_raises_is_documented():
    found = codes_in_source()
    assert len(found) >= 10, found  # the scan sees the codes (a broken scan must not pass silently)
    undocumented = {code: where for code, where in found.items() if code not in ERROR_CODES}
    assert not undocumented, undocumented
    assert set(CODES.values()) <= set(ERROR_CODES)


def test_protocol_table_and_error_codes_are_the_same_set():
    assert documented_codes() == set(ERROR_CODES)
