"""Writing a benchmark's result: JSON with its provenance, the figure beside it, a short summary."""
from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import Callable

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from clients.experiments.common import add_run_arguments, output_path, seed_list  # noqa: E402
from clients.provenance import provenance  # noqa: E402

__all__ = ["RESULTS", "ROOT", "benchmark_args", "development_seeds", "provenance", "main_provenance", "save_result",
           "start_run", "study_results"]

#: What README and docs/ publish (and the regression pins): the product's results.
RESULTS = ROOT / "benchmarks" / "results"


def study_results(study: str) -> Path:
    """The folder of a study's own JSON and figures, beside its notes and scripts:
    ``benchmarks/studies/<study>/results/``."""
    return ROOT / "benchmarks" / "studies" / study / "results"


def development_seeds(text: str) -> tuple[int, ...]:
    """An argparse type for a study of the comparison's tasks: comma-separated seeds, refused when
    one is a report seed (:func:`acnmp_core.experiments.peers.config.check_development_seeds`)."""
    from acnmp_core.errors import InputError
    from acnmp_core.experiments.peers.config import check_development_seeds

    try:
        seeds = [int(s) for s in text.split(",") if s.strip()]
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected comma-separated integers, got {text!r}") from None
    try:
        return check_development_seeds(seeds, "--seeds")
    except InputError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None


def benchmark_args(doc: str, name: str, argv: list[str] | None, *, results: Path = RESULTS,
                   **options) -> argparse.Namespace:
    """The parsed arguments of a benchmark's main. ``seeds``, ``seed``, ``envs``, ``eval_every``,
    ``jobs`` and ``recipe`` (True: ``--recipe``, the method, its result's default name following it)
    are the run options
    every experiment command line shares (:func:`clients.experiments.common.add_run_arguments`;
    ``seeds=5`` is ``--seeds``, a count or the seeds themselves, parsed to the list of seeds); every
    other keyword is ``--<option>`` from ``(default, help)`` (``train_steps=(400, "CNMP training
    steps")`` is ``--train-steps``, an int defaulting to 400, its help naming the default); and
    ``--out`` (default ``<results>/<name>.json``: the product's ``benchmarks/results/`` unless a
    study's folder is given). The usage's description is ``doc``'s first line."""
    ap = argparse.ArgumentParser(description=doc.splitlines()[0])
    shared = {k: options.pop(k) for k in ("seeds", "seed", "envs", "eval_every", "jobs", "recipe") if k in options}
    for option, (default, help_text) in options.items():
        ap.add_argument("--" + option.replace("_", "-"), type=type(default), default=default,
                        help=f"{help_text} (default {default})")
    add_run_arguments(ap, **shared, out=results / f"{name}.json")
    args = ap.parse_args(argv)
    if "seeds" in shared:
        args.seeds = seed_list(args, shared["seeds"])
    args.out = output_path(args)
    return args


def main_provenance(script: str, argv: list[str] | None) -> dict:
    """:func:`provenance` naming the command a benchmark's main ran as: this process's command line
    when ``argv`` is None (run as a script), else the main's file ``script`` (``__file__``) with
    ``argv`` (called from Python, e.g. a test)."""
    return provenance(sys.argv if argv is None else [script, *argv])


def start_run(ap: argparse.ArgumentParser, argv: list[str] | None,
              script: str | None = None) -> tuple[argparse.Namespace, dict]:
    """``ap``'s arguments parsed from ``argv`` and the run's provenance (taken now, at its start; with
    the main's file ``script``, :func:`main_provenance`), torch set to one thread first: the CNMP is
    small, threads only contend with the simulator and the services."""
    args = ap.parse_args(argv)
    import torch

    torch.set_num_threads(1)
    return args, provenance() if script is None else main_provenance(script, argv)


def save_result(result: dict, out: str | Path, plot: Callable[[dict, Path], object] | None = None,
                headline: tuple[str, ...] = ()) -> int:
    """Write ``result`` to ``out`` (JSON; it should carry ``provenance`` from the start of the run),
    its figure to ``out`` with a .png suffix via ``plot``, and print the keys ``headline``; returns 0,
    the exit code of a benchmark's main that ends here."""
    out = Path(out)
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(json.dumps(result, indent=2) + "\n")
    if plot is not None:
        plot(result, out.with_suffix(".png"))
    print(json.dumps({k: result[k] for k in headline if k in result}, indent=1))
    print(f"wrote {out}" + (f" and {out.with_suffix('.png')}" if plot is not None else ""))
    return 0
