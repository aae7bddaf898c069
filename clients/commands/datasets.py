"""Datasets in and out on the command line: ``acnmp demos import --format lerobot|minari|rosbag2
SOURCE... -o demos.npz`` (demonstrations from a LeRobot or Minari dataset or from ROS 2 bags) and
the export of a recording's roll-outs (``acnmp replay FILE.rrd --export-lerobot DIR`` /
``--export-minari DATASET_ID`` / ``--export-rosbag2 DIR``). docs/DATA.md describes both, with the
formats."""
from __future__ import annotations

import argparse
import math

from services.transport.argtypes import int_at_least, non_empty

FORMATS = ("lerobot", "minari", "rosbag2")

IMPORT_EPILOG = """\
examples:
  acnmp demos import --format lerobot ~/data/so101_pick --list          # its features and fields
  acnmp demos import --format lerobot ~/data/so101_pick -o pick.npz \\
      --trajectory observation.state[0:5] --task-params observation.environment_state@last
  acnmp demos import --format minari acnmp/e1-v0 -o e1.npz --trajectory actions \\
      --task-params acnmp/task_params --successful
  acnmp demos import --format rosbag2 bags/* --list                    # topics, types, counts
  acnmp demos import --format rosbag2 arm.bag -o arm.npz --split topic:/goal \\
      --trajectory '/joint_states:position[shoulder,elbow,wrist]' --task-params /goal:pose.position@first
  acnmp demos import --format rosbag2 out/bags/* -o back.npz --trajectory /acnmp/trajectory \\
      --task-params acnmp.task_params --successful                   # an export's roll-outs
  acnmp up --demos pick=pick.npz                                        # a skill trained on them
"""


def _list(text: str) -> list[str]:
    """A comma-separated list, commas inside brackets kept (``a[0:2],b``)."""
    out, depth, cur = [], 0, ""
    for ch in text:
        depth += ch == "["
        depth -= ch == "]"
        if ch == "," and depth == 0:
            out.append(cur)
            cur = ""
        else:
            cur += ch
    out.append(cur)
    if any(not s.strip() for s in out):
        raise argparse.ArgumentTypeError(f"{text!r}: an empty entry in the list")
    return [s.strip() for s in out]


def _episodes(text: str) -> tuple[int, ...]:
    """``0,3,5-9`` as episode indices."""
    out: list[int] = []
    for part in _list(text):
        a, _, b = part.partition("-")
        try:
            lo, hi = int(a), int(b) if b else int(a)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{part!r}: not an episode index or range (expected e.g. 0,3,5-9)") from None
        if lo < 0 or hi < lo:
            raise argparse.ArgumentTypeError(f"{part!r}: expected indices >= 0, ranges low-high")
        out.extend(range(lo, hi + 1))
    return tuple(out)


