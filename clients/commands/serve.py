"""``acnmp serve model|learner|worker|recorder|router [...]``: run one process of a deployment.

Each process module (services/<name>.py) exposes ``add_arguments(parser)`` and
``run_from_args(args) -> int``; this command only dispatches. Modules are imported when their
sub-command runs, so ``acnmp serve worker`` works even if another service cannot be imported.
"""
from __future__ import annotations

import importlib
import logging

#: sub-command -> (module, help). Parsers are built from each module's add_arguments on demand.
PROCESSES = {
    "model": ("services.model", "the model service: predict/info queries, hot-swapped weights"),
    "learner": ("services.learner", "the learner: trains skills, runs adaptation jobs, checkpoints"),
    "worker": ("services.worker", "a roll-out worker of one robot kind"),
    "recorder": ("services.recorder", "the recorder: writes every event into a .rrd file"),
    "router": ("services.router", "a zenoh router, for deployments over several hosts"),
}


def register(subparsers) -> None:
    """Add ``serve`` with one sub-command per process."""
    parser = subparsers.add_parser("serve", help="run one process of a deployment (model, learner, worker, ...)",
                                   description=__doc__.splitlines()[0])
    sub = parser.add_subparsers(dest="process", metavar="PROCESS", required=True)
    for name, (module_name, help_text) in PROCESSES.items():
        p = sub.add_parser(name, help=help_text)
        try:
            module = importlib.import_module(module_name)
        except ImportError as exc:  # e.g. a dependency missing: say so when it is run, keep the other commands
            p.set_defaults(func=_unavailable(name, exc))
            continue
        module.add_arguments(p)
        p.set_defaults(func=_runner(name, module))


def _runner(name: str, module):
    def run(args) -> int:
        logging.basicConfig(level=logging.INFO, format=f"%(asctime)s {name} %(levelname)s %(message)s")
        return module.run_from_args(args)

    return run


def _unavailable(name: str, exc: Exception):
    def run(_args) -> int:
        raise ValueError(f"serve {name}: cannot import its module ({exc})")

    return run
