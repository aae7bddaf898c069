"""Roll-outs out as datasets and back as demonstrations: the round trip through LeRobot v3,
Minari and ROS 2 bags, and how fast each direction goes.

1. A distributed E1 (``acnmp experiment viapoint --distributed --record``; ``--budget`` roll-outs
   per method, ``--train-steps``) is recorded, or a given recording (``--rrd``) is used.
2. Per format: the recording's roll-outs exported (``acnmp replay --export-lerobot/--export-minari/
   --export-rosbag2``), loaded by the format's own library when it is installed (LeRobotDataset;
   minari.load_dataset; rosbags' AnyReader, every message deserialised),
   imported back as demonstrations of the successful roll-outs (``acnmp demos import
   --successful``), a CNMP trained on them (``--skill-steps``, the rate decayed to 1e-5), and each
   roll-out reproduced by the skill conditioned where E1's query conditions, on the roll-out's own
   values there: the largest RMSE over the path against E1's tolerance (0.03 m).
3. Throughput at a larger size: ``--episodes`` synthetic roll-outs of E1's shape written and read
   by the project's own writer and reader (episodes per second each way).

Writes ``benchmarks/results/bench_datasets.json``. Usage::

    python benchmarks/performance/bench_datasets.py [--budget 100] [--train-steps 3000] [--episodes 5000]
"""
from __future__ import annotations

import argparse
import contextlib
import io
import os
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT))

from benchmarks._results import provenance, save_result  # noqa: E402
from clients.experiments.common import add_run_arguments  # noqa: E402

FORMATS = ("lerobot", "minari", "rosbag2")


def _cli(*argv: str) -> str:
    """``acnmp ARGV`` in this process; its stdout (AssertionError with its stderr when it fails)."""
    from clients.cli import main

    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = main(list(argv))
    if code != 0:
        raise AssertionError(f"acnmp {' '.join(argv)}: exit {code}: {err.getvalue().strip()}")
    return out.getvalue()


def library_load(fmt: str, where: str) -> int | None:
    """Episodes in the dataset at ``where`` as the format's own library loads them (every frame
    or episode read), or None when that library is not installed."""
    if fmt == "minari":
        try:
            import minari
        except ImportError:
            return None
        ds = minari.load_dataset(where)
        return sum(1 for _ in ds.iterate_episodes())
    if fmt == "rosbag2":
        try:
            from rosbags.highlevel import AnyReader
        except ImportError:
            return None
        bags = sorted(Path(where).iterdir())
        for bag in bags:
            with AnyReader([bag]) as reader:
                for conn, _, raw in reader.messages():
                    reader.deserialize(raw, conn.msgtype)
        return len(bags)
    try:
        from acnmp_core.datasets.lerobot import import_lerobot

        lerobot = import_lerobot()
    except ImportError:
        return None
    ds = lerobot.lerobot_dataset.LeRobotDataset("acnmp/round-trip", root=where)
    for i in range(len(ds)):
        ds[i]
    return ds.num_episodes


def round_trip(rrd: str | Path, fmt: str, work: Path, *, skill_steps: int = 5000, seed: int = 0,
               load=library_load) -> dict:
    """Export the roll-outs of ``rrd`` in ``fmt``, load them with ``load(fmt, where)``, import the
    successful ones back, train a skill on them and reproduce each; returns the figures."""
    import torch

    from acnmp_core.model.cnmp import CNMP, CNMPConfig
    from acnmp_core.data.demo_io import load_demos
    from acnmp_core.experiments.viapoint import make_setup
    from acnmp_core.model.training import TrainConfig, train
    from services.recording.tables import read_recording

    torch.set_num_threads(1)
    if fmt == "minari":
        os.environ["MINARI_DATASETS_PATH"] = str(work / "minari")
        where = "acnmp/e1-round-trip-v0"
    else:
        where = str(work / fmt)
    rows = read_recording(rrd).rollout_rows()
    t0 = time.perf_counter()
    _cli("replay", str(rrd), f"--export-{fmt}", where)
    written = time.perf_counter() - t0
    t0 = time.perf_counter()
    loaded = load(fmt, where)
    library = time.perf_counter() - t0
    demos_path = work / f"{fmt}.npz"
    t0 = time.perf_counter()
    # LeRobot's own clock is float32 timestamps; the export's observation.phase holds the recorded times
    if fmt == "lerobot":
        how = [where, "--trajectory", "action", "--time", "observation.phase"]
    elif fmt == "minari":
        how = [where, "--trajectory", "actions"]
    else:  # a bag per roll-out
        how = [*(str(b) for b in sorted(Path(where).iterdir())), "--trajectory", "/acnmp/trajectory"]
    _cli("demos", "import", "--format", fmt, *how, "-o", str(demos_path), "--successful")
    read = time.perf_counter() - t0
    demos = load_demos(demos_path)
    good = [r for r in rows if r["success"]]
    same = len(demos) == len(good) and all(np.array_equal(demos.demo(i)[1], r["trajectory"]) for i, r in enumerate(good))
    setup = make_setup()
    # the paper's CNMP: the skill is trained on E1's two successful roll-outs, too few for the default's
    # linear path (measured on one recording: 0.075-0.081 m RMSE with it, 0.013-0.017 without;
    # docs/ALGORITHM.md, "When not to use the linear path"); this benchmark is about the data, not the model
    model = CNMP(CNMPConfig(n_outputs=2, encoder_widths=(64, 64), decoder_widths=(64, 64), prior="none"), seed=seed)
    t0 = time.perf_counter()
    # a cosine-decayed rate ends with small steps: the roll-outs' exploration wiggles are fitted
    # (1500 constant-rate steps left 0.09 m RMSE on E1's two successful roll-outs, 5000 decayed 0.02)
    train(model, demos.to_demo_set(), TrainConfig(steps=skill_steps, lr_final=1e-5), seed=seed, progress=False)
    trained = time.perf_counter() - t0
    tg, gaps, worst = setup.target, [], []
    for r in good:  # conditioned where E1's query conditions, on the roll-out's own values there
        at = np.array([[np.interp(t, r["times"], r["trajectory"][:, d]) for d in range(2)] for t in tg.obs_times])
        again = model.predict(tg.obs_times, at, query_times=r["times"]).mean
        gaps.append(float(np.sqrt(np.mean(np.sum((again - r["trajectory"]) ** 2, axis=1)))))
        worst.append(float(np.max(np.linalg.norm(again - r["trajectory"], axis=1))))
    return {"format": fmt, "rollouts": len(rows), "successful": len(good), "library_episodes": loaded,
            "imported_bit_for_bit": bool(same), "reproduction_rmse_max": max(gaps) if gaps else None,
            "reproduction_rmse": gaps, "reproduction_max_deviation": worst, "tolerance": float(max(setup.task.tolerance)),
            "within_tolerance": bool(gaps) and bool(max(gaps) <= max(setup.task.tolerance)),
            "export_s": round(written, 3), "library_load_s": None if loaded is None else round(library, 3),
            "import_s": round(read, 3), "skill_train_s": round(trained, 2),
            "export_episodes_per_s": round(len(rows) / written, 1), "import_episodes_per_s": round(len(rows) / read, 1)}


