"""The docs blocks of jobs side by side in one learner and of sizing a deployment (bench_jobs*.json)."""
from __future__ import annotations

import numpy as np

from benchmarks.report_kit import block, load, pct, renderer, table


def _median(spread: dict) -> str:
    return f"{spread['median']:.2f} ({spread['min']:.2f}-{spread['max']:.2f})"


@renderer("jobs-runner")
def jobs_runner() -> str:
    """Threads against job processes for the training part (bench_jobs_runner.json)."""
    r = load("bench_jobs_runner")
    rows = []
    for k, s in r["summary"].items():
        rows.append([k, f"{s['sequential_wall_s']['median']:.1f}", _median(s["threads"]["wall_ratio"]),
                     _median(s["processes"]["wall_ratio"]), _median(s["ceiling_wall_ratio"]),
                     _median(s["threads"]["cpu_ratio"]), _median(s["processes"]["cpu_ratio"]),
                     "yes" if s["threads"]["bit_equal"] and s["processes"]["bit_equal"] else "NO"])
    return block(r, "bench_jobs_runner",
                 ["K jobs", "one after another (s, median)", "K threads / one after another",
                  "K processes / one after another", "K spinning processes / one after another (the machine's ceiling)",
                  "CPU, threads / one after another", "CPU, processes / one after another", "results bit-equal"],
                 rows,
                 f"Median (min-max) of {r['config']['reps']} repetitions; E1 jobs of {r['config']['budget']} roll-outs on the "
                 "in-process task (no workers: the adaptation's arithmetic only).")


def _deploy_table(r: dict, kinds) -> tuple[list[str], list[list]]:
    """The header and rows of K jobs at once on one learner, each learner setting of
    ``r["config"]["configs"]`` against the first, for each (key, label) of ``kinds``."""
    confs = r["config"]["configs"]
    header = ["jobs", "K at once"]
    for conf in confs:
        jobs, runner = conf.split(":")
        header += [f"--jobs {jobs} {runner}: all done (s)", "/ K x one alone"]
        if conf != confs[0]:
            header += [f"/ --jobs {confs[0].split(':')[0]}"]
    header += ["learner CPU s (" + ", ".join(confs) + ")", "workers' CPU s (" + ", ".join(confs) + ")",
               "results bit-equal"]
    rows = []
    for kind, label in kinds:
        by = r[kind]["by_config"]
        for k in by[confs[0]]["k"]:
            row = [label, k]
            for conf in confs:
                x = by[conf]["k"][k]
                row += [f"{x['wall_s']:.1f}", f"{x['ratio_to_k_alone']:.2f}"]
                if conf != confs[0]:
                    row += [f"**{x['ratio_to_baseline']:.2f}**"]
            row += [", ".join(f"{by[conf]['k'][k][cpu]:.1f}" for conf in confs) for cpu in ("learner_cpu_s", "worker_cpu_s")]
            row += ["yes" if all(by[conf]["k"][k]["bit_equal_to_baseline"] for conf in confs[1:]) else "NO"]
            rows.append(row)
    return header, rows


def _runs(config: dict, paired: bool = False) -> str:
    """How many times each K was measured (older results: once); ``paired``: the ratios are
    medians of rounds that ran every setting in turn (older results: settings one after another)."""
    reps = config.get("reps", 1)
    if reps == 1:
        return "One run."
    if not paired:
        return f"Each figure the run of median wall time of {reps}."
    return (f"Each figure the run of median wall time of {reps}; each ratio to --jobs 1 the median of {reps} "
            "rounds' ratios, a round running every setting in turn.")


def _paired(by_config: dict) -> bool:
    """Whether a result's ratios to the baseline are medians of paired rounds."""
    return any("ratio_to_baseline_runs" in x for row in by_config.values() for x in row["k"].values())


@renderer("jobs-deploy")
def jobs_deploy() -> str:
    """K jobs at once on one learner of a deployment, each learner setting against the baseline
    (the first, --jobs 1) (bench_jobs.json)."""
    r = load("bench_jobs")
    c = r["config"]
    return block(r, "bench_jobs", *_deploy_table(r, (("e1", "E1"), ("rollout_heavy", "roll-out-heavy"))),
                 f"{c['workers']} workers; E1 jobs of {c['budget']} roll-outs ({c['train_steps']}-step 32x32 skill); "
                 f"roll-out-heavy: the same jobs with {c['rollout_delay_s']} s of worker time per roll-out. {_runs(c, _paired(r['e1']['by_config']))}")


