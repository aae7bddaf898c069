"""What every ``acnmp experiment`` command and the benchmarks' mains share: the options of a run
(seeds, output files, threads, the deployment) and writing results."""
from __future__ import annotations

import json
import sys
from pathlib import Path

import argparse

from services.transport.argtypes import SEEDS_HELP, check_output_path, int_at_least, non_empty, seeds

#: The options that name a file an experiment writes at its end (checked before it starts).
OUTPUT_OPTIONS = ("json", "plot", "record")


def add_output_arguments(p, plot_help: str) -> None:
    """Add ``--json FILE`` and ``--plot FILE`` (with ``plot_help``) to parser ``p``."""
    p.add_argument("--json", type=non_empty, metavar="FILE", help="write the results as JSON")
    p.add_argument("--plot", type=non_empty, metavar="FILE", help=plot_help)


def add_seeds_argument(p, default: int, what: str = "seeds", old: str | None = None) -> None:
    """Add ``--seeds SEEDS``, the one seed option of every experiment: a count N (seeds 0..N-1) or
    the seeds themselves (:func:`services.transport.argtypes.seeds`); None when not given, resolved
    by :func:`seed_list` (the help names ``default``, a count; ``what`` says what a seed is). ``old``
    adds the spelling the experiment had before, hidden, to the same list: ``"--seed"`` (one seed S:
    [S]) or ``"--runs"`` (a count)."""
    p.add_argument("--seeds", type=seeds, default=None, metavar="SEEDS",
                   help=f"the {what}: {SEEDS_HELP} (default {default}: " + ("seed 0" if default == 1 else
                                                                           f"seeds 0..{default - 1}") + ")")
    if old == "--seed":
        p.add_argument("--seed", dest="seeds", type=lambda text: [int_at_least(0)(text)], help=argparse.SUPPRESS)
    elif old == "--runs":
        p.add_argument("--runs", dest="seeds", type=seeds, help=argparse.SUPPRESS)


def seed_list(args, default: int) -> list[int]:
    """The seeds ``--seeds`` named, or seeds 0..``default``-1."""
    return list(range(default)) if args.seeds is None else list(args.seeds)


def add_size_arguments(p, *, seeds: int, train_steps: int, budget: int, budget_help: str) -> None:
    """Add ``--seeds SEEDS`` (:func:`add_seeds_argument`, default ``seeds``), ``--train-steps N`` and
    ``--budget N``; the last two default to None, resolved by :func:`sizes` from the experiment
    module's constants (the help names ``train_steps`` and ``budget``; importing the module here
    would load torch for ``--help``)."""
    count = int_at_least(1)
    add_seeds_argument(p, seeds)
    p.add_argument("--train-steps", type=count, default=None, help=f"CNMP training steps (default {train_steps})")
    p.add_argument("--budget", type=count, default=None, help=f"{budget_help} (default {budget})")


def sizes(args, train_steps: int, budget: int) -> tuple[int, int]:
    """``(train steps, budget)`` from ``args`` with the given defaults (the parser of
    :func:`add_size_arguments` has refused values below 1)."""
    return (train_steps if args.train_steps is None else args.train_steps,
            budget if args.budget is None else args.budget)


