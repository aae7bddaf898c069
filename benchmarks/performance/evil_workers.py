"""Workers that answer badly, one way each (issue 66), shared by tests/e2e/test_bad_workers.py and the
fault benchmark (benchmarks/performance/bench_faults.py).

An evil worker runs the roll-outs as a healthy one would (services/worker/core.py ``Worker``) and
then spoils its answer by ``mode``:

========  ====================================================================================
nan       one reward NaN (msgpack carries it; the wire refuses it on reading)
inf       every reward +inf
huge      every reward -1e308 (finite: the wire takes it; the sum of two is -inf)
shape     rewards for one step fewer than asked
stale     the reply of its previous request (another chunk's tag and roll-outs)
slow      a correct reply after ``slow_s`` seconds (or once ``release`` is set)
failing   ``internal`` every time
refusing  ``bad_request`` every time (the request is fine: the healthy workers run it)
liar      every reward -1.0: finite, the right shape, its own chunk's tag (issue 73: only a
          cross-check, services/worker/remote.py, sees it)
========  ====================================================================================

As a process (the benchmark's worker beside a deployment's healthy ones)::

    python -m benchmarks.performance.evil_workers --mode nan --id evil --namespace NS --connect tcp/127.0.0.1:PORT
"""
from __future__ import annotations

import argparse
import sys
import threading
from pathlib import Path

import numpy as np

if __name__ == "__main__":
    sys.path.insert(0, str(Path(__file__).resolve().parents[2]))

from services.transport import Keyspace, WireError, declare_rpc, encode  # noqa: E402
from services.worker.core import Worker  # noqa: E402

#: The modes a reply's checks catch (services/worker/remote.py); ``liar`` needs a cross-check.
MODES = ("nan", "inf", "huge", "shape", "stale", "slow", "failing", "refusing")
ALL_MODES = (*MODES, "liar")


class EvilWorker:
    """The roll-out handler of a worker that answers badly by ``mode`` (see the module docstring)."""

    def __init__(self, mode: str, robot_kind: str, worker_id: str, *, slow_s: float = 30.0,
                 release: threading.Event | None = None):
        if mode not in ALL_MODES:
            raise ValueError(f"mode: expected one of {ALL_MODES}, got {mode!r}")
        self.mode, self.slow_s = mode, float(slow_s)
        self.release = release if release is not None else threading.Event()
        self.worker = Worker(robot_kind, worker_id)
        self.previous: bytes | None = None  # the last reply, for "stale"
        self.asked = 0

    def handle(self, request: dict | None) -> bytes:
        """The encoded reply to a roll-out request (non-finite floats allowed), or WireError."""
        self.asked += 1
        if self.mode == "failing":
            raise WireError("internal", "RuntimeError: the evil worker fails")
        if self.mode == "refusing":
            raise WireError("bad_request", "the evil worker refuses every request")
        reply = self.worker.handle(request)
        rewards = np.array(reply["rewards"], dtype=np.float64)
        if self.mode == "nan":
            rewards[0, 0] = np.nan
        elif self.mode == "inf":
            rewards[:] = np.inf
        elif self.mode == "huge":
            rewards[:] = -1e308
        elif self.mode == "liar":
            rewards[:] = -1.0
        elif self.mode == "shape":
            rewards = rewards[:, :-1]
        elif self.mode == "slow":
            self.release.wait(self.slow_s)
        reply["rewards"] = rewards
        body = encode(reply, allow_non_finite=True)
        if self.mode == "stale":
            body, self.previous = (self.previous, body) if self.previous is not None else (
                encode({**reply, "chunk": "another-chunk"}), body)
        return body


def serve_evil(session, keys: Keyspace, mode: str, robot_kind: str, worker_id: str, **options):
    """Declare an evil worker's queryable and liveliness token on ``session``; returns
    ``(handler, queryable, token)`` (undeclare the last two, or close the session)."""
    evil = EvilWorker(mode, robot_kind, worker_id, **options)
    rpc = declare_rpc(session, keys.worker_rollout(robot_kind, worker_id), lambda req, _q: evil.handle(req), workers=1)
    token = session.liveliness().declare_token(keys.worker_token(robot_kind, worker_id))
    return evil, rpc, token


def main(argv: list[str] | None = None) -> int:
    from services.transport import install_shutdown_handlers, open_session, wait_until_stopped

    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--mode", choices=ALL_MODES, required=True, help="how it answers badly (the module docstring)")
    p.add_argument("--id", default="evil", help="worker id (default: %(default)s)")
    p.add_argument("--robot", default="point2d", help="its robot kind (default: %(default)s)")
    p.add_argument("--namespace", "-n", default="default", help="the deployment's namespace (default: %(default)s)")
    p.add_argument("--connect", action="append", default=None, help="an endpoint of the deployment")
    p.add_argument("--config", default=None, help="a zenoh config file (a role's credentials)")
    p.add_argument("--slow-s", type=float, default=30.0, help="seconds a slow worker takes (default: %(default)s)")
    args = p.parse_args(argv)
    stop = install_shutdown_handlers()
    mode = "client" if args.config else "peer"
    with open_session(None if args.config else mode, connect=args.connect, config_file=args.config) as session:
        evil, rpc, token = serve_evil(session, Keyspace(args.namespace), args.mode, args.robot, args.id,
                                      slow_s=args.slow_s)
        print(f"evil worker {args.id} ({args.mode}) live", flush=True)
        wait_until_stopped(stop)
        evil.release.set()
        token.undeclare()
        rpc.close()
    return 0


if __name__ == "__main__":
    sys.exit(main())
