"""``acnmp demos from-recording FILE.rrd -o demos.npz``: demonstrations out of what a deployment
recorded, in the format ``acnmp up --demos SKILL=demos.npz`` trains on (``acnmp demos make KIND``:
a built-in kind's scripted ones; ``acnmp demos import``:
out of a LeRobot or Minari dataset, clients/commands/datasets.py)."""
from __future__ import annotations

import argparse
import sys

from services.transport.argtypes import non_empty

from .common import write_demos

EPILOG = """\
examples:
  acnmp demos from-recording run.rrd --successful --best-per-job -o found.npz
  acnmp up --demos reach=found.npz        # a skill trained on what the deployment found
"""


def register(subparsers) -> None:
    """Add ``demos`` with its ``from-recording``, ``make`` and ``import`` sub-commands."""
    from .datasets import register_import

    parser = subparsers.add_parser("demos", help="make demonstration files (from a recording, a dataset or a kind's scripted expert)",
                                   description="Make demonstration files.")
    sub = parser.add_subparsers(dest="demos_command", metavar="WHAT", required=True)
    rec = sub.add_parser("from-recording", help="the recorded roll-outs as a demonstrations .npz",
                         description=__doc__.split(": ", 1)[1].replace("\n", " "), epilog=EPILOG,
                         formatter_class=argparse.RawDescriptionHelpFormatter)
    rec.add_argument("files", nargs="+", metavar="FILE.rrd", help="recording(s) of one deployment, oldest first")
    rec.add_argument("-o", "--output", required=True, type=non_empty, metavar="DEMOS.npz", help="file to write")
    rec.add_argument("--job", default=None, metavar="JOB", help="only this job's roll-outs")
    rec.add_argument("--successful", action="store_true", help="only successful roll-outs")
    rec.add_argument("--best-per-job", action="store_true",
                     help="one roll-out per job: its highest return (the successful ones with --successful)")
    rec.set_defaults(func=_run_from_recording)
    make = sub.add_parser("make", help="the scripted demonstrations of a built-in kind as a .npz",
                          description="Write the demonstrations a built-in kind's scripted expert makes (the ones "
                                      "its experiment trains on; failed ones are left out), to serve the kind's "
                                      "skill: acnmp up --robot KIND --demos SKILL=FILE.npz.")
    make.add_argument("kind", choices=SCRIPTED, metavar="KIND", help=f"one of {', '.join(SCRIPTED)}")
    make.add_argument("-o", "--output", required=True, type=non_empty, metavar="DEMOS.npz", help="file to write")
    make.set_defaults(func=_run_make)

    register_import(sub)


#: the kinds whose scripted expert makes demonstrations (the Meta-World ones need the metaworld extra)
SCRIPTED = ("pusher", "metaworld-reach", "metaworld-push", "metaworld-pick-place")


def _run_make(args) -> int:
    from services.transport.argtypes import check_output_path

    check_output_path(args.output, "--output")
    if args.kind == "pusher":
        from acnmp_core.tasks.pusher.scene import pusher_demos

        demos = pusher_demos()
    else:
        from acnmp_core.tasks.metaworld.demos import metaworld_demos

        demos = metaworld_demos(args.kind)
    return write_demos(args.output, demos, f"serve them: acnmp up --robot {args.kind} --demos SKILL={{path}}")


def _run_from_recording(args) -> int:
    from services.recording.tables import read_recording
    from services.transport.argtypes import check_output_path

    check_output_path(args.output, "--output")
    try:
        tables = read_recording(args.files)
    except (OSError, ValueError) as exc:
        print(f"acnmp demos: {exc}", file=sys.stderr)
        return 1
    demos = tables.demonstrations(job=args.job, successful=args.successful, best_per_job=args.best_per_job)
    return write_demos(args.output, demos)