def add_deployment_arguments(p, what: str) -> None:
    """Add ``--distributed`` (help: ``what`` runs where), ``--workers N``, ``--record FILE.rrd``,
    ``--insecure`` (as ``acnmp up --insecure``: the fresh deployment without authentication) and
    ``--namespace NS`` (a running deployment instead of a fresh one) and ``--config FILE`` (the zenoh
    config that reaches it when it runs on other hosts)."""
    p.add_argument("--distributed", action="store_true", help=f"run {what} on a local zenoh deployment")
    p.add_argument("--workers", type=int_at_least(1), default=2,
                   help="workers of the --distributed deployment (default 2)")
    p.add_argument("--record", type=non_empty, metavar="FILE.rrd",
                   help="with --distributed: the recorder writes every roll-out to this Rerun file")
    p.add_argument("--insecure", action="store_true",
                   help="with --distributed: start the deployment without authentication, a zenoh peer mesh any "
                        "local process can join (as `acnmp up --insecure`; debugging only)")
    p.add_argument("--namespace", "-n", default=None, metavar="NS",
                   help="with --distributed: run on the running deployment of NS (`acnmp status` lists them; "
                        "its workers and recorder) instead of a fresh one; --workers and --record do not apply")
    p.add_argument("--config", type=non_empty, default=None, metavar="FILE",
                   help="with --namespace: join NS through this zenoh config (the operator.json5 of `acnmp "
                        "credentials`) instead of this machine's run file: a deployment whose router runs on "
                        "another host")


#: --recipe's help, the same in every command line that has it (acnmp_core/experiments/recipe.py).
RECIPE_HELP = ("the method run: 'paper' (the default: the paper's method as the experiment's page and `acnmp "
               "reproduce` report it against the paper, the CNMP alone adapted with the experiment's own settings) "
               "or 'default' (the product's default, what `acnmp up` serves: the model chooses at training between "
               "the demonstrations' linear path beside the network and the network alone, and adapts with "
               "AdaptConfig()'s settings plus only the experiment's protocol: its budget, its stopping rule)")


#: --threads' help, the same in every command line that has it.
THREADS_HELP = ("torch threads for the CNMP's training, adaptation and assimilation (default: $ACNMP_TORCH_THREADS "
                "or 1). 2 threads run faster only while no other process uses a core, and several times slower "
                "when one does (benchmarks/studies/e3_wall/results/bench_thread_default.json); the numbers "
                "computed are the same")