@renderer("jobs-ur10")
def jobs_ur10() -> str:
    """K UR10 pick-and-place jobs at once on one learner, --jobs 1 against the default
    (bench_jobs_ur10.json)."""
    r = load("bench_jobs_ur10")
    c = r["config"]
    by = r["ur10"]["by_config"]
    k = str(max(c["ks"]))
    default = by[c["configs"][-1]]["k"][k]
    cpu = default["learner_cpu_s"] + default["worker_cpu_s"]
    cores = r["provenance"]["machine"]["cpu_count"]
    return block(r, "bench_jobs_ur10", *_deploy_table(r, (("ur10", "UR10 pick and place"),)),
                 f"{c['workers']} UR10 workers (PyBullet); jobs of {c['budget']} roll-outs adapting a "
                 f"{c['train_steps']}-step 32x32 skill of E5's 8 demonstrations to its (8, 10) cm case. {_runs(c, _paired(by))} "
                 f"What the machine allows: {k} jobs at once took {cpu:.1f} CPU s with `--jobs "
                 f"{c['configs'][-1].split(':')[0]}` (learner {default['learner_cpu_s']:.1f}, workers "
                 f"{default['worker_cpu_s']:.1f}), so on its {cores} cores no setting could finish them in under "
                 f"{cpu / cores:.1f} s; they took {default['wall_s']:.1f} s ({default['wall_s'] / (cpu / cores):.2f}x that floor).")


@renderer("jobs-kill")
def jobs_kill() -> str:
    """A learner killed with SIGKILL during 4 concurrent jobs (bench_jobs_kill.json)."""
    r = load("bench_jobs_kill")
    rows = [[j["job"], j["state"], j["attempt"], "yes" if j["result_equal_to_undisturbed"] else "NO",
             j["rollouts_executed"], j["recorded_rollouts"], len(j["recorded_duplicates"] or [])] for j in r["jobs"]]
    return block(r, "bench_jobs_kill",
                 ["job", "state", "attempt", "result = undisturbed", "roll-outs executed", "recorded", "recorded twice"],
                 rows,
                 f"The learner was back {r['learner_back_s']:.1f} s after the kill (exit code {r['restart_exit_code']}).")


@renderer("jobs-hosts")
def jobs_hosts() -> str:
    """Two learners on two hosts (network namespaces) against one, K jobs at once, with the
    projection to learners on cores of their own (bench_jobs_hosts.json)."""
    r = load("bench_jobs_hosts")
    c, s = r["config"], r["summary"]
    rows = []
    for rep in s["by_rep"]:
        one, two = (next(x for x in r["rounds"] if x["rep"] == rep["rep"] and x["learners"] == n) for n in (1, 2))
        rows.append([rep["rep"] + 1, f"{one['wall_s']:.1f}", f"{two['wall_s']:.1f}", f"**{rep['wall_ratio']:.2f}**",
                     f"{one['learner_cpu_s']['learner']:.1f}",
                     " / ".join(f"{two['learner_cpu_s'][n]:.1f}" for n in sorted(two["learner_cpu_s"])),
                     f"{sum(one['worker_cpu_s'].values()):.1f} / {sum(two['worker_cpu_s'].values()):.1f}",
                     f"{rep['bound_s']['2']:.1f}", f"**{rep['projected_ratio']:.2f}**",
                     f"{rep['projected_bound_ratio']:.2f}",
                     "yes" if all(two["bit_equal_to_one_learner"]) else "NO"])
    share = s["learner_cpu_share"]
    return block(r, "bench_jobs_hosts",
                 ["rep", "1 learner: all done (s)", "2 learners: all done (s)", "2 / 1",
                  "learner CPU s (1 learner)", "learner / learner-2 CPU s (2 learners)", "workers' CPU s (1 / 2)",
                  "2 learners on their own cores: bound (s)", "bound / 1 learner's time", "bound / 1 learner's bound",
                  "results bit-equal"],
                 rows,
                 f"{r['config']['ks'][0]} E1 jobs of {c['budget']} roll-outs submitted at once from the client host, "
                 f"dealt over skills {', '.join(r['skills'])} (one owned by each learner of the pair); {c['workers']} "
                 f"workers, each learner `--jobs {c['jobs_per_learner']}`. 2 / 1: median "
                 f"{_median(s['wall_ratio'])} over {c['reps']} repetitions. The two learners' CPU split "
                 f"{pct(share['learner']['median'])} / {pct(share['learner-2']['median'])}. Bound: the wall time the "
                 f"2-learner run could not beat with {c['cores_per_learner']:g} cores per learner and "
                 f"{c['worker_cores']:g} for the workers (the busiest learner's CPU / its cores, or the workers' CPU / "
                 f"theirs); over the 1-learner run measured here: median {_median(s['projected_ratio'])}; over the "
                 f"same bound for 1 learner: {_median(s['projected_bound_ratio'])}.")


