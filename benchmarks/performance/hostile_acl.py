"""Generated hostile traffic against the access table (issue 31), shared by the default suite's short
run (tests/e2e/test_acl_generated.py) and the 10,000-case benchmark (benchmarks/performance/bench_acl.py).

A case is (role, message kind, key expression, payload). Key expressions are written by
hypothesis from every key family of the deployment (docs/PROTOCOL.md section 5): exact, with
``*``, ``**`` or a ``$*`` chunk in any position, ``/**`` appended, cut short, or in another
namespace. Each case is sent through a session holding that role's password.

The cases the table allows on a concrete key are legitimate use (a worker serving roll-outs, an
operator starting a job): they are counted, not sent; the functional suite covers them. Every
other case is sent, and in batches the deployment's state is read from the trusted side (the
router's own session and the state directory): the served model (version, data hash, a predict),
the learner's skills and jobs, the recording's counts, the live workers as the learner sees them.
Any difference is a state change outside the table. After the run every process must be alive
and answering.
"""
from __future__ import annotations

import contextlib
import time
from collections import Counter
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Iterator

import numpy as np
import zenoh
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from acnmp_core.experiments.viapoint import make_setup
from benchmarks.performance.hostile_inputs import OBS, SMALL, served, valid_requests
from services.launcher import LocalDeployment
from services.transport import call, encode, open_session
from services.transport.acl import MESSAGES, may
from services.transport.keys import is_concrete

#: The roles an attacker may hold a password of (the services' own roles included: a stolen
#: worker or model password must not reach further than that role's grants).
ATTACKER_ROLES = ("client", "operator", "worker", "model", "recorder", "learner")


@dataclass(frozen=True)
class Case:
    """One generated message: ``role`` sends ``message`` on ``key`` with payload kind ``payload``."""

    role: str
    message: str
    key: str
    payload: str


def families(ns: str) -> list[str]:
    """A concrete key of every family of namespace ``ns`` (docs/PROTOCOL.md sections 5-7)."""
    p = f"acnmp/{ns}"
    return [f"{p}/skill/e1/{op}" for op in ("predict", "info", "transfer", "weights", "train", "train_pair", "adapt")] + [
        f"{p}/skill/e1/weights/latest", f"{p}/job/e1-0/status", f"{p}/job/e1-0/cancel",
        f"{p}/worker/point2d/point2d-0", f"{p}/worker/point2d/point2d-0/rollout", f"{p}/model/e1",
        f"{p}/service/model/abc", f"{p}/learner/l1", f"{p}/recorder/status", f"{p}/recorder/r1",
        f"{p}/event/rollout/e1-0", f"{p}/event/model_version/e1", f"{p}/event/rollout/e1-0/@adv/pub/z/1/_/_",
        f"{p}/event/rollout/e1-0/@adv/sub/z/1/_/_"]


_WILD = st.sampled_from(["*", "**", "e$*", "$*", "*"])


@st.composite
def key_exprs(draw, ns: str) -> str:
    """A key expression built from a real key of ``ns``: kept, or with wildcards, cut, extended,
    or moved to another namespace."""
    chunks = draw(st.sampled_from(families(ns))).split("/")
    for _ in range(draw(st.integers(0, 2))):
        i = draw(st.integers(1, len(chunks) - 1))
        chunks[i] = draw(_WILD)
    how = draw(st.sampled_from(["keep", "keep", "cut", "extend", "other-ns"]))
    if how == "cut":
        chunks = chunks[:draw(st.integers(1, len(chunks)))]
    elif how == "extend":
        chunks.append(draw(st.sampled_from(["**", "*", "x"])))
    elif how == "other-ns":
        chunks[1] = draw(st.sampled_from(["other", "*", "**"]))
    # zenoh takes key expressions in canonical form only ("$*" alone is "*", "**/*" is "*/**")
    return str(zenoh.KeyExpr.autocanonize("/".join(chunks)))


