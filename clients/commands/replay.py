"""``acnmp replay FILE.rrd``: summarise a recording (jobs by method and skill, roll-outs and rewards,
model versions, the learner's curves); export it as Parquet tables; run its roll-outs again."""
from __future__ import annotations

import argparse
import json
import sys

from services.transport.argtypes import int_at_least, non_empty, seconds

EPILOG = """\
examples:
  acnmp replay run.rrd                          # what it holds: jobs by method and skill, curves
  acnmp replay run.rrd --export tables/         # rollouts/jobs/latents/models/metrics.parquet
  acnmp replay run.rrd --execute                # every roll-out again here: recorded vs now
  acnmp replay run.rrd --execute --namespace lab --job e1-0123456789   # on a deployment's workers
  acnmp replay run.rrd                          # also run.1.rrd, run.2.rrd, ...: the recording's segments
  acnmp replay old.rrd new.rrd --export t/      # files of one deployment, each roll-out once
  acnmp replay run.rrd --export-lerobot e1-lerobot/     # each roll-out an episode of a LeRobot v3 dataset
  acnmp replay run.rrd --export-minari acnmp/e1-v0      # ... of a Minari dataset ($MINARI_DATASETS_PATH)
  acnmp replay run.rrd --export-rosbag2 e1-bags/        # each roll-out a ROS 2 bag (MCAP): e1-bags/rollout_0000, ...
  acnmp replay run.rrd --export-rosbag2 bags/ --duration 2   # time_from_start over 2 s: the robot's pace

In Python: services.recording.tables.read_recording("run.rrd") gives the same tables (pyarrow),
.trajectories(job) a (N, T, D) numpy array; `acnmp demos from-recording` writes demonstrations.
"""