def throughput(n: int, work: Path, steps: int = 101, dims: int = 2) -> dict:
    """Episodes per second of the project's writer and reader of each format, ``n`` roll-outs of
    ``steps`` x ``dims`` (E1's shape)."""
    from acnmp_core.datasets.episodes import RolloutEpisode
    from acnmp_core.datasets.lerobot import read_lerobot, write_lerobot
    from acnmp_core.datasets.message_paths import parse_ref
    from acnmp_core.datasets.minari import read_minari, write_minari
    from acnmp_core.datasets.rosbag2 import BagSelection, read_rosbag2, write_rosbag2

    rng = np.random.default_rng(0)
    times = np.linspace(0, 1, steps)
    rollouts = [RolloutEpisode(times, rng.normal(size=(steps, dims)), rng.normal(size=steps), bool(i % 2), 0.0,
                               rng.normal(size=2), job=f"j{i // 100}", method="acnmp", skill="e1", task="viapoint",
                               rollout_index=i) for i in range(n)]
    out = {"episodes": n, "steps": steps, "dims": dims}
    for fmt, write, read, where in (("lerobot", lambda: write_lerobot(work / "t-lerobot", rollouts),
                                     lambda: read_lerobot(work / "t-lerobot"), None),
                                    ("minari", lambda: write_minari("bench/throughput-v0", rollouts, root=work / "t-minari"),
                                     lambda: read_minari(work / "t-minari" / "bench" / "throughput-v0"), None),
                                    ("rosbag2", lambda: write_rosbag2(work / "t-bags", rollouts),
                                     lambda: read_rosbag2(sorted((work / "t-bags").iterdir()),
                                                          BagSelection((parse_ref("/acnmp/trajectory"),))), None)):
        t0 = time.perf_counter()
        write()
        w = time.perf_counter() - t0
        t0 = time.perf_counter()
        got = read()
        r = time.perf_counter() - t0
        assert len(got.episodes) == n
        out[fmt] = {"write_episodes_per_s": round(n / w, 1), "read_episodes_per_s": round(n / r, 1),
                    "write_s": round(w, 3), "read_s": round(r, 3)}
    return out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--rrd", default=None, help="a recording to use instead of recording a distributed E1")
    ap.add_argument("--keep-rrd", default=None, metavar="PATH", help="where to keep the E1 recording it makes (for --rrd)")
    ap.add_argument("--seed", type=int, default=0, help="E1's seed (default 0)")
    ap.add_argument("--budget", type=int, default=100, help="E1's roll-outs per method (full size: 100)")
    ap.add_argument("--train-steps", type=int, default=3000, help="E1's training steps (full size: 3000)")
    ap.add_argument("--skill-steps", type=int, default=5000, help="training steps of the skill on the imported roll-outs")
    ap.add_argument("--episodes", type=int, default=5000, help="synthetic episodes for the throughput part")
    add_run_arguments(ap, out=str(ROOT / "benchmarks" / "results" / "bench_datasets.json"))
    args = ap.parse_args(argv)
    result = {"provenance": provenance(), "config": vars(args)}
    start = time.perf_counter()
    with tempfile.TemporaryDirectory() as tmp:
        work = Path(tmp)
        rrd = args.rrd
        if rrd is None:
            rrd = args.keep_rrd or str(work / "e1.rrd")
            t0 = time.perf_counter()
            _cli("experiment", "viapoint", "--seeds", f"{args.seed}-{args.seed}", "--budget", str(args.budget),
                 "--train-steps", str(args.train_steps), "--distributed", "--fresh", "--workers", "2", "--record", rrd, "--quiet")
            result["e1_distributed_s"] = round(time.perf_counter() - t0, 1)
        for fmt in FORMATS:
            (work / fmt).mkdir()
            result[fmt] = round_trip(rrd, fmt, work / fmt, skill_steps=args.skill_steps, seed=args.seed)
            print(fmt, {k: v for k, v in result[fmt].items() if k != "reproduction_rmse"}, flush=True)
        result["throughput"] = throughput(args.episodes, work)
    result["wall_time_s"] = round(time.perf_counter() - start, 1)
    save_result(result, args.out, headline=(*FORMATS, "throughput"))
    return 0


if __name__ == "__main__":
    sys.exit(main())
