"""Published numbers cannot go stale: the docs' tables are what benchmarks/report.py writes from the
JSON results, every result file records where it came from, and the pinned regression runs
(benchmarks/regression.py) still give exactly the pinned roll-out counts and successes."""
from __future__ import annotations

import json
import warnings

import pytest

from benchmarks import regression, report
from benchmarks.report_kit import result_path
from tests.paths import ROOT

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
                                  "e5_demo_spread", "e3_budget", "e3_stop", "e3_seeds", "e3_wall_paper_paths",
                                  "e3_seeds_paper_paths", "e2_push_second_machine", "e6_pour", "e6_pour_first_machine",
                                  "e6_assimilation", "e5_ur10", "e6_pour_setting_s", "e6_assimilation_demos",
                                  "e6_assimilation_demos_tuning", "e6_assimilation_rbf_tuning"])
def test_result_files_record_their_provenance(name):
    p = json.loads(result_path(name).read_text())["provenance"]
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


@pytest.fixture(scope="module")
def here():
    """This machine's numerics fingerprint (the canary runs: about 8 s)."""
    import torch

    from benchmarks.numerics import fingerprint

    before = torch.get_num_threads()
    torch.set_num_threads(1)  # as the pinned runs measure
    try:
        yield fingerprint()
    finally:
        torch.set_num_threads(before)


def _measure(only):
    import torch

    before = torch.get_num_threads()
    try:
        return regression.measure(only)
    finally:
        torch.set_num_threads(before)


@pytest.fixture(scope="module")
def e1_measured():
    """The suite's pinned run (E1 seed 0, about 25 s)."""
    return _measure(regression.QUICK)


def _checked(result):
    assert not result.differences, ("the defaults changed the pinned runs; re-run the benchmarks and the pin:\n"
                                    + "\n".join(result.differences))
    if not result.exact:
        warnings.warn(result.note + " (python benchmarks/regression.py --write adds this machine's pin)")


@pytest.mark.slow
def test_pinned_e1_run_is_unchanged(here, e1_measured):
    _checked(regression.compare(regression.load_pins(), e1_measured, here))


@pytest.mark.slow
def test_all_pinned_runs_are_unchanged(here):
    """E1, E2 and E3 (minutes: deselected by default, `pytest -m slow` runs it)."""
    _checked(regression.compare(regression.load_pins(), _measure(None), here))


FP_A = {"cpu": {"vendor": "AuthenticAMD", "name": "AMD EPYC"}, "software": {"torch": "2.13.0"}, "canary": "aa"}
RUNS = {"e1_seed0": {"rl_only": {"rollouts": 25, "success": True}},
        "e3_envs20": {"acnmp": {"rollouts_per_env": [1, 31], "test_success_rate": 0.4, "adaptations_failed": 0}}}
OTHER_COUNTS = {"e1_seed0": {"rl_only": {"rollouts": 35, "success": True}},
                "e3_envs20": {"acnmp": {"rollouts_per_env": [1, 16], "test_success_rate": 0.5, "adaptations_failed": 0}}}
BANDS = {"e1_seed0": {"rl_only": {"rollouts": [10, 120]}}}


def test_every_count_is_compared_only_on_the_machine_whose_fingerprint_wrote_the_pin():
    pins = {"AMD EPYC, AVX2 #1": {"provenance": {}, "fingerprint": FP_A, "runs": RUNS}}
    same = regression.compare(pins, OTHER_COUNTS, json.loads(json.dumps(FP_A)), BANDS)
    assert same.exact and len(same.differences) == 3 and "same fingerprint" in same.note
    # the same CPU name and torch build, but other floats (the report): successes and bands only
    other = {**FP_A, "canary": "bb"}
    result = regression.compare(pins, OTHER_COUNTS, other, BANDS)
    assert result == regression.Comparison(False, [], result.note)
    assert "exact counts not compared" in result.note and "canary: aa -> bb" in result.note
    # a pin written before fingerprints is never exact
    old = {"AMD EPYC, AVX2": {"provenance": {}, "runs": RUNS}}
    assert "has no fingerprint (written before fingerprints)" in regression.compare(old, RUNS, FP_A, BANDS).note


def test_without_a_pin_a_lost_success_a_failed_adaptation_or_a_count_outside_its_band_fails():
    pins = {"AMD EPYC, AVX2 #1": {"provenance": {}, "fingerprint": FP_A, "runs": RUNS}}
    broken = json.loads(json.dumps(OTHER_COUNTS))
    broken["e1_seed0"]["rl_only"] = {"rollouts": 121, "success": False}
    broken["e3_envs20"]["acnmp"]["adaptations_failed"] = 2
    result = regression.compare(pins, broken, {**FP_A, "canary": "bb"}, BANDS)
    assert not result.exact and result.differences == [
        "[AMD EPYC, AVX2 #1] e1_seed0/rl_only/success: True -> False",
        "[AMD EPYC, AVX2 #1] e3_envs20/acnmp/adaptations_failed: 0 -> 2",
        "e1_seed0/rl_only/rollouts: 121 outside the band [10, 120]"]


def test_the_bands_span_the_published_seeds_widened():
    bands = regression.published_bands()
    e1 = json.loads((RESULTS / "e1_viapoint.json").read_text())["runs"]
    counts = [r["methods"]["acnmp"]["rollouts"] for r in e1]
    assert bands["e1_seed0"]["acnmp"]["rollouts"] == [min(counts) / regression.BAND_FACTOR,
                                                       max(counts) * regression.BAND_FACTOR]
    assert set(bands["e2_seed0"]) == {"acnmp/interpolation", "acnmp/extrapolation",
                                      "promp_rl/interpolation", "promp_rl/extrapolation"}


@pytest.mark.slow
def test_a_changed_default_fails_the_check_on_a_machine_without_a_pin(here, e1_measured, monkeypatch):
    """Item 3 of issue 32: a pin from another machine (another fingerprint) lets this machine's
    unchanged E1 pass, and E1's defaults lowered (training steps 3000 -> 50, roll-out budget
    100 -> 20: changes that also make the mutated run short) make it fail."""
    from acnmp_core.experiments import viapoint

    foreign = {k: {**pin, "fingerprint": {**here, "canary": "another machine"}}
               for k, pin in regression.load_pins().items()}
    unchanged = regression.compare(foreign, e1_measured, here)
    assert not unchanged.exact and unchanged.differences == []
    monkeypatch.setitem(viapoint.run_viapoint.__kwdefaults__, "train_steps", 50)
    monkeypatch.setitem(viapoint.run_viapoint.__kwdefaults__, "budget", 20)
    changed = regression.compare(foreign, _measure(regression.QUICK), here)
    assert not changed.exact and "e1_seed0/acnmp/success: True -> False" in " ".join(changed.differences)


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
    other = {"cpu": {"model_name": "AMD EPYC"}, "software": {}, "canary": "0" * 16}
    dropped = regression.compare(pins, new["runs"], other, bands={})
    assert not dropped.exact and dropped.differences == [] and "'Intel, AVX512'" in dropped.note
    # and writing its pin again clears its superseded record
    again, superseded = regression.written_pins(pins, "AMD EPYC", new, supersede=False, superseded=superseded,
                                                commit="d" * 40)
    assert set(again) == {"AMD EPYC", "Intel, AVX512"} and superseded == {}
