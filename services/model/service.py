"""The model service: serves CNMP skills over zenoh and hot-swaps the weights the learner publishes.

Declared entities (``<ns>`` the namespace, ``<skill>`` a skill name):

- queryables ``acnmp/<ns>/skill/*/predict``, ``acnmp/<ns>/skill/*/transfer`` (paired skills) and
  ``acnmp/<ns>/skill/*/info`` (``complete=False``),
  dispatching on the skill chunk of the query's key: a query for a skill with no model gets
  ``unknown_skill`` instead of silence. One wildcard queryable per operation rather than one per
  skill, because zenoh hands a query to *every* matching queryable of a session: a per-skill
  queryable next to a catch-all would run every predict twice. With several
  model processes, each answers; :class:`clients.client.ACNMPClient` takes the successful reply;
- queryable ``acnmp/<ns>/skill/*/predict/<zid>``: the same predicts, for this process alone. Zenoh
  gives a query on the skill's key to every model process (each computes it:
  benchmarks/results/bench_predict_routed.json), so a client that sees several processes serving a
  skill sends each predict to one of them here, and they share the work;
- subscriber ``acnmp/<ns>/skill/<skill|*>/weights`` (weights messages, services/model/weights.py);
- liveliness tokens ``acnmp/<ns>/service/model/<zid>`` (the process, once its queryables exist)
  and ``acnmp/<ns>/model/<skill>`` plus ``acnmp/<ns>/model/<skill>/<zid>`` (per skill, once it has
  a model: the skill is served, and by this process).

At start-up, and again every few seconds while a skill it should serve has no model, it queries
``acnmp/<ns>/skill/<skill|*>/weights/latest``; and for every served skill whenever a learner's
liveliness token appears (again): after its link to the router was cut and came back, the weights
put meanwhile are fetched. Weights can also come from checkpoint files.
Weights are decoded and the model built on one loader thread, then swapped in under a lock
(services/model/handlers.py): queries in flight finish on the old model, versions only increase.
"""
from __future__ import annotations

import logging
import queue
import threading
from dataclasses import dataclass
from pathlib import Path
from typing import Sequence

import zenoh

from acnmp_core.model.checkpoint import load_checkpoint
from services.transport import Keyspace, Ready, declare_rpc, wait_until_stopped
from services.transport.auth import authenticated_user
from services.transport.heap import Trimmer, map_large_blocks
from services.transport.keys import check_name, is_concrete, skill_from_key
from services.transport.wire import WireError

from .batching import PredictBatcher
from .config import DEFAULT_BATCH_MAX, DEFAULT_BATCH_WINDOW, MAX_QUEUE, ModelOptions
from .handlers import ModelRegistry, SkillModel, handle_info, handle_predict, handle_transfer, prepare_predict
from .weights import decode_weights

log = logging.getLogger(__name__)

#: Seconds between ``weights/latest`` queries while a skill still has no model.
LATEST_POLL = 2.0
#: Seconds a predict query without a ``timeout`` parameter may wait in the queue before it is dropped.
DEFAULT_QUERY_TIMEOUT = 30.0


def _skill_of(query: zenoh.Query) -> str:
    try:
        return skill_from_key(str(query.key_expr))
    except ValueError as exc:
        raise WireError("bad_request", str(exc)) from None


