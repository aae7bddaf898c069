"""The docs blocks of datasets in and out: LeRobot, Minari and ROS 2 bags (bench_datasets.json)."""
from __future__ import annotations

from benchmarks.report_kit import fmt, load, renderer, source, table


@renderer("datasets-round-trip")
def datasets_round_trip() -> str:
    """E1's roll-outs through LeRobot, Minari and ROS 2 bags and back, and each format's speed
    (bench_datasets.json)."""
    r = load("bench_datasets")
    cfg, rows = r["config"], []
    for f, label in (("lerobot", "LeRobot v3"), ("minari", "Minari (HDF5)"), ("rosbag2", "ROS 2 bags (MCAP)")):
        if f not in r:
            continue
        x = r[f]
        rows.append([label, x["rollouts"], fmt(x["library_episodes"]), x["successful"],
                     "yes" if x["imported_bit_for_bit"] else "no", fmt(x["reproduction_rmse_max"]),
                     fmt(x["export_episodes_per_s"]), fmt(x["import_episodes_per_s"])])
    t = r["throughput"]
    return "\n".join([
        f"E1 at budget {cfg['budget']} and {cfg['train_steps']} training steps (seed {cfg['seed']}) across a local "
        f"deployment, recorded; its roll-outs exported, loaded by the format's own library, the successful ones "
        f"imported back and a skill trained on them ({cfg['skill_steps']} steps):",
        "",
        table(["format", "roll-outs exported", "episodes the library loaded", "successful", "values imported bit for bit",
               "reproduction RMSE (max, m)", "export (episodes/s)", "import (episodes/s)"], rows),
        "",
        f"* E1's tolerance is {fmt(r['lerobot']['tolerance'])} m. Export and import per second include reading "
        f"the recording and the command's start.",
        f"* The writers and readers alone, {t['episodes']} episodes of {t['steps']} steps x {t['dims']}: LeRobot "
        f"{fmt(t['lerobot']['write_episodes_per_s'])} episodes/s written, {fmt(t['lerobot']['read_episodes_per_s'])} "
        f"read; Minari {fmt(t['minari']['write_episodes_per_s'])} written, {fmt(t['minari']['read_episodes_per_s'])} read"
        + (f"; ROS 2 bags (one per episode) {fmt(t['rosbag2']['write_episodes_per_s'])} written, "
           f"{fmt(t['rosbag2']['read_episodes_per_s'])} read." if "rosbag2" in t else "."),
        "",
        source(r, "bench_datasets"),
    ])
