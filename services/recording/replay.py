"""Read a recording back and summarise it: roll-outs and rewards per job, model versions, latents.

Uses Rerun 0.41's chunk reader (``rerun.chunk.RrdReader``), which streams the file chunk by chunk
and also works on a file without footer (a recorder killed with -9). The entity layout read here
is the one services/recording/rrd_writer.py writes.
"""
from __future__ import annotations

import math
import os
import time
import warnings
from collections import Counter, defaultdict
from pathlib import Path

import rerun as rr

from .segments import recording_segments


def _column(batch, name: str) -> list:
    """Values of a component column, one per row (AnyValues stores 1-element lists)."""
    if name not in batch.schema.names:
        return [None] * batch.num_rows
    out = []
    for cell in batch.column(name).to_pylist():
        out.append(cell[0] if isinstance(cell, list) and cell else (None if isinstance(cell, list) else cell))
    return out


def has_footer(path: str | Path) -> bool | None:
    """True/False whether the .rrd ends with a footer; None if this Rerun cannot tell."""
    try:
        from rerun_bindings import check_for_rrd_footer

        return bool(check_for_rrd_footer(str(path)))
    except Exception:
        return None


#: Seconds: a recording without footer modified more recently than this, with no writer in
#: sight, is said to be perhaps still being written (by a process this user cannot inspect).
RECENT_WRITE_S = 5.0


def open_writers(path: str | Path) -> list[int] | None:
    """Pids of the processes holding ``path`` open for writing, read from ``/proc/<pid>/fd`` (where
    each descriptor points) and ``/proc/<pid>/fdinfo`` (its access mode); processes of other users
    are not visible. None where there is no /proc (not Linux): cannot tell."""
    if not os.path.isdir("/proc/self/fd"):
        return None
    target = os.path.realpath(path)
    pids = []
    for entry in os.scandir("/proc"):
        if not entry.name.isdigit():
            continue
        fd_dir = f"/proc/{entry.name}/fd"
        try:
            fds = os.listdir(fd_dir)
        except OSError:  # exited meanwhile, or another user's
            continue
        for fd in fds:
            try:
                if os.readlink(f"{fd_dir}/{fd}") != target:
                    continue
                with open(f"/proc/{entry.name}/fdinfo/{fd}") as info:
                    flags = next(int(line.split()[1], 8) for line in info if line.startswith("flags:"))
            except (OSError, StopIteration, ValueError, IndexError):
                continue
            if flags & os.O_ACCMODE in (os.O_WRONLY, os.O_RDWR):
                pids.append(int(entry.name))
                break
    return sorted(pids)


def writer_state(path: str | Path, footer: bool | None) -> dict:
    """Whether the recording at ``path`` (whose footer check gave ``footer``) is still being
    written: ``{"state", "pids", "modified_s_ago"}``, state one of ``complete`` (it has its
    footer), ``writing`` (open for writing by ``pids``), ``perhaps_writing`` (no footer, no writer
    visible, but modified less than :data:`RECENT_WRITE_S` s ago), ``unknown`` (no footer, and no
    /proc to look for a writer), ``stopped`` (no footer, no writer: it did not shut down cleanly);
    None when this Rerun cannot check footers (``footer`` None)."""
    if footer is None:
        return {"state": None, "pids": [], "modified_s_ago": None}
    age = max(0.0, time.time() - os.stat(path).st_mtime)
    if footer:
        return {"state": "complete", "pids": [], "modified_s_ago": age}
    pids = open_writers(path)
    if pids:
        state = "writing"
    elif age < RECENT_WRITE_S:
        state = "perhaps_writing"
    else:
        state = "unknown" if pids is None else "stopped"
    return {"state": state, "pids": pids or [], "modified_s_ago": age}


def _open(path: Path):
    """(reader, recordings) of an .rrd, with or without footer; ValueError if it is not readable."""
    try:
        with warnings.catch_warnings():
            # a file without footer makes Rerun warn; the callers report it themselves
            warnings.simplefilter("ignore")
            reader = rr.chunk.RrdReader(path)
        return reader, reader.recordings()
    except Exception as exc:
        raise ValueError(f"{path}: not a readable .rrd ({exc})") from None


