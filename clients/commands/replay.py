"""``acnmp replay FILE.rrd``: summarise a recording (roll-outs and rewards per job, model versions)."""
from __future__ import annotations

import json
import sys


def register(subparsers) -> None:
    """Add the ``replay`` sub-command."""
    parser = subparsers.add_parser("replay", help="summarise a recording written by the recorder",
                                   description=__doc__.splitlines()[0].split(": ", 1)[1])
    parser.add_argument("file", metavar="FILE.rrd", help="recording written by the recorder")
    parser.add_argument("--json", action="store_true", help="print the summary as JSON")
    parser.set_defaults(func=run)


def run(args) -> int:
    """Print the summary of ``args.file``; exit code 0, or 1 if it cannot be read."""
    from services.recording.replay import format_summary, summarize

    try:
        summary = summarize(args.file)
    except (OSError, ValueError) as exc:  # missing, a directory, unreadable, not a recording
        print(f"acnmp replay: {exc}", file=sys.stderr)
        return 1
    print(json.dumps(summary, indent=2) if args.json else format_summary(summary))
    return 0