class ModelService:
    """The model service's zenoh side on an open ``session``; :meth:`close` undeclares everything.

    Parameters
    ----------
    session : an open zenoh session (the caller closes it after :meth:`close`).
    namespace : deployment namespace.
    skills : serve only these skills; None serves every skill whose weights appear.
    workers : threads answering predicts with batching off (zenoh's own threads are never held by a
        predict). With batching on, the ``batch_threads`` batcher threads prepare and compute them.
    fetch_latest : query ``weights/latest`` at start and while skills are missing.
    max_queue : predict queries waiting for a thread before more are answered ``overloaded``; a
        waiting query whose timeout has passed is dropped without being computed.
    weights_source : what ``info`` says for weights that came over zenoh: ``learner`` where the
        deployment's ACL lets only the learner put them, ``unauthenticated`` where anyone could.
    batch_max : concurrent single predicts of one skill model run in one forward pass, at most this
        many (services/model/batching.py); 1 turns batching off (each computed on its handler thread).
    batch_window : seconds the batcher thread waits for more predicts after the first of a round.
    batch_threads : batcher threads (default 1); each takes the predicts waiting and computes them.
        More than one only fight over the GIL on 2 cores (mode ``threads2`` of
        benchmarks/results/bench_predict.json).
    device : where the served networks run (``cpu``, ``cuda``, ``auto``; acnmp_core/model/device.py): each
        model is moved there once, when it is swapped in; ValueError for a device not present.
    """

    def __init__(self, session: zenoh.Session, namespace: str = "default", *,
                 skills: Sequence[str] | None = None, workers: int = 2, fetch_latest: bool = True,
                 max_queue: int = MAX_QUEUE, weights_source: str = "learner",
                 batch_max: int = DEFAULT_BATCH_MAX, batch_window: float = DEFAULT_BATCH_WINDOW,
                 batch_threads: int = 1, device: str = "cpu"):
        from acnmp_core.model.device import resolve_device

        self.device = resolve_device(device)
        self.session = session
        self.weights_source = weights_source
        self.keys = Keyspace(namespace)
        self.registry = ModelRegistry(None if skills is None else [check_name("skill", s) for s in skills])
        self._lock = threading.Lock()
        self._tokens: dict[str, list] = {}  # skill -> its liveliness tokens (kept referenced: GC undeclares)
        self._inbox: queue.Queue = queue.Queue()
        self._stop = threading.Event()
        self.swaps = 0
        self.rejected = 0
        sub_skills = ["*"] if skills is None else list(self.registry.allowed)
        if batch_max < 1:
            raise ValueError(f"--batch-max: expected >= 1 (1 turns batching off), got {batch_max}")
        if not batch_window >= 0:
            raise ValueError(f"--batch-window: expected >= 0 seconds, got {batch_window}")
        self.batcher = (PredictBatcher(batch_max, batch_window, max_pending=max_queue, threads=batch_threads)
                        if batch_max > 1 else None)
        self._subs = [session.declare_subscriber(self.keys.weights(s), self._on_weights) for s in sub_skills]
        # complete=False: this process does not claim to serve every skill name, so a wildcard or
        # unknown-skill query still reaches the other model processes. One predict RPC serves two
        # keys: the skill's, which every model process answers, and this process's own (predict_at),
        # on which a client shares its predicts between processes; both share the handler threads and
        # the queue bound (--workers and --max-queue are the process's, whichever key a client asks on)
        self.zid = str(session.zid())
        # what a large predict or weights message left behind goes back to the system once answered
        self.trimmer = Trimmer().start()
        predict_keys = (self.keys.predict("*"), self.keys.predict_at("*", self.zid))
        if self.batcher is None:  # each predict decoded, checked and computed on a handler thread
            predict = declare_rpc(session, predict_keys,
                                  lambda req, q: handle_predict(self.registry, _skill_of(q), req),
                                  workers=workers, complete=False, max_queue=max_queue,
                                  default_timeout=DEFAULT_QUERY_TIMEOUT, on_payload=self.trimmer.note)
        else:  # zenoh's thread only queues the query: the batcher's threads decode, check and compute
            predict = declare_rpc(session, predict_keys, self._submit_predict, workers=0, complete=False,
                                  decode_payload=False, default_timeout=DEFAULT_QUERY_TIMEOUT, pass_deadline=True,
                                  on_payload=self.trimmer.note)
        self._predict_rpc = predict
        self._rpcs = [
            predict,
            # a transfer is a predict through two models: the same queue bound and deadline, no batching
            declare_rpc(session, self.keys.transfer("*"),
                        lambda req, q: handle_transfer(self.registry, _skill_of(q), req),
                        workers=1, complete=False, max_queue=max_queue, default_timeout=DEFAULT_QUERY_TIMEOUT,
                        on_payload=self.trimmer.note),
            declare_rpc(session, self.keys.info("*"),
                        lambda req, q: handle_info(self.registry, _skill_of(q), req),
                        workers=1, complete=False, on_payload=self.trimmer.note),
        ]
        self._loader = threading.Thread(target=self._load_loop, name="model-loader", daemon=True)
        self._loader.start()
        self._fetcher, self._learners = None, None
        # a learner's token seen (again): at start, and when this process's link to the router comes
        # back after a cut (weights put meanwhile never reached it): ask every skill's latest weights
        self._learner_seen = threading.Event()
        if fetch_latest:
            self._learners = session.liveliness().declare_subscriber(
                self.keys.tokens("learner"), self._on_learner, history=True)
            self._fetcher = threading.Thread(target=self._fetch_loop, name="model-fetch", daemon=True)
            self._fetcher.start()
        self.token_key = self.keys.model_service_token(str(session.zid()))
        self._token = session.liveliness().declare_token(self.token_key)

    @property
    def predicts_answered(self) -> int:
        """Predicts this process has computed and answered, on either of its predict keys."""
        return self._predict_rpc.served

    def _submit_predict(self, _request, query: zenoh.Query, deadline: float | None):
        # on zenoh's callback thread: nothing but the skill's name is looked at here
        skill = _skill_of(query)
        return self.batcher.submit(
            lambda: prepare_predict(self.registry, skill, self._predict_rpc.decode_request(query)), deadline)

    # ----- loading ---------------------------------------------------------------------------
    def _on_weights(self, sample: zenoh.Sample) -> None:
        # zenoh thread: only queue the bytes; decoding and building happen on the loader thread.
        # A put on a wildcard (acnmp/NS/**) is nobody's weights: dropped and counted
        if not is_concrete(sample.key_expr):
            self.rejected += 1
            return
        self.trimmer.note(len(sample.payload))
        self._inbox.put(("bytes", sample.payload.to_bytes(), str(sample.key_expr)))

    def _load_loop(self) -> None:
        while not self._stop.is_set():
            try:
                kind, payload, origin = self._inbox.get(timeout=0.2)
            except queue.Empty:
                continue
            if kind == "stop":
                return
            try:
                w = decode_weights(payload)
                if origin not in (self.keys.weights(w.skill), self.keys.weights_latest(w.skill)):
                    # the key names the skill the message carries
                    raise WireError("bad_request", f"weights of skill {w.skill!r} put on {origin}")
                self.load(SkillModel(w.skill, w.version, w.model, w.data_hash, w.n_demos, source=self.weights_source,
                                     partner=w.partner))
            except WireError as exc:
                self.rejected += 1
                log.warning("rejected weights from %s: %s", origin, exc)
            except Exception:  # a bad message must never kill the loader
                self.rejected += 1
                log.exception("could not load weights from %s", origin)

    def load(self, entry: SkillModel) -> bool:
        """Swap ``entry`` in if it is newer than what is served; declare the skill's liveliness token
        the first time. Returns True if it was swapped in."""
        entry.model.to_device(self.device)  # once, before any predict sees it
        if not self.registry.offer(entry):
            log.debug("ignored %s v%d (not newer or not served here)", entry.skill, entry.version)
            return False
        self.swaps += 1
        log.info("serving %s v%d (%s)", entry.skill, entry.version, entry.source)
        with self._lock:
            if entry.skill not in self._tokens and not self._stop.is_set():
                # the skill is served (by someone), and served by this process
                self._tokens[entry.skill] = [self.session.liveliness().declare_token(key) for key in (
                    self.keys.model_token(entry.skill), self.keys.model_process_token(entry.skill, self.zid))]
        return True

    def load_checkpoint(self, path: str | Path, skill: str | None = None) -> SkillModel:
        """Serve a checkpoint file (acnmp_core.model.checkpoint format). The skill name is ``skill``, else
        the checkpoint's ``meta["skill"]``, else the file stem; version from ``meta["version"]``
        (default 0). Returns the entry; raises ValueError for a bad file or name."""
        model, info = load_checkpoint(path)
        meta = info.get("meta", {})
        name = check_name("skill", skill or meta.get("skill") or Path(path).stem)
        entry = SkillModel(name, int(meta.get("version", 0)), model, info.get("data_hash", ""),
                           int(meta.get("n_demos", 0)), source=f"checkpoint:{path}")
        self.load(entry)
        return entry

    def _on_learner(self, sample: zenoh.Sample) -> None:
        if sample.kind == zenoh.SampleKind.PUT:
            self._learner_seen.set()

    def _fetch_loop(self) -> None:
        first = True
        while not self._stop.is_set():
            again = self._learner_seen.is_set()
            self._learner_seen.clear()
            wanted = self.registry.missing() if self.registry.allowed is not None else (
                ["*"] if first or not self.registry.skills() else [])
            if again:  # what is served may be behind: load() keeps only a newer version
                wanted = sorted(set(wanted) | set(self.registry.skills()))
            for skill in wanted:
                self._fetch_latest(skill)
            first = False
            self._learner_seen.wait(LATEST_POLL)

    def _fetch_latest(self, skill: str) -> None:
        key = self.keys.weights_latest(skill)
        try:
            replies = self.session.get(key, target=zenoh.QueryTarget.ALL, timeout=5.0)
            for reply in replies:
                if reply.ok is not None:
                    self._inbox.put(("bytes", reply.ok.payload.to_bytes(), str(reply.ok.key_expr)))
        except Exception as exc:  # session closing, or no learner yet: try again later
            log.debug("weights/latest query on %s failed: %s", key, exc)

    # ----- shutdown --------------------------------------------------------------------------
    def close(self) -> None:
        """Undeclare the tokens, subscribers and queryables (waiting for queries in flight); a second
        call does nothing."""
        if self._stop.is_set():
            return
        self._stop.set()
        self._learner_seen.set()  # wakes the fetcher
        self._inbox.put(("stop", b"", ""))
        if self._learners is not None:
            self._learners.undeclare()
        for t in (self._loader, self._fetcher):
            if t is not None:
                t.join(timeout=6.0)
        self._token.undeclare()
        for sub in self._subs:
            sub.undeclare()
        with self._lock:
            tokens, self._tokens = [t for pair in self._tokens.values() for t in pair], {}
        for token in tokens:
            token.undeclare()
        for rpc in self._rpcs:
            rpc.close()
        if self.batcher is not None:  # after the queryables: predicts already handed over are answered
            self.batcher.close()
        self.trimmer.close()

    def __enter__(self) -> "ModelService":
        return self

    def __exit__(self, *exc) -> None:
        self.close()