#: The deployment docs/SCALING.md sizes, and how its users behave in a busy hour (assumptions,
#: not measurements): every user adapts once an hour (an E1 job of 150 roll-outs, batches of 5)
#: and predicts once every 10 s.
SIZING = {"users": 1000, "workers": 100, "learners": 10, "cores_per_learner": 2, "jobs_per_user_hour": 1.0,
          "rollouts_per_job": 150, "batch": 5, "predicts_per_user_s": 0.1}


def sizing_figures() -> dict:
    """The sizing of docs/SCALING.md from the measured per-message costs (see the page)."""
    s = SIZING
    jobs = load("bench_jobs")
    par = jobs["e1"]["by_config"][jobs["config"]["configs"][-1]]["k"]
    budget = jobs["config"]["budget"]
    cpu_per_rollout = float(np.median([v["learner_cpu_s"] / (int(k) * budget) for k, v in par.items()]))
    rec = next(x for x in load("bench_recorder")["results"] if x["kind"] == "point2d")
    export = load("bench_recordings")["export"]
    rrd_bytes_per_rollout = export["rrd_mb"] * 1e6 / export["rollouts"]
    secure = load("bench_secure")["empty_query"]
    ur10_s = load("bench_ur10_rollout")["noisy_rollout"]["median_ms"] / 1000
    hosts = load("bench_hosts")["loopback"]["runs"]
    predict_capacity = float(np.median([max(t["predicts_per_s"] for t in run["throughput"]) for run in hosts]))

    jobs_s = s["users"] * s["jobs_per_user_hour"] / 3600
    rollouts_s = jobs_s * s["rollouts_per_job"]
    batches_s = rollouts_s / s["batch"]
    chunks_s = batches_s * min(s["batch"], s["workers"])
    liveliness_s = batches_s * 2 * s["workers"]  # per batch: a liveliness query and a subscriber's history
    events = {"rollout": rollouts_s, "job_progress": batches_s, "metrics": batches_s}
    events_s = sum(events.values())
    predicts_s = s["users"] * s["predicts_per_user_s"]
    cpu_per_job = cpu_per_rollout * s["rollouts_per_job"]
    learner_cores = s["learners"] * s["cores_per_learner"]
    events_per_job = s["rollouts_per_job"] * (1 + 2 / s["batch"])
    capacity_jobs_s = {
        "learners (training)": learner_cores / cpu_per_job,
        "recorder (one)": rec["events_per_s"] / events_per_job,
        "workers, UR10 roll-outs": s["workers"] / (s["rollouts_per_job"] * ur10_s),
    }
    return {
        "jobs_s": jobs_s, "rollouts_s": rollouts_s, "batches_s": batches_s, "chunks_s": chunks_s,
        "liveliness_s": liveliness_s, "events": events, "events_s": events_s, "predicts_s": predicts_s,
        "cpu_per_rollout": cpu_per_rollout, "cpu_per_job": cpu_per_job, "learner_cores": learner_cores,
        "learner_use": jobs_s * cpu_per_job / learner_cores,
        "recorder_capacity": rec["events_per_s"], "recorder_use": events_s / rec["events_per_s"],
        "event_bytes": rec["bytes_per_event"], "wire_mb_h": events_s * rec["bytes_per_event"] * 3600 / 1e6,
        "rrd_bytes_per_rollout": rrd_bytes_per_rollout,
        "rrd_gb_h": rollouts_s * rrd_bytes_per_rollout * 3600 / 1e9,
        "router_hop_ms": secure["router+auth+acl"]["p50_ms"] - secure["peer"]["p50_ms"],
        "predict_capacity": predict_capacity, "model_processes": predicts_s / predict_capacity,
        "ur10_s": ur10_s, "worker_use_ur10": rollouts_s * ur10_s / s["workers"],
        "capacity_jobs_s": capacity_jobs_s,
        "router_msgs_s": 2 * chunks_s + liveliness_s + events_s + 2 * predicts_s,
    }