def register(subparsers) -> None:
    """Add the ``replay`` sub-command."""
    parser = subparsers.add_parser(
        "replay", help="summarise, export (Parquet) or re-execute a recording",
        description=__doc__.splitlines()[0].split(": ", 1)[1] + "\n" + __doc__.splitlines()[1],
        epilog=EPILOG, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("files", nargs="+", metavar="FILE.rrd",
                        help="recording(s) written by the recorder; several: one deployment's files, oldest first")
    parser.add_argument("--json", action="store_true", help="print the summary (or the re-execution) as JSON")
    parser.add_argument("--export", metavar="DIR", type=non_empty, default=None,
                        help="write every roll-out, job, latent, model version and metric as Parquet tables "
                             "in DIR, each task parameter a column (task_config.<key>[.<i>], task_params.<i>; "
                             "schemas: docs/EVENTS.md, 'Recordings as data')")
    parser.add_argument("--export-lerobot", metavar="DIR", type=non_empty, default=None,
                        help="write every roll-out as an episode of a new LeRobot v3 dataset in DIR (docs/DATA.md)")
    parser.add_argument("--export-minari", metavar="DATASET_ID", type=non_empty, default=None,
                        help="write every roll-out as an episode of the new Minari dataset DATASET_ID, e.g. acnmp/e1-v0, "
                             "under $MINARI_DATASETS_PATH or ~/.minari/datasets (docs/DATA.md)")
    parser.add_argument("--export-rosbag2", metavar="DIR", type=non_empty, default=None,
                        help="write every roll-out as a ROS 2 bag of its own in the new directory DIR: its trajectory "
                             "a trajectory_msgs/JointTrajectory, its reward and success on their own topics, its job, "
                             "skill and task parameters in the bag's metadata (docs/DATA.md)")
    parser.add_argument("--storage", choices=("mcap", "sqlite3"), default="mcap",
                        help="with --export-rosbag2: the bags' storage (default: %(default)s)")
    parser.add_argument("--duration", type=seconds(), default=None, metavar="S",
                        help="with --export-rosbag2: each roll-out's time_from_start and stamps scaled so it lasts S "
                             "seconds, the robot's pace for `ros2 bag play` (default: the recorded time, the phase: "
                             "1 s for E1)")
    parser.add_argument("--fps", type=int_at_least(1), default=10, metavar="N",
                        help="with --export-lerobot: the dataset's frames per second (timestamps = frame / N; default 10)")
    parser.add_argument("--execute", action="store_true",
                        help="run the recorded roll-outs again and compare each return with the recorded one "
                             "(exit 1 if any differs)")
    parser.add_argument("--namespace", "-n", default=None, metavar="NS",
                        help="with --execute: on the workers of the running deployment NS (default: in this process)")
    parser.add_argument("--job", default=None, metavar="JOB",
                        help="with --execute or an export to a dataset or bags: only this job's roll-outs")
    parser.add_argument("--limit", type=int_at_least(1), default=None, metavar="N",
                        help="with --execute: at most N roll-outs per job")
    parser.set_defaults(func=run)


def run(args) -> int:
    """Print the summary of each file, export or re-execute; 0, or 1 if a file cannot be read or a
    re-executed return differs."""
    from services.recording.replay import format_summary, summarize

    datasets = bool(args.export_lerobot or args.export_minari or args.export_rosbag2)
    if args.duration is not None and not args.export_rosbag2:
        raise ValueError("--duration: only with --export-rosbag2")
    if (args.namespace or args.limit) and not args.execute:
        raise ValueError("--namespace, --limit: only with --execute")
    if args.job and not (args.execute or datasets):
        raise ValueError("--job: only with --execute, --export-lerobot, --export-minari or --export-rosbag2")
    try:
        if args.export or args.execute or datasets:
            from services.recording.tables import read_recording

            tables = read_recording(args.files)
        else:  # a file given beside its first one is read with it (one recording, its segments)
            from pathlib import Path

            covered: set[Path] = set()
            summaries = []
            for f in args.files:
                if Path(f) in covered:
                    continue
                summaries.append(summarize(f))
                covered.update(Path(s["path"]) for s in summaries[-1]["segments"])
    except (OSError, ValueError) as exc:  # missing, a directory, unreadable, not a recording
        print(f"acnmp replay: {exc}", file=sys.stderr)
        return 1
    if datasets:
        from .datasets import export_rollouts

        for line in export_rollouts(tables, lerobot=args.export_lerobot, minari=args.export_minari,
                                    rosbag2=args.export_rosbag2, job=args.job, fps=args.fps, storage=args.storage,
                                    duration=args.duration):
            print(line)
        if not (args.export or args.execute):
            return 0
    if args.export:
        paths = tables.write_parquet(args.export)
        for name, path in paths.items():
            print(f"wrote {path} ({getattr(tables, name).num_rows} rows)")
        if not args.execute:
            return 0
    if args.execute:
        return _execute(args, tables)
    if args.json:
        print(json.dumps(summaries[0] if len(summaries) == 1 else summaries, indent=2))
    else:
        print("\n".join(format_summary(s) for s in summaries))
    return 0


def _execute(args, tables) -> int:
    from tqdm import tqdm

    from services.recording.reexecute import local_evaluator, reexecute

    total = tables.rollouts.num_rows
    with _evaluators(args) as evaluator_for, tqdm(total=total, unit="rollout", desc="re-executing",
                                                  disable=None if not args.json else True) as bar:
        results, skipped = reexecute(tables, job=args.job, limit=args.limit,
                                     evaluator_for=evaluator_for or local_evaluator, on_done=lambda _r: bar.update())
    differ = [r for r in results if not r.equal]
    if args.json:
        print(json.dumps({"rollouts": len(results), "equal": len(results) - len(differ),
                          "differ": [vars(r) for r in differ], "skipped_jobs": skipped}, indent=2))
    else:
        jobs = sorted({r.job for r in results})
        for job in jobs:
            mine = [r for r in results if r.job == job]
            worst = max(abs(r.return_now - r.recorded_return) for r in mine)
            print(f"job {job}: {len(mine)} roll-outs again, {sum(r.equal for r in mine)} equal, "
                  f"largest return difference {worst:.3g}")
        for r in differ[:20]:
            print(f"  differs: job {r.job} roll-out {r.rollout_index}: recorded return {r.recorded_return!r}, "
                  f"now {r.return_now!r}; success {r.recorded_success} -> {r.success_now}")
        for job, why in skipped.items():
            print(f"job {job}: not re-executed ({why})")
        print(f"{len(results)} roll-outs re-executed, {len(results) - len(differ)} with the recorded return")
    return 1 if differ or not results else 0


class _evaluators:
    """``with _evaluators(args) as make``: None (in this process), or ``make(robot, task, task_config)``
    giving remote evaluators on the running deployment ``--namespace`` (operator credentials)."""

    def __init__(self, args):
        self.args, self.client = args, None

    def __enter__(self):
        if self.args.namespace is None:
            return None
        from clients.client import ACNMPClient
        from services.transport.runfile import DeploymentNotFound, find
        from services.worker.remote import RemoteEvaluator

        try:
            run = find(self.args.namespace)
        except DeploymentNotFound:
            raise ValueError(f"--namespace {self.args.namespace}: no such deployment is running "
                             "(`acnmp status` lists them)") from None
        self.client = ACNMPClient(run.namespace, role="operator", timeout=30).__enter__()
        client = self.client
        return lambda robot, task, task_config: RemoteEvaluator(client.session, client.keys, robot, task, task_config)

    def __exit__(self, *exc):
        if self.client is not None:
            self.client.__exit__(*exc)
        return False
