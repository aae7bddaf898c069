"""``acnmp replay FILE.rrd``: summarise a recording (roll-outs and rewards per job, model versions)."""
from __future__ import annotations

from services import replay


def register(subparsers) -> None:
    """Add the ``replay`` sub-command."""
    parser = subparsers.add_parser("replay", help="summarise a recording written by the recorder",
                                   description=replay.__doc__.splitlines()[0])
    replay.add_arguments(parser)
    parser.set_defaults(func=replay.run_from_args)