def register_import(sub) -> None:
    """Add ``demos import`` to the ``demos`` sub-commands ``sub``."""
    p = sub.add_parser("import", help="demonstrations from a LeRobot or Minari dataset or ROS 2 bags",
                       description="Demonstrations (.npz) from a LeRobot v3 dataset (a local directory, e.g. a hub "
                                   "dataset already downloaded), a Minari dataset (an id under $MINARI_DATASETS_PATH "
                                   "or ~/.minari/datasets, or its directory) or ROS 2 bags (rosbag2, MCAP or SQLite: "
                                   "one episode per bag, or --split). Feature names become the skill's output "
                                   "and task-parameter names. docs/DATA.md has the details.",
                       epilog=IMPORT_EPILOG, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("source", nargs="+", metavar="DATASET",
                   help="LeRobot: the dataset's root directory; Minari: a dataset id or directory; rosbag2: one or more "
                        "bag directories (a bag per episode unless --split)")
    p.add_argument("--format", required=True, choices=FORMATS, help="the dataset's format")
    p.add_argument("-o", "--output", type=non_empty, metavar="DEMOS.npz", help="file to write (not with --list)")
    p.add_argument("--list", action="store_true", help="print the dataset's features and per-episode fields, write nothing")
    p.add_argument("--trajectory", type=_list, metavar="F[,F]",
                   help="per-frame features that make each row, concatenated: NAME, NAME[i] or NAME[i:j] "
                        "(e.g. observation.state[0:3] or actions); rosbag2: TOPIC[:FIELD.FIELD...] on one topic, a "
                        "field optionally [i], [i:j], [name,...] (joints by name) or [*] (a row per element), e.g. "
                        "'/joint_states:position[shoulder,elbow]' or '/arm/cmd:points[*].positions' (a JointState's "
                        "default: position; a JointTrajectory's: points[*].positions)")
    p.add_argument("--task-params", type=_list, default=[], metavar="P[,P]",
                   help="task parameters: a per-frame feature at the first or last frame (NAME@first, NAME@last) or a "
                        "per-episode field (NAME), sliced like --trajectory (default: none); rosbag2: a topic's first "
                        "or last message in the episode (/goal:pose.position@first) or a key of the bags' custom_data "
                        "(acnmp.task_params)")
    p.add_argument("--episodes", type=_episodes, default=None, metavar="IDS", help="only these episodes (e.g. 0,3,5-9)")
    p.add_argument("--successful", action="store_true",
                   help="only the episodes the dataset marks successful (LeRobot next.success, Minari infos/success, "
                        "a bag's custom_data acnmp.success)")
    p.add_argument("--phase", choices=("normalized", "time"), default="normalized",
                   help="times: each episode's time mapped to [0, 1] (default), or the dataset's time from the "
                        "episode's start (LeRobot and bags: s, Minari: steps)")
    p.add_argument("--time", default=None, metavar="FEATURE",
                   help="the per-frame feature holding the time (default: LeRobot's timestamp, Minari's step index); "
                        "rosbag2: header (each message's header stamp) or receive (when the bag received it); default: "
                        "the header's stamp where the message has one and it is set, else the receive time")
    p.add_argument("--split", type=_split, default=None, metavar="HOW",
                   help="rosbag2: episodes within a bag: topic:/TOPIC (each message on it starts one), gap:SECONDS (a "
                        "pause longer than that ends one) or ranges:A-B[,C-D...] (seconds from the trajectory's first "
                        "message); default: one episode per bag")
    p.add_argument("--given-task-params", type=_numbers, action="append", default=[], metavar="V[,V]",
                   help="rosbag2: task parameters given per episode, once per episode in order (after those of "
                        "--task-params)")
    p.add_argument("--given-task-param-names", type=_list, default=None, metavar="N[,N]",
                   help="rosbag2: the names of --given-task-params (default: p0, p1, ...)")
    p.add_argument("--align", choices=("before", "after"), default=None,
                   help="a trajectory feature with one row more than the episode's steps (Minari's observations: "
                        "the reset state first): before: rows 0..T-1, the state each step starts from; after: rows "
                        "1..T, the state each step reaches (what a robot that tracks one row per step is commanded); "
                        "default: every row (features of different lengths cut to the shortest); not for bags")
    p.add_argument("--resample", type=int_at_least(2), default=None, metavar="T",
                   help="T rows per demonstration, linearly interpolated over the phase (default: each episode's own "
                        "frames; different lengths are kept, padded, with their lengths)")
    p.set_defaults(func=run_import)


def _split(text: str):
    from acnmp_core.datasets.rosbag2 import parse_split

    try:
        return parse_split(text)
    except ValueError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None


def _numbers(text: str) -> tuple[float, ...]:
    """``0.5,-0.2`` as finite numbers."""
    try:
        values = tuple(float(v) for v in _list(text))
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r}: expected comma-separated numbers, e.g. 0.5,-0.2") from None
    if not all(math.isfinite(v) for v in values):
        raise argparse.ArgumentTypeError(f"{text!r}: expected finite numbers")
    return values