def add_run_arguments(p, *, seeds: int | None = None, seeds_what: str = "seeds", old_seeds: str | None = None,
                      seed: int | None = None, envs: int | None = None, eval_every: int | None = None,
                      quick: str | dict | None = None, jobs: int | None = None,
                      threads: bool = False, recipe: bool = False, out: str | Path | None = None,
                      plot: str | None = None, deployment: str | None = None, quiet: str | None = None) -> None:
    """Add to parser ``p`` the options of a run that the experiment commands (``acnmp experiment
    ...``) and the benchmarks' mains share, each whose keyword is given, in this order:

    - ``seeds=N``: ``--seeds SEEDS`` (:func:`add_seeds_argument` with ``seeds_what`` and
      ``old_seeds``; default the count N), resolved by :func:`seed_list`;
    - ``seed=S``: ``--seed S``, the run's one seed (default S);
    - ``envs=N``, ``eval_every=K`` (E3's loop): ``--envs N``, new environments in the loop, and
      ``--eval-every K``, new environments between test evaluations;
    - ``quick=HELP``: ``--quick``, a small run, described by HELP or, for a dict of the sizes it
      sets (``seeds``, ``train_steps``, ``budget`` or ``acnmp_budget``, ``promp_budget``), by them;
    - ``jobs=N``: ``--jobs N``, processes at once (1 to 64, default N);
    - ``threads=True``: ``--threads N`` (:data:`THREADS_HELP`), applied by :func:`apply_threads`;
    - ``recipe=True``: ``--recipe paper|default`` (:data:`RECIPE_HELP`; default "paper"), read by
      :func:`recipe_of`;
    - ``out=PATH``: ``--out FILE`` (also spelled ``--json``), the result's JSON (default PATH; with
      ``recipe``, PATH for the paper's method and ``<PATH's stem>_default.json`` beside it for the
      default, resolved by :func:`output_path`) with its figure beside it;
    - ``plot=HELP``: ``--json FILE`` and ``--plot FILE`` (:func:`add_output_arguments`);
    - ``deployment=WHAT``: the deployment options (:func:`add_deployment_arguments`);
    - ``quiet=HELP``: ``--quiet``, described by HELP."""
    if seeds is not None:
        add_seeds_argument(p, seeds, seeds_what, old_seeds)
    if seed is not None:
        p.add_argument("--seed", type=int_at_least(0), default=seed,
                       help=f"the seed of the run's environments, training and exploration (default {seed})")
    if envs is not None:
        p.add_argument("--envs", type=int_at_least(1), default=envs, help=f"new environments in the loop (default {envs})")
    if eval_every is not None:
        p.add_argument("--eval-every", type=int_at_least(1), default=eval_every,
                       help=f"new environments between test evaluations (default {eval_every})")
    if quick is not None:
        p.add_argument("--quick", action="store_true", help=quick if isinstance(quick, str) else _quick_help(quick))
    if jobs is not None:
        p.add_argument("--jobs", type=int_at_least(1, 64), default=jobs,
                       help=f"processes run at once, the same result (default {jobs})")
    if threads:
        p.add_argument("--threads", type=int_at_least(1), default=None, metavar="N", help=THREADS_HELP)
    if recipe:
        from acnmp_core.experiments.recipe import RECIPES  # light: no torch

        p.add_argument("--recipe", choices=RECIPES, default=RECIPES[0], help=RECIPE_HELP)
    if out is not None:
        root = Path(__file__).resolve().parents[2]
        shown = Path(out).relative_to(root) if Path(out).is_relative_to(root) else out
        if any(a.dest == "recipe" for a in p._actions):
            # the default follows the recipe, so the default's result never overwrites the paper's
            p.set_defaults(out_of_recipe=str(out))
            p.add_argument("--out", "--json", dest="out", type=non_empty, default=None, metavar="FILE",
                           help=f"write the result here as JSON, its figure (if any) beside it as .png (default {shown}; "
                                f"with --recipe default, {Path(shown).stem}_default.json beside it)")
        else:
            p.add_argument("--out", "--json", dest="out", type=non_empty, default=str(out), metavar="FILE",
                           help=f"write the result here as JSON, its figure (if any) beside it as .png (default {shown})")
    if plot is not None:
        add_output_arguments(p, plot)
    if deployment is not None:
        add_deployment_arguments(p, deployment)
    if quiet is not None:
        p.add_argument("--quiet", action="store_true", help=quiet)


def _quick_help(sizes: dict) -> str:
    """--quick's help from the sizes it sets: 'a small run (2 seeds, 1500 training steps, budgets 100/150,
    each unless given)'."""
    parts = [f"{sizes['seeds']} seeds"] if "seeds" in sizes else []
    parts += [f"{sizes['train_steps']} training steps"] if "train_steps" in sizes else []
    budgets = [str(sizes[k]) for k in ("budget", "acnmp_budget", "promp_budget") if k in sizes]
    parts += [f"budget{'s' if len(budgets) > 1 else ''} {'/'.join(budgets)}"] if budgets else []
    return f"a small run ({', '.join(parts)}, each unless given)"


def add_promp_budget_argument(p, per: str, default: int = 1500) -> None:
    """Add ``--promp-budget N``: ProMP + RL's roll-out budget per ``per`` (at least 3, its first
    iteration; None when not given, the help naming ``default``)."""
    p.add_argument("--promp-budget", type=int_at_least(3), default=None,
                   help=f"ProMP + RL roll-out budget per {per} (default {default})")


def recipe_of(args):
    """The :class:`~acnmp_core.experiments.recipe.Recipe` ``--recipe`` named (the paper's without
    the option)."""
    from acnmp_core.experiments.recipe import Recipe

    return Recipe(getattr(args, "recipe", "paper"))