def recorded_event_ids(path: str | Path) -> set[str]:
    """The event ids (``/event_ids/<kind>`` rows, the ``event_id`` and ``rollout_key`` of
    ``/rollouts/<job>`` rows, see rrd_writer) a recording holds; the file may
    lack its footer (a recorder killed with -9: what reached the file is read). Raises ValueError
    if it is not a readable recording."""
    reader, stores = _open(Path(path))
    ids: set[str] = set()
    for store in stores:
        for chunk in reader.stream(store=store):
            if chunk.is_static or chunk.is_empty or not chunk.entity_path.strip("/").startswith(("event_ids/", "rollouts/")):
                continue
            batch = chunk.to_record_batch()
            for name in ("event_id", "rollout_key"):
                ids.update(i for i in _column(batch, name) if i is not None)
    return ids


def summarize(path: str | Path) -> dict:
    """Summarise a recording written by the recorder: the file ``path`` and its segments
    (``<stem>.<n><suffix>``, services/recording/segments.py), read together.

    Returns ``{"path", "segments" ([{"path", "footer"}], first first), "application_id",
    "recording_id", "footer" and "writer" (:func:`writer_state`) of the newest segment,
    "jobs": {job: {...}},
    "skills": {skill: {"versions": [...], "latents": n}}, "processes": [...], "metrics": {...},
    "events": {kind: n}}``;
    ``processes`` lists the launcher's restarts (``process`` events: process, action, pid,
    exit_code, restarts); ``metrics`` the learner's curves, ``{source: {"<phase>/<name>":
    {"points", "first_step", "last_step", "first", "last", "min", "max"}}}``; per job:
    ``rollouts`` (rows logged), ``unique_rollouts`` (distinct indices), ``duplicates`` (indices
    logged more than once), ``mean_return``, ``best_return``, ``rollouts_succeeded`` and
    ``rollout_success_share`` (how many of its roll-outs, and which share, met the task: not
    whether the job reached its target, which the job's result says), ``method``,
    ``skill``, ``robot``, ``task``, ``seed`` (from its ``job`` event; None for a recording without
    one), ``workers`` ({worker: roll-outs}), ``hosts`` ({the workers' host: roll-outs}, where the
    events name it) and ``last_progress`` (the latest job_progress values).
    Raises FileNotFoundError, IsADirectoryError or ValueError (not a readable recording).
    """
    path = Path(path)
    if path.is_dir():
        raise IsADirectoryError(f"{path}: is a directory, not a recording (give the .rrd file in it)")
    if not path.exists():
        raise FileNotFoundError(f"{path}: no such file")
    if not path.is_file():  # /dev/null, a fifo: rerun would wait on it or call it empty
        raise ValueError(f"{path}: not a regular file, not a recording")
    files = recording_segments(path) or [path]
    footers = [has_footer(f) for f in files]  # before reading: a writer may add the footer meanwhile
    footer = footers[-1]
    writer = writer_state(files[-1], footer)
    opened = []
    for f in files:
        reader, stores = _open(f)
        if not stores:
            raise ValueError(f"{f}: contains no recording")
        opened.append((reader, stores[0]))
    store = opened[0][1]

    rollouts: dict[str, list[dict]] = defaultdict(list)
    progress: dict[str, list[dict]] = defaultdict(list)
    versions: dict[str, set] = defaultdict(set)
    latents: Counter = Counter()
    processes: list[dict] = []
    metrics: dict[str, dict[str, list]] = defaultdict(lambda: defaultdict(list))
    about: dict[str, dict] = {}  # job -> its job event's method, robot, task, skill, seed
    for chunk in (c for reader, segment in opened for c in reader.stream(store=segment)):
        if chunk.is_static or chunk.is_empty:
            continue
        parts = chunk.entity_path.strip("/").split("/")
        head = parts[0]
        if head == "metrics" and len(parts) == 4:
            batch = chunk.to_record_batch()
            series = metrics[parts[1]][f"{parts[2]}/{parts[3]}"]
            series.extend(zip(_column(batch, "metric_step"), _column(batch, "Scalars:scalars")))
            continue
        if head not in ("rollouts", "progress", "models", "latent", "processes", "jobs") or len(parts) < 2:
            continue
        batch = chunk.to_record_batch()
        if head == "jobs":
            cols = {c: _column(batch, c) for c in ("method", "robot", "task", "skill", "seed")}
            for i in range(batch.num_rows):
                about[parts[1]] = {c: cols[c][i] for c in cols}
            continue
        if head == "rollouts":
            cols = {c: _column(batch, c) for c in ("rollout_index", "ret", "success", "worker", "host")}
            for i in range(batch.num_rows):
                rollouts[parts[1]].append({c: cols[c][i] for c in cols})
        elif head == "progress":
            cols = {c: _column(batch, c) for c in ("iteration", "rollouts", "best_return", "state", "excluded_workers")}
            for i in range(batch.num_rows):
                progress[parts[1]].append({c: cols[c][i] for c in cols})
        elif head == "models":
            for v in _column(batch, "version"):
                if v is not None:
                    versions[parts[1]].add(int(v))
        elif head == "latent":
            latents[parts[1]] += batch.num_rows
        elif head == "processes":
            cols = {c: _column(batch, c) for c in ("action", "pid", "exit_code", "restarts")}
            for i in range(batch.num_rows):
                processes.append({"process": parts[1], **{c: cols[c][i] for c in cols}})

    jobs = {}
    for job in sorted(set(rollouts) | set(progress)):
        rows = rollouts.get(job, [])
        idx = Counter(r["rollout_index"] for r in rows)
        returns = [r["ret"] for r in rows if r["ret"] is not None]
        last = None
        if progress.get(job):
            # Ties (the final "done" event repeats the last "running" counts) go to the finished
            # state, then to the later row.
            last = max(enumerate(progress[job]), key=lambda ip: (
                ip[1]["rollouts"] or 0, ip[1]["iteration"] or 0, ip[1].get("state") in ("done", "failed"), ip[0]))[1]
        described = about.get(job, {})
        jobs[job] = {
            "method": described.get("method"), "skill": described.get("skill"), "robot": described.get("robot"),
            "task": described.get("task"), "seed": None if described.get("seed") in (None, -1) else described["seed"],
            "rollouts": len(rows),
            "unique_rollouts": len(idx),
            "duplicates": sorted(i for i, n in idx.items() if n > 1),
            "mean_return": (sum(returns) / len(returns)) if returns else None,
            "best_return": max(returns) if returns else None,
            # the roll-outs that met the task (exploring ones included), not whether the job reached its target
            "rollouts_succeeded": sum(bool(r["success"]) for r in rows),
            "rollout_success_share": (sum(bool(r["success"]) for r in rows) / len(rows)) if rows else None,
            "workers": dict(Counter(r["worker"] or "?" for r in rows)),
            "hosts": dict(Counter(r["host"] for r in rows if r["host"])),
            "last_progress": last,
        }
    skills = {s: {"versions": sorted(versions.get(s, ())), "latents": latents.get(s, 0)}
              for s in sorted(set(versions) | set(latents))}
    return {
        "path": str(path),
        "segments": [{"path": str(f), "footer": ft} for f, ft in zip(files, footers)],
        "application_id": store.application_id,
        "recording_id": store.recording_id,
        "footer": footer,
        "writer": writer,
        "jobs": jobs,
        "skills": skills,
        "processes": processes,
        "metrics": {source: {name: _series(points) for name, points in sorted(by_name.items())}
                    for source, by_name in sorted(metrics.items())},
        "events": {"process": len(processes), "metrics": _metric_events(metrics),"rollout": sum(len(r) for r in rollouts.values()),
                   "job_progress": sum(len(p) for p in progress.values()),
                   "model_version": sum(len(v) for v in versions.values()),
                   "latent": sum(latents.values())},
    }