def read_dataset(fmt: str, source: str):
    """The episodes of ``source`` in format ``fmt`` (DatasetError when it is not such a dataset)."""
    if fmt == "lerobot":
        from acnmp_core.datasets.lerobot import read_lerobot

        return read_lerobot(source)
    from acnmp_core.datasets.minari import read_minari

    return read_minari(source)


def run_import(args) -> int:
    """``acnmp demos import``: write the demonstrations (or list the dataset); a bad dataset,
    feature or option is a ValueError (one line, exit 2) before anything is written."""
    from acnmp_core.datasets.selection import Selection, parse_feature, select_demos
    from services.transport.argtypes import check_output_path

    from .common import write_demos

    bags = args.format == "rosbag2"
    if not bags:
        if len(args.source) > 1:
            raise ValueError(f"DATASET: one {args.format} dataset (got {len(args.source)}; several sources are bags)")
        extra = [o for o, v in (("--split", args.split), ("--given-task-params", args.given_task_params),
                                ("--given-task-param-names", args.given_task_param_names)) if v]
        if extra:
            raise ValueError(f"{extra[0]}: only with --format rosbag2")
    if args.list:
        if bags:
            from acnmp_core.datasets.rosbag2 import describe_bags

            print(describe_bags(args.source))
        else:
            print(describe(read_dataset(args.format, args.source[0])))
        return 0
    if not args.output or not args.trajectory:
        raise ValueError("--output and --trajectory: both needed to write demonstrations (or --list to look first)")
    check_output_path(args.output, "--output")
    if bags:
        if args.align:  # Minari's observations have the reset state first; a bag's trajectory does not
            raise ValueError("--align: for a feature with one row more than the episode's steps (Minari's "
                             "observations); a bag's trajectory has a row per message: not with --format rosbag2")
        data, selection = _bag_selection(args)
    else:
        try:
            selection = Selection(tuple(parse_feature(t) for t in args.trajectory),
                                  tuple(parse_feature(t, task_param=True) for t in args.task_params),
                                  episodes=args.episodes, successful=args.successful, phase=args.phase, time=args.time,
                                  resample=args.resample, align=args.align)
        except ValueError as exc:
            raise ValueError(f"--trajectory/--task-params: {exc}") from None
        data = read_dataset(args.format, args.source[0])
    demos = select_demos(data, selection)
    code = write_demos(args.output, demos)
    warn_constant_task_params(demos)
    return code


def warn_constant_task_params(demos) -> None:
    """Say on stderr which task parameters of ``demos`` (DemoArrays) have one value in every one of
    its two or more demonstrations (e.g. a goal's z on a table): a constant tells the skill nothing,
    and an adaptation must then be given that value too."""
    import sys

    import numpy as np

    tp = np.asarray(demos.task_params)
    if tp.shape[0] < 2:
        return
    names = [str(n) for n in demos.task_param_names] if demos.task_param_names is not None else []
    for j in np.flatnonzero(np.all(tp == tp[0], axis=0)):
        name = names[j] if j < len(names) else f"task parameter {j}"
        print(f"acnmp demos import: warning: task parameter {name!r} is {tp[0, j]:g} in every demonstration (a "
              "constant tells the skill nothing; select the others, e.g. FIELD[0:2]@first)", file=sys.stderr)


