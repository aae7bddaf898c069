"""``acnmp serve model|learner|worker|recorder|router [...]``: run one process of a deployment.

The processes are the launcher's table (services/launcher/processes.py); each one's options come
from its options class (torch- and rerun-free, so `acnmp --help` is quick) and it is run by
:func:`services.transport.service.run_process` with the class that runs it, so this command only
dispatches.
"""
from __future__ import annotations


def register(subparsers) -> None:
    """Add ``serve`` with one sub-command per process."""
    from services.launcher.processes import PROCESSES, options_class
    from services.transport.service import add_arguments

    parser = subparsers.add_parser("serve", help="run one process of a deployment (model, learner, worker, ...)",
                                   description=__doc__.splitlines()[0].split(": ", 1)[1])
    sub = parser.add_subparsers(dest="process", metavar="PROCESS", required=True)
    for name in PROCESSES:
        cls = options_class(name)
        p = sub.add_parser(name, help=cls.summary, description=cls.summary)
        add_arguments(p, cls)
        p.set_defaults(func=_runner(name))


def _runner(name: str):
    def run(args) -> int:
        from services.launcher.processes import service_class
        from services.transport.service import configure_logging, from_args, run_process

        cls = service_class(name)
        configure_logging(cls.name)
        return run_process(from_args(cls, args))

    return run