def _series(points: list) -> dict:
    """``{"points", "first_step", "last_step", "first", "last", "min", "max"}`` of one metric's
    (step, value) points, in step order."""
    points = sorted((int(step), float(value)) for step, value in points if step is not None and value is not None)
    values = [v for _, v in points]
    return {"points": len(points), "first_step": points[0][0] if points else None,
            "last_step": points[-1][0] if points else None, "first": values[0] if values else None,
            "last": values[-1] if values else None, "min": min(values, default=None),
            "max": max(values, default=None)}


def _metric_events(metrics: dict[str, dict[str, list]]) -> int:
    """How many metrics events the series came from: one per (source, phase, step)."""
    return len({(source, name.split("/")[0], step) for source, by_name in metrics.items()
                for name, points in by_name.items() for step, _ in points})


def format_summary(summary: dict) -> str:
    """Human-readable text of :func:`summarize`'s result, ending with how to open the recording in
    Rerun's viewer, native or in a browser."""
    def num(x):
        return "-" if x is None or (isinstance(x, float) and math.isnan(x)) else f"{x:.4g}"

    lines = [f"recording {summary['path']}  (app {summary['application_id']}, id {summary['recording_id']})"]
    segments = summary.get("segments") or []
    if len(segments) > 1:
        lines.append(f"  {len(segments)} files read together: " + ", ".join(Path(s['path']).name for s in segments)
                     + " (a recorder restarted, or the deployment started again on this recording)")
    writer = summary.get("writer") or {}
    state = writer.get("state")
    if state == "writing":
        lines.append(f"  still being written (open for writing by pid {', '.join(map(str, writer['pids']))}): "
                     "what reached the file so far is shown; run it again for more")
    elif state == "perhaps_writing":
        lines.append(f"  no footer yet: perhaps still being written (modified {writer['modified_s_ago']:.1f} s ago, "
                     "no writer visible to this user); what reached the file so far is shown")
    elif state == "unknown":
        lines.append("  no footer: cannot tell whether it is still being written (no /proc here to look for a "
                     "writer); if its writer has stopped, it did not shut down cleanly; data read by streaming")
    elif summary.get("footer") is False:
        lines.append("  warning: no footer (the writer did not shut down cleanly); data read by streaming")
    if not summary["jobs"]:
        lines.append("  no adaptation jobs recorded")
    def group(item):
        j = item[1]
        return (j.get("method") or "~", j.get("skill") or "", item[0])

    shown = None
    for job, j in sorted(summary["jobs"].items(), key=group):
        heading = (j.get("method"), j.get("skill"))
        if heading != shown and j.get("method"):
            shown = heading
            lines.append(f"  method {j['method']}" + (f", skill {j['skill']}" if j.get("skill") else "")
                         + f" ({j['robot']}/{j['task']}):")
        seed = "" if j.get("seed") is None else f", seed {j['seed']}"
        lines.append(f"  job {job}: {j['rollouts']} roll-outs ({j['unique_rollouts']} distinct), "
                     f"mean return {num(j['mean_return'])}, best {num(j['best_return'])}, "
                     f"{j['rollouts_succeeded']} of them succeeded (share of roll-outs that succeeded "
                     f"{num(j['rollout_success_share'])}){seed}")
        if j["duplicates"]:
            lines.append(f"    duplicated roll-out indices: {j['duplicates'][:20]}")
        if j["workers"]:
            lines.append("    workers: " + ", ".join(f"{w}={n}" for w, n in sorted(j["workers"].items())))
        if j.get("hosts"):
            lines.append("    hosts: " + ", ".join(f"{h}={n}" for h, n in sorted(j["hosts"].items())))
        if j["last_progress"]:
            p = j["last_progress"]
            lines.append(f"    last progress: iteration {p['iteration']}, {p['rollouts']} roll-outs, "
                         f"best {num(p['best_return'])}, {p['state']}")
            if p.get("excluded_workers"):
                lines.append(f"    excluded workers: {p['excluded_workers']}")
    if summary["jobs"]:
        lines.append("  (a roll-out succeeded when it met the task, exploring roll-outs included; whether a job "
                     "succeeded, the `success` of an experiment's JSON, is its result: `acnmp query jobs`)")
    for skill, s in summary["skills"].items():
        lines.append(f"  skill {skill}: model versions {s['versions'] or '-'}, {s['latents']} latent vector(s)")
    for p in summary.get("processes", []):
        lines.append(f"  process {p['process']} {p['action']} (exit code {p['exit_code']}, pid {p['pid']})")
    for source, by_name in summary.get("metrics", {}).items():
        cells = [f"{name} {num(m['first'])} -> {num(m['last'])}" for name, m in by_name.items()]
        steps = max(m["last_step"] or 0 for m in by_name.values())
        lines.append(f"  learner metrics of {source} (to step {steps}): " + ", ".join(cells))
    every = " ".join(s["path"] for s in segments) or summary["path"]  # one recording in the viewer too
    lines.append(f"open it in the viewer:  rerun {every}   "
                 f"(or: python -m rerun {every})")
    lines.append(f"or in a browser:        rerun --serve-web --bind 127.0.0.1 {every}   "
                 "(then open the address it prints, http://127.0.0.1:9090 by default)")
    return "\n".join(lines)