def _parse_checkpoint_arg(value: str) -> tuple[str | None, str]:
    """``FILE`` or ``SKILL=FILE`` -> (skill or None, file)."""
    if "=" in value and not Path(value).exists():
        skill, path = value.split("=", 1)
        return skill, path
    return None, value


@dataclass
class ModelConfig(ModelOptions):
    """The model service process: its options (:class:`~services.model.config.ModelOptions`) and
    :meth:`serve`, which runs it on an open session."""

    def serve(self, session: zenoh.Session, stop: threading.Event, ready: Ready) -> int:
        """Serve until ``stop``: checkpoints are loaded before ``ready`` is called."""
        import torch

        torch.set_num_threads(1)  # one predict is small; threads would only fight over the cores
        map_large_blocks()  # a flood of large predicts must not leave the process holding its buffers
        source = "learner" if authenticated_user(self.session.config) else "unauthenticated"
        with ModelService(session, self.session.namespace, skills=self.skills, workers=self.workers,
                          max_queue=self.max_queue, weights_source=source, batch_max=self.batch_max,
                          batch_window=self.batch_window, batch_threads=self.batch_threads,
                          device=self.device) as service:
            for value in self.checkpoints:
                skill, path = _parse_checkpoint_arg(value)
                try:
                    entry = service.load_checkpoint(path, skill)
                except ValueError as exc:
                    raise ValueError(f"--checkpoint {value}: {str(exc).removeprefix('path: ')}") from None
                log.info("loaded checkpoint %s as %s v%d", path, entry.skill, entry.version)
            served = ", ".join(service.registry.skills()) or "none yet"
            ready(f"model service live as {service.token_key}; skills: {served}")
            wait_until_stopped(stop)
        return 0