def _bag_selection(args):
    """The episodes of the bags ``args.source`` and the Selection that makes demonstrations of
    them, from the options (ValueError naming the option for a malformed one)."""
    from acnmp_core.datasets.message_paths import parse_ref
    from acnmp_core.datasets.rosbag2 import TIME, BagSelection, Split, read_rosbag2
    from acnmp_core.datasets.selection import FeatureRef, Selection, TaskParamRef, parse_feature

    try:
        trajectory = tuple(parse_ref(t) for t in args.trajectory)
        params = [parse_ref(t, task_param=True) if t.startswith("/") else parse_feature(t, task_param=True)
                  for t in args.task_params]
        if any(isinstance(p, TaskParamRef) and p.at for p in params):
            bad = next(p for p in params if isinstance(p, TaskParamRef) and p.at)
            raise ValueError(f"{bad.text!r}: @first/@last are for a topic's messages (expected a custom_data key alone)")
        topic_params = tuple(p for p in params if not isinstance(p, TaskParamRef))
        sel = BagSelection(trajectory, topic_params,
                           meta_params=tuple(p.ref.name for p in params if isinstance(p, TaskParamRef)),
                           split=args.split or Split(), time=args.time, given=tuple(args.given_task_params),
                           given_names=tuple(args.given_task_param_names or ()))
    except ValueError as exc:
        raise ValueError(f"--trajectory/--task-params/--time: {exc}") from None
    refs = tuple(TaskParamRef(FeatureRef(p.text)) if not isinstance(p, TaskParamRef) else p for p in params)
    refs += (TaskParamRef(FeatureRef("given")),) if args.given_task_params else ()
    selection = Selection((FeatureRef(sel.feature),), refs, episodes=args.episodes, successful=args.successful,
                          phase=args.phase, time=TIME, resample=args.resample, align=args.align)
    return read_rosbag2(args.source, sel), selection


def describe(data) -> str:
    """The features and fields of ``data`` (DatasetEpisodes), one per line."""
    lines = [f"{data.path}: {data.format} dataset, {len(data.episodes)} episodes"]
    if data.episodes:
        first = data.episodes[0]
        lines.append("per-frame features (episode %d: %d frames):" % (first.index, max(len(v) for v in first.frames.values())))
        for name, arr in first.frames.items():
            names = data.names.get(name)
            lines.append(f"  {name:<28} ({arr.shape[1]},)" + (f"  {', '.join(names)}" if names else ""))
        for name, shape in data.ranks.items():
            lines.append(f"  {name:<28} {tuple(shape)}  (not a vector: cannot be used)")
        if first.fields or first.labels:
            lines.append("per-episode fields:")
            lines += [f"  {name:<28} ({len(v)},)" for name, v in first.fields.items()]
            lines += [f"  {name:<28} text: {v[:40]}" for name, v in first.labels.items()]
        marked = [ep for ep in data.episodes if ep.success is not None]
        if marked:
            lines.append(f"successful: {sum(ep.success for ep in marked)} of {len(marked)}")
    return "\n".join(lines)


def export_rollouts(tables, *, lerobot: str | None, minari: str | None, job: str | None, fps: int,
                    rosbag2: str | None = None, storage: str = "mcap", duration: float | None = None) -> list[str]:
    """Write the roll-outs of ``tables`` (RecordingTables; of ``job`` when given) as a LeRobot
    dataset at ``lerobot``, a Minari dataset ``minari`` and/or ROS 2 bags in ``rosbag2`` (with
    ``storage``, each roll-out lasting ``duration`` s when given); returns the lines to print."""
    from acnmp_core.datasets.lerobot import write_lerobot
    from acnmp_core.datasets.minari import write_minari

    rollouts = tables.rollout_episodes(job=job)
    lines = []
    if rosbag2:
        from acnmp_core.datasets.rosbag2 import write_rosbag2

        path = write_rosbag2(rosbag2, rollouts, storage=storage, duration=duration)
        lines.append(f"wrote {path}: {len(rollouts)} ROS 2 bags ({storage}), rollout_0000 ... "
                     f"(acnmp demos import --format rosbag2 {path}/* --trajectory /acnmp/trajectory)")
    if lerobot:
        path = write_lerobot(lerobot, rollouts, fps=fps, robot_type=rollouts[0].robot or None if rollouts else None)
        lines.append(f"wrote {path}: LeRobot v3 dataset, {len(rollouts)} episodes "
                     f"(LeRobotDataset('acnmp/rollouts', root='{path}'))")
    if minari:
        path = write_minari(minari, rollouts)
        lines.append(f"wrote {path}: Minari dataset {minari!r}, {len(rollouts)} episodes (minari.load_dataset('{minari}'))")
    return lines
