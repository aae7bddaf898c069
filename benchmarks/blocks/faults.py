"""The docs blocks of docs/FAULTS.md: the model service's memory under payloads at the predict
bound (bench_model_memory.json), the fault benchmark (bench_faults.json) and the cross-checks of
roll-out chunks (bench_cross_check.json)."""
from __future__ import annotations

from benchmarks.report_kit import block, has_result, load, renderer, source, table


@renderer("model-memory")
def model_memory() -> str:
    """RSS of the model process idle, at peak and idle again; how fast over-bound requests are refused."""
    r = load("bench_model_memory")
    t = r["targets"]
    rows = [["predicts at the bound", f"{r['predicts']} x {r['payload_bytes'] / 2**20:.0f} MiB from {r['senders']} senders "
             f"({', '.join(f'{n} {k}' for k, n in sorted(r['answers'].items()))})",
             f"idle {r['idle_mib']:.0f} MiB, peak {r['peak_mib']:.0f} MiB, idle again {r['after_mib']:.0f} MiB: "
             f"**{r['after_over_idle']:.2f}x** idle", f"<= {t['after_over_idle']}x idle",
             "yes" if r["after_over_idle"] <= t["after_over_idle"] else "**no**"]]
    names = {"over_bound_client": "one byte over the bound, through the client",
             "over_bound_raw_get": "one byte over the bound, a raw zenoh get",
             "500mb_client": "500 MB, through the client"}
    for key, label in names.items():
        x = r["refusals"][key]
        rows.append([label, f"{x['bytes'] / 2**20:.0f} MiB", f"{x['answer']} after **{x['seconds']:.3f} s**",
                     f"< {t['refusal_s']:g} s", "yes" if x["seconds"] < t["refusal_s"] else "**no**"])
    return block(r, "bench_model_memory", ["case", "sent", "measured", "target", "met"], rows,
                 "Idle again: the lowest resident set over the 10 s after the last answer (sampled every 0.1 s). "
                 "A raw get over the bound is dropped by zenoh's filter: it ends with no reply at once.")


def _kills_measured(k: dict) -> str:
    """What one kills part of bench_faults.json measured, in a few words."""
    text = (f"{k['jobs']} jobs done: {k['lost']} roll-outs lost, {k['duplicated']} duplicated of {k['reserved']} "
            f"reserved; {k['segments']} recording files")
    if "excluded_at_end" in k:
        text += f"; {k['excluded_at_end']} jobs naming an excluded worker at the end"
    return text


def _kills_met(k: dict) -> str:
    ok = k["lost"] == 0 and k["duplicated"] == 0 and k.get("excluded_at_end", 0) == 0
    return "yes" if ok else "**no**"


@renderer("faults")
def faults() -> str:
    """Kills of the learner, restarts on the same recording, a bad worker per mode (bench_faults.json)."""
    if not has_result("bench_faults"):
        return "*Not measured yet: `python benchmarks/performance/bench_faults.py`.*"
    r = load("bench_faults")
    k = r["kills"]
    rows = [["kill -9 of the learner between reserving and publishing a batch",
             f"{k['kills']} kills ({', '.join(f'{n} {w}' for w, n in sorted(k['where'].items()))}), "
             f"{k['restarts_same_record']} of them with the launcher killed too and started again on the same --record",
             _kills_measured(k), "0 lost, 0 duplicated", _kills_met(k)]]
    if "joint" in r:
        j = r["joint"]
        rows.append(["kill -9 of the learner with the recorder, or with the launcher and the recorder, at the same "
                     "moment, between writing a batch's journal and its roll-outs reaching the recorder",
                     f"{j['kills']} joint kills ({', '.join(f'{n} {w}' for w, n in sorted(j['with'].items()) if n)}; "
                     f"{', '.join(f'{n} {w}' for w, n in sorted(j['where'].items()))})",
                     _kills_measured(j), "0 lost, 0 duplicated, no worker named at the end", _kills_met(j)])
    for mode, m in r["workers"].items():
        avoided = m["jobs"] - m["named"]
        rows.append([f"a worker answering {m['what']} beside 2 healthy ones", f"{m['jobs']} jobs at once",
                     f"{m['done']}/{m['jobs']} done in {m['seconds']:.1f} s; named by {m['named']}"
                     + (f" (the other {avoided} avoided it)" if avoided else "")
                     + f"; {m['rollouts_by_bad']} of its roll-outs used",
                     "every job done, the worker named, none of its roll-outs used",
                     "yes" if m["done"] == m["jobs"] and m["named"] >= 1 and m["rollouts_by_bad"] == 0 else "**no**"])
    return block(r, "bench_faults", ["fault", "runs", "measured", "target", "met"], rows, r.get("note", ""))


@renderer("cross-check")
def cross_check() -> str:
    """What cross-checks of roll-out chunks cost on E1 jobs and how soon they find a liar (bench_cross_check.json)."""
    if not has_result("bench_cross_check"):
        return "*Not measured yet: `python benchmarks/performance/bench_cross_check.py`.*"
    r = load("bench_cross_check")
    skills = {"default": "E1, the default skill", "paper": "E1, the paper's CNMP"}
    rows = []
    for skill, settings in r["overhead"].items():
        for key, o in settings.items():
            if o["cross_check"] == 0:
                continue
            rows.append([skills.get(skill, skill), f"{o['cross_check']:g} and every success",
                         f"{o['rollouts']} in {r['config']['jobs']} jobs", f"{o['check_rollouts']:g} "
                         f"(**{o['check_rollouts_ratio']:.1%}**); {o['chunks_checked']:.1%} of the chunks",
                         f"**{o['wall_ratio']:.2f}x** (rounds: {', '.join(f'{x:.2f}' for x in o['wall_ratios'])})",
                         "yes" if o["same_rollouts_as_baseline"] and o["disagreements"] == 0 else "**no**"])
    over = table(["jobs", "cross-check", "roll-outs the jobs used", "roll-outs checked on top", "wall time against none",
                  "results unchanged"], rows)
    rows = []
    for skill, d in r["detection"].items():
        u = d["unchecked"]
        rows.append([skills.get(skill, skill), f"{d['cross_check']:g}", f"{d['found']} of {d['of']}",
                     "-" if d["liar_chunks_median"] is None else
                     f"median **{d['liar_chunks_median']:g}**, at most {d['liar_chunks_max']}",
                     f"median {d['jobs_median']:g}",
                     f"{u['successes']} of {u['jobs']} jobs succeed; the liar never named ({u['liar_chunks']} of its chunks used)"
                     if not u["excluded"] else f"{u['successes']} of {u['jobs']} jobs succeed"])
    detect = table(["jobs", "cross-check", "liar found", "its chunks answered until then", "jobs until then",
                    "without cross-checks"], rows)
    return "\n\n".join([over, detect, r.get("note", ""), source(r, "bench_cross_check")])