@renderer("scaling-sizing")
def scaling_sizing() -> str:
    """docs/SCALING.md's table: messages per second per key family, router load, recording volume
    and each part's load for :data:`SIZING`, from the measured costs."""
    s, f = SIZING, sizing_figures()
    rows = [
        ["`skill/*/adapt` (submit), `job/*/status`", f"{f['jobs_s']:.2f} + polling", "-", "learner queryables"],
        ["`worker/<robot>/<id>/rollout` (chunk queries)", f"{f['chunks_s']:.0f} queries + as many replies",
         f"{f['rollouts_s']:.0f} roll-outs/s", "workers: E1 roll-outs cost microseconds; UR10 "
         f"{f['ur10_s'] * 1000:.0f} ms each: {pct(f['worker_use_ur10'])} of {s['workers']} workers"],
        ["liveliness `worker/<robot>/*` (query + subscriber history per batch)", f"{f['liveliness_s']:.0f}",
         f"{s['workers']} tokens x 2 per batch", "the router: the largest family by count"],
        ["`event/rollout/**`", f"{f['events']['rollout']:.0f}", f"{f['event_bytes']} B each",
         f"recorder: {pct(f['recorder_use'])} of the {f['recorder_capacity']:.0f} events/s it recorded here"],
        ["`event/job_progress/**`, `event/metrics/**`", f"{f['events']['job_progress'] + f['events']['metrics']:.0f}",
         "", ""],
        ["`skill/*/predict`", f"{f['predicts_s']:.0f} queries + replies", "",
         f"model service: {f['model_processes']:.2f} of one process ({f['predict_capacity']:.0f} predicts/s measured)"],
    ]
    cap = f["capacity_jobs_s"]
    first = min(cap, key=cap.get)
    lines = [
        table(["key family", "messages/s", "size", "who carries it"], rows),
        "",
        f"* Router: about {f['router_msgs_s']:.0f} messages/s in all (queries and replies counted apart); "
        f"a hop through the router added {f['router_hop_ms']:.2f} ms to a query here (p50, with authentication "
        "and ACL, against peer to peer).",
        f"* Learners: {f['jobs_s']:.2f} jobs/s x {f['cpu_per_job']:.1f} CPU s per 150-roll-out job "
        f"({f['cpu_per_rollout'] * 1000:.0f} ms per roll-out measured) = {f['jobs_s'] * f['cpu_per_job']:.1f} cores of "
        f"the {f['learner_cores']} ({pct(f['learner_use'])}).",
        f"* Recording: {f['events_s']:.0f} events/s, {f['wire_mb_h']:.0f} MB/h on the wire, "
        f"{f['rrd_gb_h']:.2f} GB/h of .rrd ({f['rrd_bytes_per_rollout'] / 1000:.1f} kB per E1 roll-out on disk).",
        "* Jobs per second each part can carry at most: "
        + "; ".join(f"{name} {v:.2f}" for name, v in cap.items())
        + f". The first to saturate: **{first}**, at {cap[first] / f['jobs_s']:.1f}x this hour's load.",
    ]
    return "\n".join(lines)


@renderer("spawner")
def spawner() -> str:
    """A deployment's start with and without the spawner (bench_spawner.json)."""
    r = load("bench_spawner")
    rows = [[label, _median(r["summary"][key]["ready_s"]), _median(r["summary"][key]["cpu_s"])]
            for key, label in (("spawner", "forked by the spawner (the default)"),
                               ("fresh", "each a fresh interpreter (`fork_server=False`)"))]
    ratio = r["ratio_spawner_to_fresh"]
    rows.append(["spawner / fresh interpreters, paired by round", _median(ratio["ready_s"]), _median(ratio["cpu_s"])])
    return block(r, "bench_spawner", ["learner, model, workers", "up after (s)", "CPU of all its processes by then (s)"],
                 rows, f"Median (min-max) of {r['config']['reps']} starts each, alternately; a deployment of "
                       f"{', '.join(r['config']['processes'])}; the spawner's own CPU counted.")