def cases(ns: str) -> st.SearchStrategy[Case]:
    """Generated cases for namespace ``ns``."""
    return st.builds(Case, st.sampled_from(ATTACKER_ROLES), st.sampled_from(MESSAGES), key_exprs(ns),
                     st.sampled_from(["forged-weights", "train", "adapt", "rollout", "event", "garbage"]))


def is_legitimate(case: Case) -> bool:
    """The table allows this case on a concrete key: legitimate use, not sent."""
    return is_concrete(case.key) and may(case.role, case.message, case.key)


class Attacker:
    """One open session per role (the roles' config files of a secured :class:`LocalDeployment`)
    and the payloads; :meth:`send` performs one case and undoes its declarations."""

    def __init__(self, dep: LocalDeployment, stack: contextlib.ExitStack):
        self.sessions = {r: stack.enter_context(open_session(None, config_file=dep.announcement.secrets.config_path(r)))
                         for r in ATTACKER_ROLES}
        from acnmp_core import CNMP, CNMPConfig, TrainConfig, train
        from services.model.weights import encode_weights
        from services.recording.events import rollout_event

        model = CNMP(CNMPConfig(n_outputs=2, **SMALL), seed=9)
        train(model, make_setup().demos, TrainConfig(steps=1), seed=9)
        valid = valid_requests()
        self.payloads = {
            "forged-weights": encode_weights("e1", 2**62, model, data_hash="forged", n_demos=1),
            "train": encode({"v": 1, **valid["train"]}), "adapt": encode({"v": 1, **valid["adapt"]}),
            "rollout": encode({"v": 1, **valid["rollout"]}),
            "event": encode(rollout_event("forged", 0, np.zeros((3, 2)), [0.0, 0.5, 1.0], [0.0, 0.0, 1.0], worker="w")),
            "garbage": b"\xc1\x00garbage"}
        self.heard = 0  # samples, queries or tokens an attacker's declaration received

    def _hear(self, *_args) -> None:
        self.heard += 1

    def send(self, case: Case) -> None:
        """Send one case (ValueError from zenoh for a key it refuses is the caller's to count)."""
        s, body = self.sessions[case.role], self.payloads[case.payload]
        m = case.message
        if m == "put":
            s.put(case.key, body)
        elif m == "delete":
            s.delete(case.key)
        elif m in ("query", "reply"):  # a reply needs a query: sent as a query the attacker answers itself
            for _ in s.get(case.key, payload=body, timeout=2.0):
                pass
        elif m == "declare_subscriber":
            s.declare_subscriber(case.key, self._hear).undeclare()
        elif m == "declare_queryable":
            q = s.declare_queryable(case.key, lambda query: query.reply(query.key_expr, body))
            q.undeclare()
        elif m == "liveliness_token":
            s.liveliness().declare_token(case.key).undeclare()
        elif m == "declare_liveliness_subscriber":
            s.liveliness().declare_subscriber(case.key, self._hear).undeclare()
        elif m == "liveliness_query":
            for _ in s.liveliness().get(case.key, timeout=2.0):
                pass


def snapshot(dep: LocalDeployment) -> dict:
    """The deployment's state read from the trusted side: the served model, the learner's skills
    and jobs (state directory), the recording's counts, the live point2d workers."""
    from services.worker.remote import RemoteEvaluator

    info = call(dep.session, dep.keys.info("e1"), None, timeout=10)
    pred = call(dep.session, dep.keys.predict("e1"), {**OBS, "n_steps": 20}, timeout=10)
    rec = call(dep.session, dep.keys.recorder_status(), None, timeout=10)
    state = Path(dep.state_dir)
    workers = RemoteEvaluator(dep.session, dep.keys.namespace, "point2d", "viapoint").workers()
    return {"model": {"version": info["version"], "data_hash": info["data_hash"], "source": info["source"],
                      "mean_sum": round(float(np.asarray(pred["mean"]).sum()), 9)},
            "skills": sorted(p.name for p in (state / "skills").iterdir()) if (state / "skills").exists() else [],
            "jobs": sorted(p.name for p in (state / "jobs").iterdir()) if (state / "jobs").exists() else [],
            "recording": {"events": rec["events"], "rollouts": rec["rollouts"]},
            "workers": sorted(workers)}


