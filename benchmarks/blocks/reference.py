"""Reference tables the code itself holds, rendered into the docs by benchmarks/report.py like the
measured ones, so that a page cannot drift from the code: the error codes
(:data:`services.transport.wire.ERROR_CODES`, docs/PROTOCOL.md), the key expressions and who
serves and asks each (the router's access table, :data:`services.transport.acl.GRANTS`:
deny-by-default, so it names every key a deployment uses; docs/PROTOCOL.md), that access table
itself (docs/SECURITY.md), the request bound of each key
(:data:`services.transport.payload_limits.REQUEST_LIMITS`, docs/FAULTS.md) and the options of
``acnmp up`` and of every ``acnmp serve`` process (their parsers, docs/OPTIONS.md). No JSON
result is involved: the test of the published numbers (tests/unit/benchmarks/test_published_numbers.py)
fails when the code changed and the page was not rendered again."""
from __future__ import annotations

import argparse

from benchmarks.report_kit import renderer, table

#: the messages by which a role serves or announces a key, each with those by which another uses it
SERVES = {"declare_queryable": ("query",), "liveliness_token": ("declare_liveliness_subscriber", "liveliness_query"),
          "put": ("declare_subscriber",)}


@renderer("error-codes")
def error_codes() -> str:
    """The error codes a reply may carry, with what each means (docs/PROTOCOL.md section 3)."""
    from services.transport.wire import ERROR_CODES

    return table(["code", "meaning"], [[f"`{code}`", meaning] for code, meaning in ERROR_CODES.items()])


def _roles(roles) -> str:
    from services.transport.acl import ROLES

    roles = sorted(set(roles), key=ROLES.index)
    return "every role" if set(roles) == set(ROLES) else ", ".join(roles) or "-"


@renderer("keys")
def keys() -> str:
    """Every key expression a process of a deployment declares a queryable, token or publisher on,
    grouped as the router's access table grants them: the roles that serve or announce them (and
    how), the roles that ask or follow them, and what for (docs/PROTOCOL.md section 5)."""
    import zenoh

    from services.transport.acl import GRANTS

    rows = []
    for grant in GRANTS:
        served = sorted(m for m in grant.messages if m in SERVES)
        keys = [k for k in grant.keys if "/@adv/" not in k]
        if not served or not keys:
            continue
        uses = {u for m in served for u in SERVES[m]}
        exprs = [zenoh.KeyExpr(k) for k in keys]
        asked = {role for g in GRANTS if uses & set(g.messages)
                 for k in g.keys for e in exprs if zenoh.KeyExpr(k).intersects(e) for role in g.roles}
        rows.append([", ".join(f"`{k}`" for k in keys), f"{_roles(grant.roles)} ({', '.join(served)})",
                     _roles(asked), grant.why])
    return table(["key expressions", "served or announced by (how)", "asked or followed by", "what for"], rows)


@renderer("access-table")
def access_table() -> str:
    """The router's access table, one row per grant (docs/SECURITY.md)."""
    from services.transport.acl import grants_markdown

    return grants_markdown()


@renderer("request-bounds")
def request_bounds() -> str:
    """The largest request each queryable key takes (docs/FAULTS.md)."""
    from services.transport.payload_limits import REQUEST_LIMITS

    def size(n: int) -> str:
        return f"{n // 2**20} MiB" if n >= 2**20 else f"{n // 1024} KiB"

    return table(["key", "largest request", "it carries"],
                 [[f"`{lim.key}`", size(lim.max_bytes), lim.carries] for lim in REQUEST_LIMITS])


def _subparsers(parser: argparse.ArgumentParser) -> dict[str, argparse.ArgumentParser]:
    return next((a.choices for a in parser._actions if isinstance(a, argparse._SubParsersAction)), {})


def options_table(parser: argparse.ArgumentParser) -> str:
    """A command's options as its ``--help`` gives them: flags with their value, default, help (the
    robot kinds it lists: the built-in ones, whatever plugins this machine has installed)."""
    from acnmp_core.robots.registry import robot_kinds, robot_source

    kinds = robot_kinds()
    here, built_in = ", ".join(kinds), ", ".join(k for k in kinds if robot_source(k) == "built in")
    formatter = parser._get_formatter()
    rows = []
    for action in parser._actions:
        if not action.option_strings or isinstance(action, argparse._HelpAction):
            continue
        flags = ", ".join(action.option_strings)
        if action.nargs != 0:
            flags += f" {action.metavar or action.dest.upper()}" if not action.choices else \
                f" {{{','.join(map(str, action.choices))}}}"
        default = "" if action.default in (None, False, [], argparse.SUPPRESS) else f"`{action.default}`"
        text = formatter._expand_help(action) if action.help else ""
        rows.append([f"`{flags}`", default, text.replace(here, built_in).replace("|", "\\|").replace("\n", " ")])
    return table(["option", "default", "what it does"], rows)


@renderer("serve-options")
def serve_options() -> str:
    """The options of ``acnmp up`` and of each ``acnmp serve`` process, one table each (docs/OPTIONS.md)."""
    from clients.cli import build_parser

    commands = _subparsers(build_parser())
    parts = ["### `acnmp up`", "", options_table(commands["up"])]
    for name, parser in _subparsers(commands["serve"]).items():
        parts += ["", f"### `acnmp serve {name}`", "", options_table(parser)]
    return "\n".join(parts)
