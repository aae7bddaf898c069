"""``acnmp robots``: every robot kind this installation knows, its tasks, and where it comes from."""
from __future__ import annotations

import json
import sys


def register(subparsers) -> None:
    """Add the ``robots`` sub-command."""
    p = subparsers.add_parser("robots", help="list the robot kinds (built in and plugins) and where each comes from",
                              description=__doc__.splitlines()[0].split(": ", 1)[1])
    p.add_argument("plugins", nargs="*", metavar="PACKAGE.MODULE:ATTR",
                   help="also load these plugins (robots of packages that are not installed)")
    p.add_argument("--json", action="store_true", help="print the list as JSON")
    p.set_defaults(func=run)


def run(args) -> int:
    """Print one row per kind (kind, tasks, source, summary), then one line per plugin that could
    not be loaded. Exit 0; 2 when a plugin named on the command line cannot be loaded (after the
    list); installed plugins that fail are listed, not fatal."""
    from acnmp_core.errors import UnknownRobotError
    from acnmp_core.robots.registry import plugin_problems, robot, robot_kinds, robot_source

    failed = []
    for ref in args.plugins:
        try:
            robot(ref)
        except UnknownRobotError as exc:
            failed.append(str(exc).removeprefix("robot: "))
    rows = [{"kind": k, "tasks": sorted(robot(k).tasks), "source": robot_source(k), "summary": robot(k).summary}
            for k in robot_kinds()]
    problems = [str(p) for p in plugin_problems()] + failed
    if args.json:
        print(json.dumps({"robots": rows, "problems": problems}, indent=2))
    else:
        width = max(len(r["kind"]) for r in rows)
        for r in rows:
            print(f"{r['kind']:<{width}}  {', '.join(r['tasks'])}  [{r['source']}]  {r['summary']}")
        for line in problems:
            print(line, file=sys.stderr)
    return 2 if failed else 0