def recipe_line(result: dict) -> str:
    """A few words naming the method of an experiment's JSON ``result`` for its printed table: "the
    paper's method", or "the default method" with the prior its model chose per seed."""
    from acnmp_core.experiments.recipe import chosen_priors

    recipe = (result.get("recipe") or {}).get("name", "paper")
    if recipe == "paper":
        return "the paper's method"
    chosen = chosen_priors(result)
    names = {"linear": "the linear path beside the network", "none": "the network alone"}
    counts = [f"{names.get(p, p)} in {sum(v == p for v in chosen.values())}/{len(chosen)}"
              for p in sorted(set(chosen.values()))]
    return "the default method" + (f" (model: {', '.join(counts)} seeds)" if counts else "")


def output_path(args) -> str:
    """The result's JSON: ``--out`` when given, else the default of ``add_run_arguments(out=PATH)``
    under ``--recipe`` (PATH, or ``<stem>_default.json`` beside it)."""
    if args.out is not None:
        return args.out
    path = Path(args.out_of_recipe)
    return str(path.with_name(recipe_of(args).result_name(path.stem) + path.suffix))


def apply_threads(args) -> None:
    """Set the torch threads of training, adaptation and assimilation to ``args.threads`` when it was
    given (:func:`acnmp_core.threads.set_training_threads`)."""
    if getattr(args, "threads", None) is not None:
        from acnmp_core.threads import set_training_threads

        set_training_threads(args.threads)


def check_deployment_arguments(args) -> None:
    """ValueError when the deployment options do not fit together."""
    if args.record and not args.distributed:
        raise ValueError("--record: only with --distributed (the recorder is a process of the deployment)")
    if args.insecure and not args.distributed:
        raise ValueError("--insecure: only with --distributed (it is about the deployment's authentication)")
    if getattr(args, "namespace", None) is not None and not args.distributed:
        raise ValueError("--namespace: only with --distributed (it names the deployment to run on)")
    if getattr(args, "config", None) is not None and getattr(args, "namespace", None) is None:
        raise ValueError("--config: only with --distributed --namespace NS (it is how to reach NS)")


def check_output_arguments(args) -> None:
    """:func:`check_output_path` for each of ``--json``, ``--plot``, ``--record`` that ``args`` has,
    and that matplotlib can write the format ``--plot``'s suffix names (no suffix: PNG)."""
    for name in OUTPUT_OPTIONS:
        check_output_path(getattr(args, name, None), f"--{name}")
    suffix = Path(getattr(args, "plot", None) or "").suffix.lower()[1:]
    if suffix:
        from matplotlib.backend_bases import FigureCanvasBase

        formats = FigureCanvasBase.get_supported_filetypes()
        if suffix not in formats:
            raise ValueError(f"--plot {args.plot}: matplotlib cannot write .{suffix} files "
                             f"(give one of .{', .'.join(sorted(formats))})")


def with_deployment(result: dict, make) -> dict:
    """``result`` with the ``deployment`` facts of the evaluator maker ``make`` it ran with
    (:class:`clients.distributed.EvaluatorMaker`): namespace, attached, workers, recording,
    authenticated."""
    result["deployment"] = make.deployment.to_dict()
    return result


def write_json(result: dict, path: str | None) -> None:
    """Write ``result`` as indented JSON to ``path`` (parents created) and say so; no-op for None.
    The file records where it came from (:func:`clients.provenance.provenance`) unless ``result``
    already does."""
    if path:
        from clients.provenance import provenance

        Path(path).parent.mkdir(parents=True, exist_ok=True)
        Path(path).write_text(json.dumps({"provenance": provenance(), **result}, indent=2))
        print(f"wrote {path}")
    sys.stdout.flush()



def write_outputs(result: dict, args, plot) -> int:
    """Write ``result`` to ``args.json`` (:func:`write_json`) and its figure to ``args.plot`` with
    ``plot(result, path)``, saying where; returns 0, the experiment's exit code."""
    write_json(result, args.json)
    if args.plot:
        print(f"wrote {plot(result, args.plot)}", flush=True)
    return 0