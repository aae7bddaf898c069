"""The docs block of the learner's mutation check (mutation.json, benchmarks/mutation/run.py)."""
from __future__ import annotations

from benchmarks.report_kit import block, load, pct, renderer


@renderer("mutation")
def mutation() -> str:
    """Killed / total per file of the scope (and the service's owner checks beside it), then every
    survivor with why it is equivalent, then issue 67's breaks and the test that kills each."""
    r = load("mutation")
    rows = []
    for file in [*r["scope"], *sorted({m["file"] for m in r["mutants"]} - set(r["scope"]))]:
        mine = [m for m in r["mutants"] if m["file"] == file]
        killed = sum(m["killed"] for m in mine)
        rows.append([f"`{file}`" + ("" if file in r["scope"] else " (beside the scope)"), len(mine), killed,
                     len(mine) - killed, ", ".join(m["id"] for m in mine if not m["killed"]) or "-"])
    s = r["score"]
    rows.append(["**scope**", s["total"], s["killed"], s["total"] - s["killed"], f"**{pct(s['fraction'])} killed**"])
    survivors = [f"- `{m['id']}` ({m['breaks']}): " + (f"equivalent: {m['equivalent']}." if m["equivalent"]
                                                       else "**not explained: a gap in the tests.**")
                 for m in r["mutants"] if not m["killed"]]
    breaks = [f"{m['issue_67_break']}: `{m['id']}` killed by `{m['killed_by']}`" if m["killed"]
              else f"{m['issue_67_break']}: `{m['id']}` **survives**"
              for m in sorted((m for m in r["mutants"] if m["issue_67_break"]), key=lambda m: m["issue_67_break"])]
    notes = ["Survivors:\n\n" + ("\n".join(survivors) if survivors else "none."),
             "Issue 67's breaks (8, the LeRobot export, is not the learner's):\n\n" + "\n".join(f"- {b}" for b in breaks)]
    if r.get("tool_count") and r["tool_count"].get("total"):
        notes.append(f"{r['tool_count']['tool']} would generate {r['tool_count']['total']} mutants for the four files "
                     "of the scope (most of them changes of log and error strings), hence a hand-kept table.")
    return block(r, "mutation", ["file", "mutants", "killed", "survived", "survivors"], rows, *notes)