@contextlib.contextmanager
def acl_deployment(tmp: Path) -> Iterator[LocalDeployment]:
    """An authenticated deployment (router, learner, model, one point2d worker, recorder) in
    ``tmp`` with skill ``e1`` trained (20 steps, small) and served."""
    setup = make_setup()
    with LocalDeployment(f"aclgen-{tmp.name[-8:].replace('_', '-')}", workers=1, secure=True, announce=False,
                         record=tmp / "run.rrd", state_dir=tmp / "state", start_timeout=90,
                         learner_args=["--max-train-steps", "50", "--max-rollouts", "4"]) as dep:
        train = {"times": np.stack([d.times for d in setup.demos]), "values": np.stack([d.values for d in setup.demos]),
                 "model": SMALL, "train": {"steps": 20}}
        call(dep.session, dep.keys.train("e1"), train, timeout=60)
        served(dep)
        # the training's events (one model_version, a latent per demonstration) are recorded
        # asynchronously: the state read before the first case must already hold them
        want = {"model_version": 1, "latent": len(setup.demos)}
        deadline = time.monotonic() + 30
        while True:
            events = call(dep.session, dep.keys.recorder_status(), None, timeout=10)["events"]
            if all(events.get(k, 0) >= n for k, n in want.items()):
                break
            if time.monotonic() > deadline:
                raise RuntimeError(f"the recorder holds {events} after 30 s, expected {want}")
            time.sleep(0.1)
        yield dep


def run_cases(dep: LocalDeployment, n: int, batch: int = 250, seed_label: str = "acl") -> dict:
    """Generate ``n`` cases (hypothesis, derandomized), send the ones that are not legitimate, read
    the state after every ``batch`` sent; returns the tally (JSON-able): cases, legitimate (not
    sent), sent, refused by zenoh's key parser, by (role, message) and by outcome, state changes
    (each with the batch's first cases), crashes (processes not alive at the end)."""
    tally: Counter = Counter()
    by_kind: Counter = Counter()
    changes: list[dict] = []
    pending: list[Case] = []
    sample_cases: list[dict] = []
    before = snapshot(dep)

    def check() -> None:
        nonlocal before
        after = snapshot(dep)
        if after != before:
            changes.append({"before": before, "after": after, "cases": [asdict(c) for c in pending[:20]]})
            before = after
        pending.clear()

    with contextlib.ExitStack() as stack:
        attacker = Attacker(dep, stack)

        @settings(max_examples=n, deadline=None, derandomize=True, database=None,
                  suppress_health_check=list(HealthCheck))
        @given(cases(dep.keys.namespace))
        def one(case: Case) -> None:
            tally["cases"] += 1
            if len(sample_cases) < 50:
                sample_cases.append(asdict(case))
            if is_legitimate(case):
                tally["legitimate (not sent)"] += 1
                return
            by_kind[f"{case.role} {case.message}"] += 1
            tally["denied by the table" if not may(case.role, case.message, case.key)
                  else "granted by the table, wildcard: dropped by the service"] += 1
            try:
                attacker.send(case)
            except Exception:  # zenoh refuses the expression itself (e.g. a put on a wildcard chunk mix)
                tally["refused by zenoh's API"] += 1
            tally["sent"] += 1
            pending.append(case)
            if len(pending) >= batch:
                check()

        one()
        check()
        heard = attacker.heard
    start = time.monotonic()
    crashed = [c.name for c in dep.children.values() if c.proc.poll() is not None]
    final = snapshot(dep)  # answering afterwards: a predict, info, recorder status, worker tokens
    return {"cases": tally["cases"], "tally": dict(tally), "by_role_and_message": dict(sorted(by_kind.items())),
            "state_changes": len(changes), "changes": changes, "crashes": len(crashed), "crashed": crashed,
            "heard_by_attacker_declarations": heard, "final_state": final,
            "final_check_seconds": round(time.monotonic() - start, 3), "sample_cases": sample_cases}
