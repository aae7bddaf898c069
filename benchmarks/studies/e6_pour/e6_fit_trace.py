"""E6: what one policy update does to the mean (the fit of the "awr" step), on a few tuning seeds.

For each seed a CNMP is trained as in E6 and adapted with a candidate of ``e6_settings.py`` (default
"F", ``e6_adapt_config``), budget 20, exactly as ``e6_settings.py`` runs it. Every policy update is
traced, without changing it: the wrist's largest tilt (deg) of the mean before the update, of the
AWR target and of the iteration's best roll-out, and of the mean after it; the fit measure (the
largest relevance-weighted distance of the mean from the target, in exploration stds, the one
``fit_tolerance`` is compared with) after each policy step but the last (update() does not
measure it either), the step where that largest distance sits (0-239), and why the update stopped
("fit_tolerance" or "max_reuse").

Usage: ``python benchmarks/studies/e6_pour/e6_fit_trace.py [--seeds 104,115] [--candidate F] [--out FILE]``.
"""
from __future__ import annotations

import argparse
import copy
import sys
from pathlib import Path

import numpy as np
import torch

ROOT = Path(__file__).resolve().parents[3]
sys.path.insert(0, str(ROOT))

from acnmp_core.adaptation import loop as adaptation  # noqa: E402
from acnmp_core.experiments.pour import TOLERANCE_G, make_setup, run_seed, train_pour_cnmp  # noqa: E402
from benchmarks._results import provenance, save_result, study_results  # noqa: E402
from clients.experiments.common import add_run_arguments  # noqa: E402
from benchmarks.studies.e6_pour.e6_settings import candidate_config, parse_seeds  # noqa: E402


def traced_update(original, trace: list[dict], cfg: adaptation.AdaptConfig):
    """Wrap ``_Updater.update`` so that every call appends one dict to ``trace`` (see the module
    docstring); the update itself runs unchanged."""

    def update(self, rollouts):
        rel = torch.stack([r.adv for r in rollouts]).sum(0)
        target = sum(r.adv[:, None] * r.tau for r in rollouts) / rel.clamp_min(1e-12)[:, None]
        std = rollouts[0].std
        best = max(rollouts, key=lambda r: float(r.adv.sum()))
        deg = lambda x: float(np.degrees(self.model.value_norm.denormalize(x.double()).numpy().max()))  # noqa: E731
        fits, where = [], []
        plain_mean = self.mean

        def mean():
            mu = plain_mean()
            d = rel[:, None] * (mu - target).abs() / std  # (T, D)
            fits.append(round(float(d.max()), 4))
            where.append(int(d.max(-1).values.argmax()))
            return mu

        mu0 = plain_mean()
        self.mean = mean
        try:
            reuses = original(self, rollouts)
        finally:
            del self.mean
        mu1 = plain_mean()
        trace.append({"mean_tilt_before_deg": deg(mu0), "target_tilt_deg": deg(target),
                      "best_rollout_tilt_deg": deg(best.tau), "mean_tilt_after_deg": deg(mu1),
                      "moved_fraction": (deg(mu1) - deg(mu0)) / max(abs(deg(target) - deg(mu0)), 1e-9)
                      * np.sign(deg(target) - deg(mu0)),
                      "reuses": reuses, "fit_after_each_step": fits, "worst_step_index": where,
                      "stopped_by": "fit_tolerance" if fits and fits[-1] < cfg.fit_tolerance else "max_reuse"})
        return reuses

    return update


def main(argv: list[str] | None = None) -> int:
    """Trace the updates of ``--candidate`` on ``--seeds``; print a line per update, write the JSON."""
    from acnmp_core.tasks.pour.task import PourTask

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", default="104,115", help="seeds: A-B (A to B), A,B or a mix (default 104,115)")
    ap.add_argument("--candidate", default="F", help="the adapt setting traced, a candidate of e6_settings.py (default F)")
    ap.add_argument("--budget", type=int, default=20, help="ACNMP roll-out budget (default 20)")
    add_run_arguments(ap, out=str(study_results("e6_pour") / "e6_fit_trace.json"))
    args = ap.parse_args(argv)
    meta = provenance()
    torch.set_num_threads(1)
    setup = make_setup()
    cfg = candidate_config(args.candidate, args.budget)
    original = adaptation._Updater.update
    seeds = {}
    with PourTask(tolerance_g=TOLERANCE_G) as task:
        for seed in parse_seeds(args.seeds):
            trace: list[dict] = []
            adaptation._Updater.update = traced_update(original, trace, cfg)
            try:
                model = train_pour_cnmp(setup.demos, seed)
                r = run_seed(copy.deepcopy(model), setup, task, cfg, seed, None)
            finally:
                adaptation._Updater.update = original
            for i, t in enumerate(trace):
                print(f"seed {seed} update {i}: tilt {t['mean_tilt_before_deg']:.1f} -> {t['mean_tilt_after_deg']:.1f} "
                      f"(target {t['target_tilt_deg']:.1f}, best {t['best_rollout_tilt_deg']:.1f}), reuses "
                      f"{t['reuses']}, fit {t['fit_after_each_step'][:1]}..{t['fit_after_each_step'][-1:]} at step "
                      f"{t['worst_step_index'][-1:]}, {t['stopped_by']}", flush=True)
            seeds[seed] = {"first_success_rollout": r["first_success_rollout"], "curve": r["curve"],
                           "updates": trace}
    return save_result({"provenance": meta, "benchmark": "e6_fit_trace", "candidate": args.candidate,
                 "config": cfg.to_dict(), "seeds": seeds}, args.out, None, ())


if __name__ == "__main__":
    sys.exit(main())
