"""Datasets in and out on the command line: ``acnmp demos import --format lerobot|minari SOURCE
-o demos.npz`` (demonstrations from a LeRobot or Minari dataset) and the export of a recording's
roll-outs (``acnmp replay FILE.rrd --export-lerobot DIR`` / ``--export-minari DATASET_ID``).
docs/DATA.md describes both, with the formats."""
from __future__ import annotations

import argparse

from services.transport.argtypes import int_at_least, non_empty

FORMATS = ("lerobot", "minari")

IMPORT_EPILOG = """\
examples:
  acnmp demos import --format lerobot ~/data/so101_pick --list          # its features and fields
  acnmp demos import --format lerobot ~/data/so101_pick -o pick.npz \\
      --trajectory observation.state[0:5] --task-params observation.environment_state@last
  acnmp demos import --format minari acnmp/e1-v0 -o e1.npz --trajectory actions \\
      --task-params acnmp/task_params --successful
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
    p = sub.add_parser("import", help="demonstrations from a LeRobot or Minari dataset",
                       description="Demonstrations (.npz) from a LeRobot v3 dataset (a local directory, e.g. a hub "
                                   "dataset already downloaded) or a Minari dataset (an id under $MINARI_DATASETS_PATH "
                                   "or ~/.minari/datasets, or its directory). Feature names become the skill's output "
                                   "and task-parameter names. docs/DATA.md has the details.",
                       epilog=IMPORT_EPILOG, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("source", metavar="DATASET", help="LeRobot: the dataset's root directory; Minari: a dataset id or directory")
    p.add_argument("--format", required=True, choices=FORMATS, help="the dataset's format")
    p.add_argument("-o", "--output", type=non_empty, metavar="DEMOS.npz", help="file to write (not with --list)")
    p.add_argument("--list", action="store_true", help="print the dataset's features and per-episode fields, write nothing")
    p.add_argument("--trajectory", type=_list, metavar="F[,F]",
                   help="per-frame features that make each row, concatenated: NAME, NAME[i] or NAME[i:j] "
                        "(e.g. observation.state[0:3] or actions)")
    p.add_argument("--task-params", type=_list, default=[], metavar="P[,P]",
                   help="task parameters: a per-frame feature at the first or last frame (NAME@first, NAME@last) or a "
                        "per-episode field (NAME), sliced like --trajectory (default: none)")
    p.add_argument("--episodes", type=_episodes, default=None, metavar="IDS", help="only these episodes (e.g. 0,3,5-9)")
    p.add_argument("--successful", action="store_true",
                   help="only the episodes the dataset marks successful (LeRobot next.success, Minari infos/success)")
    p.add_argument("--phase", choices=("normalized", "time"), default="normalized",
                   help="times: each episode's time mapped to [0, 1] (default), or the dataset's time from the "
                        "episode's start (LeRobot: s, Minari: steps)")
    p.add_argument("--time", default=None, metavar="FEATURE",
                   help="the per-frame feature holding the time (default: LeRobot's timestamp, Minari's step index)")
    p.add_argument("--align", choices=("before", "after"), default=None,
                   help="a trajectory feature with one row more than the episode's steps (Minari's observations: "
                        "the reset state first): before: rows 0..T-1, the state each step starts from; after: rows "
                        "1..T, the state each step reaches (what a robot that tracks one row per step is commanded); "
                        "default: every row (features of different lengths cut to the shortest)")
    p.add_argument("--resample", type=int_at_least(2), default=None, metavar="T",
                   help="T rows per demonstration, linearly interpolated over the phase (default: each episode's own "
                        "frames; different lengths are kept, padded, with their lengths)")
    p.set_defaults(func=run_import)


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

    if args.list:
        data = read_dataset(args.format, args.source)
        print(describe(data))
        return 0
    if not args.output or not args.trajectory:
        raise ValueError("--output and --trajectory: both needed to write demonstrations (or --list to look first)")
    check_output_path(args.output, "--output")
    try:
        selection = Selection(tuple(parse_feature(t) for t in args.trajectory),
                              tuple(parse_feature(t, task_param=True) for t in args.task_params),
                              episodes=args.episodes, successful=args.successful, phase=args.phase, time=args.time,
                              resample=args.resample, align=args.align)
    except ValueError as exc:
        raise ValueError(f"--trajectory/--task-params: {exc}") from None
    data = read_dataset(args.format, args.source)
    demos = select_demos(data, selection)
    return write_demos(args.output, demos)


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


def export_rollouts(tables, *, lerobot: str | None, minari: str | None, job: str | None, fps: int) -> list[str]:
    """Write the roll-outs of ``tables`` (RecordingTables; of ``job`` when given) as a LeRobot
    dataset at ``lerobot`` and/or a Minari dataset ``minari``; returns the lines to print."""
    from acnmp_core.datasets.lerobot import write_lerobot
    from acnmp_core.datasets.minari import write_minari

    rollouts = tables.rollout_episodes(job=job)
    lines = []
    if lerobot:
        path = write_lerobot(lerobot, rollouts, fps=fps, robot_type=rollouts[0].robot or None if rollouts else None)
        lines.append(f"wrote {path}: LeRobot v3 dataset, {len(rollouts)} episodes "
                     f"(LeRobotDataset('acnmp/rollouts', root='{path}'))")
    if minari:
        path = write_minari(minari, rollouts)
        lines.append(f"wrote {path}: Minari dataset {minari!r}, {len(rollouts)} episodes (minari.load_dataset('{minari}'))")
    return lines
