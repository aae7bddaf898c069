"""Published numbers cannot go stale: the docs' tables are what benchmarks/report.py writes from the
JSON results, every result file records where it came from, and the pinned regression runs
(benchmarks/regression.py) still give exactly the pinned roll-out counts and successes."""
from __future__ import annotations

import json
import warnings
from pathlib import Path

import pytest

from benchmarks import regression, report

ROOT = Path(__file__).resolve().parents[2]
RESULTS = ROOT / "benchmarks" / "results"


def test_docs_tables_are_what_the_results_give():
    stale = report.stale_blocks()
    assert not stale, "stale docs blocks (run python benchmarks/report.py): " + ", ".join(stale)


def test_every_block_has_a_renderer_and_every_renderer_is_used():
    used = {m.group(2) for page in report.pages() for m in report.BLOCK.finditer(page.read_text())}
    assert used == set(report.RENDERERS)


@pytest.mark.parametrize("name", ["e1_viapoint", "e2_push", "e3_wall", "e4_transfer", "e4_latent_weight",
                                  "adapt_sweep", "adapt_sweep_2", "e3_profile", "regression", "bench_predict",
                                  "bench_hostile", "e3_compare_paper", "e3_compare_authors", "e4_failures",
                                  "e4_failures_seed0", "e4_failures_sl_once", "e4_failures_cubic", "e1_assimilation",
                                  "e5_demo_spread", "e3_budget", "e3_stop", "e3_seeds"])
def test_result_files_record_their_provenance(name):
    p = json.loads((RESULTS / f"{name}.json").read_text())["provenance"]
    assert len(p["commit"]) == 40 and isinstance(p["dirty"], bool) and p["command"]
    assert p["libraries"]["torch"] and p["machine"]["cpu_count"] >= 1


def test_a_block_differing_from_its_json_is_reported(tmp_path, monkeypatch):
    page = tmp_path / "page.md"
    page.write_text("x\n<!-- BEGIN report:e1-results -->\nold numbers\n<!-- END report:e1-results -->\n")
    monkeypatch.setattr(report, "pages", lambda: [page])
    monkeypatch.setattr(report, "ROOT", tmp_path)
    assert report.stale_blocks() == ["page.md: e1-results"]
    assert report.main([]) == 0 and report.stale_blocks() == []
    assert "old numbers" not in page.read_text() and "ACNMP" in page.read_text()


@pytest.mark.slow
def test_pinned_regression_runs_are_unchanged():
    from clients.provenance import provenance

    key = regression.machine_key(provenance()["machine"])
    exact, diff = regression.compare(regression.load_pins(), regression.measure(), key)
    assert not diff, "the defaults changed the pinned runs; re-run the benchmarks and the pin:\n" + "\n".join(diff)
    if not exact:
        warnings.warn(f"no exact regression pin for {key!r}: only successes were compared "
                      "(python benchmarks/regression.py --write adds this machine's pin)")


def test_a_pin_compares_every_count_on_its_machine_and_successes_elsewhere():
    runs = {"e1_seed0": {"rl_only": {"rollouts": 25, "success": True}},
            "e3_envs20": {"acnmp": {"rollouts_per_env": [1, 31], "test_success_rate": 0.4, "adaptations_failed": 0}}}
    pins = {"AMD EPYC": {"provenance": {}, "runs": runs}}
    other_counts = {"e1_seed0": {"rl_only": {"rollouts": 35, "success": True}},
                    "e3_envs20": {"acnmp": {"rollouts_per_env": [1, 16], "test_success_rate": 0.5,
                                            "adaptations_failed": 0}}}
    # the machine that wrote the pin (recorded before the capability was) compares every count
    exact, diff = regression.compare(pins, other_counts, "AMD EPYC, AVX2")
    assert exact and len(diff) == 3
    # another machine compares the successes only ...
    assert regression.compare(pins, other_counts, "Intel(R) Xeon(R) Processor, AVX512") == (False, [])
    # ... and still catches a run that stopped succeeding or an adaptation that failed
    broken = json.loads(json.dumps(other_counts))
    broken["e1_seed0"]["rl_only"]["success"] = False
    broken["e3_envs20"]["acnmp"]["adaptations_failed"] = 2
    exact, diff = regression.compare(pins, broken, "Intel(R) Xeon(R) Processor, AVX512")
    assert not exact and diff == ["[AMD EPYC] e1_seed0/rl_only/success: True -> False",
                                  "[AMD EPYC] e3_envs20/acnmp/adaptations_failed: 0 -> 2"]


def test_superseding_a_pin_drops_the_other_machines_and_records_them():
    old = {"AMD EPYC": {"provenance": {"commit": "a" * 40}, "runs": {"e1_seed0": {}}},
           "Intel, AVX512": {"provenance": {"commit": "b" * 40}, "runs": {"e1_seed0": {}}}}
    new = {"provenance": {"commit": "c" * 40}, "runs": {"e1_seed0": {"acnmp": {"rollouts": 3, "success": True}}}}
    # a plain write keeps the others
    pins, superseded = regression.written_pins(old, "Intel, AVX512", new, supersede=False, superseded={},
                                               commit="c" * 40)
    assert set(pins) == {"AMD EPYC", "Intel, AVX512"} and pins["Intel, AVX512"] is new and superseded == {}
    # a superseding write keeps only this machine's and says which pin was dropped, from when
    pins, superseded = regression.written_pins(old, "Intel, AVX512", new, supersede=True, superseded={},
                                               commit="c" * 40)
    assert pins == {"Intel, AVX512": new}
    assert superseded == {"AMD EPYC": {"by_commit": "c" * 40, "pinned_at": "a" * 40}}
    # the dropped machine now compares successes only, against the new pin
    assert regression.compare(pins, new["runs"], "AMD EPYC")[0] is False
    # and writing its pin again clears its superseded record
    again, superseded = regression.written_pins(pins, "AMD EPYC", new, supersede=False, superseded=superseded,
                                                commit="d" * 40)
    assert set(again) == {"AMD EPYC", "Intel, AVX512"} and superseded == {}
