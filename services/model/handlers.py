"""The model service's logic without zenoh: a registry of hot-swappable skill models and the
predict/info/transfer request handlers (decoded request map in, reply map out, :class:`WireError`
on bad input).

services/model/service.py wires these to zenoh queryables; tests and benchmarks call them in-process.
"""
from __future__ import annotations

import threading
import time
from dataclasses import dataclass, field as dc_field, replace
from typing import Iterable

import numpy as np
import torch

from acnmp_core.model.cnmp import CNMP, Prediction, Query
from acnmp_core.transfer.pair import TransferPair, TransferredSkill
from services.transport.errors import wire_error
from services.transport.wire import DEFAULT_MAX_BYTES, WireError, array_field, field, require_payload

#: Bounds on one predict request (absurd sizes get ``too_large``, never a stalled service).
MAX_OBS = 4096            # observations N
MAX_QUERY_STEPS = 20_000  # query times T
MAX_SAMPLES = 1000        # samples S
MAX_SAMPLE_VALUES = 4_000_000  # S * T * D, summed over the requests of one query
MAX_BATCH = 64            # requests in one batched query
MAX_BATCH_POINTS = 100_000  # N + T summed over the requests of one query (about 4 of the largest)
MAX_REPLY_BYTES = DEFAULT_MAX_BYTES  # estimated size of one reply, checked before computing it
REPLY_OVERHEAD = 512      # bytes per reply item besides its arrays' data (keys, headers), estimated


@dataclass
class SkillModel:
    """One served model: the CNMP (eval mode, never mutated once served) and its provenance.

    A paired skill's ``model`` is robot A's CNMP (predict answers with it) and ``partner`` robot
    B's (transfer answers with A's encoder and B's decoder).
    """

    skill: str
    version: int
    model: CNMP
    data_hash: str = ""
    n_demos: int = 0
    source: str = "learner"
    loaded_at: float = dc_field(default_factory=time.time)
    partner: CNMP | None = None


class ModelRegistry:
    """Skill name -> :class:`SkillModel`, swapped atomically.

    A handler takes the current entry once (:meth:`get`) and runs on it to the end, so a swap
    while a query is in flight never fails it: the old model answers that query, the next one
    gets the new model. Entries are built completely before :meth:`offer` swaps the reference.

    Parameters
    ----------
    skills : names this registry is restricted to; None serves any skill that is offered.
    """

    def __init__(self, skills: Iterable[str] | None = None):
        self._lock = threading.Lock()
        self._models: dict[str, SkillModel] = {}
        self.allowed: frozenset[str] | None = None if skills is None else frozenset(skills)

    def accepts(self, skill: str) -> bool:
        """True if ``skill`` may be served here (always, when not restricted)."""
        return self.allowed is None or skill in self.allowed

    def offer(self, entry: SkillModel) -> bool:
        """Serve ``entry`` if its skill is accepted and its version is newer than the one served.

        Returns True if it was swapped in. Stale or repeated versions (e.g. a ``weights/latest``
        reply arriving after a newer publication) are ignored, so versions only increase.
        """
        if not self.accepts(entry.skill):
            return False
        with self._lock:
            current = self._models.get(entry.skill)
            if current is not None and entry.version <= current.version:
                return False
            self._models[entry.skill] = entry
            return True

    def get(self, skill: str) -> SkillModel:
        """The entry serving ``skill``; WireError ``unknown_skill`` if there is none (yet)."""
        with self._lock:
            entry = self._models.get(skill)
        if entry is None:
            if self.accepts(skill) and self.allowed is not None:
                raise WireError("unknown_skill", f"skill {skill!r} has no model yet (waiting for weights from the learner)")
            served = ", ".join(self.skills()) or "none"
            raise WireError("unknown_skill", f"no model for skill {skill!r} here (served: {served})")
        return entry

    def skills(self) -> list[str]:
        """Sorted names of the skills that have a model now."""
        with self._lock:
            return sorted(self._models)

    def missing(self) -> list[str]:
        """Sorted names of the restricted skills that still have no model (empty if unrestricted)."""
        if self.allowed is None:
            return []
        with self._lock:
            return sorted(self.allowed - set(self._models))


# --------------------------------------------------------------------------------------------
# predict


def _int_field(msg: dict, key: str, lo: int, hi: int, default=None):
    """An optional int field within [lo, hi]; ``too_large`` above ``hi``, ``bad_request`` below ``lo``."""
    value = field(msg, key, int, default=default)
    if value is None:
        return None
    if value > hi:
        raise WireError("too_large", f"field '{key}': {value}, at most {hi}")
    if value < lo:
        raise WireError("bad_request", f"field '{key}': must be >= {lo}, got {value}")
    return value


@dataclass(frozen=True)
class PredictItem:
    """One predict request, checked but not computed: its arrays and what answering it costs.

    ``n_obs`` N, ``n_query`` T, ``n_samples`` S; :meth:`reply_values` is the number of float64
    values its reply will carry, known before any forward pass.
    """

    obs_times: np.ndarray
    obs_values: np.ndarray
    obs_dims_mask: np.ndarray | None
    task_params: np.ndarray | None
    query_times: np.ndarray | None
    n_steps: int | None
    n_samples: int
    seed: int | None

    @property
    def n_obs(self) -> int:
        return int(self.obs_times.shape[0])

    @property
    def n_query(self) -> int:
        return int(self.query_times.shape[0]) if self.query_times is not None else int(self.n_steps)

    def reply_values(self, n_outputs: int, latent_dim: int) -> int:
        """Values of the reply: times T, mean and std T*D each, latent L, samples S*T*D."""
        t = self.n_query
        return t + 2 * t * n_outputs + latent_dim + self.n_samples * t * n_outputs


def parse_predict(entry: SkillModel, request: dict) -> PredictItem:
    """Check one predict request (decoded map) against ``entry``'s model without computing it.

    Request: ``obs_times`` (N,), ``obs_values`` (N, D), optional ``obs_dims_mask`` (N, D) bool,
    optional ``task_params`` (P,), ``query_times`` (T,) or ``n_steps`` int, optional
    ``n_samples`` int with optional ``seed`` int >= 0. Raises WireError (bad_request, bad_shape,
    bad_dtype, non_finite, too_large).
    """
    if not isinstance(request, dict):
        raise WireError("bad_request", "a predict request must be a map")
    cfg = entry.model.config
    d, p = cfg.n_outputs, cfg.n_task_params
    obs_times = array_field(request, "obs_times", ndim=1, kinds="fi", max_elements=MAX_OBS)
    obs_values = array_field(request, "obs_values", shape=(obs_times.shape[0], d), kinds="fi")
    dims = array_field(request, "obs_dims_mask", shape=obs_values.shape, kinds="b", default=None)
    task_params = array_field(request, "task_params", shape=(p,), kinds="fi", default=None)
    query_times = array_field(request, "query_times", ndim=1, kinds="fi", default=None,
                              max_elements=MAX_QUERY_STEPS)
    n_steps = _int_field(request, "n_steps", 2, MAX_QUERY_STEPS)
    if query_times is not None and n_steps is not None:
        raise WireError("bad_request", "give either 'query_times' or 'n_steps', not both")
    if query_times is None and n_steps is None:
        raise WireError("bad_request", "give 'query_times' or 'n_steps'")
    n_samples = _int_field(request, "n_samples", 0, MAX_SAMPLES) or 0
    seed = field(request, "seed", int, default=None)
    if seed is not None and seed < 0:
        raise WireError("bad_request", f"field 'seed': must be >= 0, got {seed}")
    item = PredictItem(obs_times, obs_values, dims, task_params, query_times, n_steps, n_samples, seed)
    if n_samples * item.n_query * d > MAX_SAMPLE_VALUES:
        raise WireError("too_large", f"{n_samples} samples of ({item.n_query}, {d}) exceed {MAX_SAMPLE_VALUES} values")
    return item


def check_cost(entry: SkillModel, items: list[PredictItem]) -> None:
    """Refuse a request whose total cost is over the bounds, before any forward pass.

    Summed over every item of a batch: points through the network (N + T each) at most
    :data:`MAX_BATCH_POINTS`, sampled values (S*T*D) at most :data:`MAX_SAMPLE_VALUES`, and the
    reply's estimated size (8 bytes per value plus :data:`REPLY_OVERHEAD` per item) at most
    :data:`MAX_REPLY_BYTES`. Raises WireError ``too_large``.
    """
    cfg = entry.model.config
    points = sum(it.n_obs + it.n_query for it in items)
    if points > MAX_BATCH_POINTS:
        raise WireError("too_large", f"{len(items)} request(s) ask for {points} observation and query points in all, "
                                     f"at most {MAX_BATCH_POINTS}")
    samples = sum(it.n_samples * it.n_query * cfg.n_outputs for it in items)
    if samples > MAX_SAMPLE_VALUES:
        raise WireError("too_large", f"{len(items)} request(s) ask for {samples} sampled values in all, "
                                     f"at most {MAX_SAMPLE_VALUES}")
    reply = sum(8 * it.reply_values(cfg.n_outputs, cfg.latent_dim) + REPLY_OVERHEAD for it in items)
    if reply > MAX_REPLY_BYTES:
        raise WireError("too_large", f"the reply would be about {reply} bytes, at most {MAX_REPLY_BYTES}")


def item_query(entry: SkillModel, item: PredictItem) -> Query:
    """The network inputs of a checked request (times checked against the model's trained range);
    WireError (``bad_request`` or the code of a typed input error) on a request the model refuses."""
    try:
        return entry.model.make_query(item.obs_times, item.obs_values, item.task_params, item.query_times,
                                      n_steps=item.n_steps, obs_dims_mask=item.obs_dims_mask)
    except ValueError as exc:  # every ValueError of make_query is about the request; typed ones carry their code
        raise wire_error(exc, default="bad_request") from None


def predict_reply(entry: SkillModel, item: PredictItem, pred: Prediction) -> dict:
    """The reply to ``item`` from its prediction: ``{"v", "skill", "version", "times" (T,),
    "mean" (T, D), "std" (T, D), "latent" (L,)}`` in raw units (float64), plus ``"samples"``
    (S, T, D) drawn independently per step from N(mean, std^2) with the item's seed when S > 0."""
    reply = {"v": 1, "skill": entry.skill, "version": entry.version, "times": pred.times,
             "mean": pred.mean, "std": pred.std, "latent": pred.latent}
    if item.n_samples:
        rng = np.random.default_rng(item.seed)
        reply["samples"] = pred.mean + pred.std * rng.standard_normal((item.n_samples, *pred.mean.shape))
    return reply


def run_predict(entry: SkillModel, item: PredictItem) -> dict:
    """Answer a checked request with ``entry``'s model alone (one forward pass): the reply of
    :func:`predict_reply`."""
    return predict_reply(entry, item, entry.model.predict_query(item_query(entry, item)))


_thread_state = threading.local()


def pin_threads() -> None:
    """Give this thread the process's torch thread count.

    MKL keeps its thread count per OS thread: a fresh handler thread would use every core, and a
    different summation order changes float32 results in the last bits. Re-applying the process
    setting makes a predict over zenoh equal the in-process one exactly.
    """
    if not getattr(_thread_state, "pinned", False):
        torch.set_num_threads(torch.get_num_threads())
        _thread_state.pinned = True


@dataclass
class PreparedPredict:
    """A single predict request checked and turned into network inputs, ready for a forward pass
    (alone or batched with others of the same ``entry``)."""

    entry: SkillModel
    item: PredictItem
    query: Query

    @property
    def points(self) -> int:
        """Observation plus query points (N + T): what the pass's cost grows with."""
        return self.item.n_obs + self.item.n_query


def prepare_predict(registry: ModelRegistry, skill: str, request) -> PreparedPredict | dict:
    """Check a predict query for ``skill`` (decoded map) without a forward pass.

    A single request comes back as a :class:`PreparedPredict` (its entry taken now, so the version
    it will be computed with); ``{"batch": [request, ...]}`` is answered here, item by item (each
    equals its single predict bit for bit), as the reply map ``{"v", "skill", "version",
    "results": [single reply, ...]}`` (a bad item fails the whole batch, its index in the message).
    Raises WireError (every code of :func:`parse_predict`, ``unknown_skill``, ``bad_request``).
    """
    request = require_payload(request, "a predict request (obs_times, obs_values, ...)")
    entry = registry.get(skill)
    pin_threads()
    if "batch" not in request:
        item = parse_predict(entry, request)
        check_cost(entry, [item])
        return PreparedPredict(entry, item, item_query(entry, item))
    batch = field(request, "batch", list)
    if not batch:
        raise WireError("bad_request", "field 'batch': empty")
    if len(batch) > MAX_BATCH:
        raise WireError("too_large", f"field 'batch': {len(batch)} requests, at most {MAX_BATCH}")
    items = []
    for i, raw in enumerate(batch):  # every item checked before any is computed
        try:
            items.append(parse_predict(entry, raw))
        except WireError as exc:
            raise WireError(exc.code, f"batch[{i}]: {exc.message}") from None
    check_cost(entry, items)
    results = []
    for i, item in enumerate(items):
        try:
            results.append(run_predict(entry, item))
        except WireError as exc:
            raise WireError(exc.code, f"batch[{i}]: {exc.message}") from None
    return {"v": 1, "skill": entry.skill, "version": entry.version, "results": results}


def handle_predict(registry: ModelRegistry, skill: str, request) -> dict:
    """Answer a predict query for ``skill`` on this thread: a single request or
    ``{"batch": [request, ...]}`` (see :func:`prepare_predict`); returns the reply map. The model
    service's batched path (services/model/batching.py) runs :func:`prepare_predict` on its own
    threads instead and computes single requests of one model together."""
    prepared = prepare_predict(registry, skill, request)
    if isinstance(prepared, dict):
        return prepared
    return predict_reply(prepared.entry, prepared.item, prepared.entry.model.predict_query(prepared.query))


# --------------------------------------------------------------------------------------------
# transfer


def transfer_view(entry: SkillModel) -> SkillModel:
    """``entry`` with its model replaced by A's encoder -> B's decoder
    (:class:`~acnmp_core.transfer.pair.TransferredSkill`, which has the CNMP's ``config`` of robot B,
    ``make_query`` and ``predict_query``), so the predict path's cost check and computation run on
    it unchanged. WireError ``bad_request`` for a skill that is not a paired skill."""
    if entry.partner is None:
        raise WireError("bad_request", f"skill {entry.skill!r} is not a paired skill (train it with train_pair); "
                                       "use predict")
    return replace(entry, model=TransferredSkill(TransferPair.from_models(entry.model, entry.partner)))


def handle_transfer(registry: ModelRegistry, skill: str, request) -> dict:
    """Answer a transfer query for paired skill ``skill``: robot A's observations in, robot B's
    trajectory out.

    The request is a single predict request (docs/PROTOCOL.md) whose ``obs_values`` are robot A's,
    (N, D_A), without ``task_params``; it is checked by :func:`parse_predict` against robot A's
    model and its cost by :func:`check_cost` against robot B's outputs. The reply is a predict
    reply: ``times`` (T,), ``mean``/``std`` (T, D_B) robot B's raw units, ``latent`` (L,) the
    latent A's encoder gave, ``samples`` when asked. Equals
    :meth:`acnmp_core.transfer.pair.TransferPair.transfer` on the same weights. Raises WireError.
    """
    request = require_payload(request, "a transfer request (obs_times, obs_values of robot A, ...)")
    if "batch" in request:
        raise WireError("bad_request", "field 'batch': a transfer query takes one request")
    entry = registry.get(skill)
    view = transfer_view(entry)
    pin_threads()
    item = parse_predict(entry, request)  # robot A's observations
    check_cost(view, [item])              # robot B's reply
    return run_predict(view, item)


# --------------------------------------------------------------------------------------------
# info


def info_reply(entry: SkillModel) -> dict:
    """Describe a served model: dimensions, names, ranges (raw units, from the model's normalisers),
    version and training-data summary. Plain types and small float64 arrays only."""
    model, cfg = entry.model, entry.model.config
    t_lo, t_hi = model.time_range()
    p_lo, p_hi = model.task_norm.range_np()
    v_lo, v_hi = model.value_norm.range_np()
    return {
        "v": 1, "skill": entry.skill, "version": entry.version,
        "n_outputs": cfg.n_outputs, "n_task_params": cfg.n_task_params, "latent_dim": cfg.latent_dim,
        "output_names": list(cfg.output_names), "task_param_names": list(cfg.task_param_names),
        "time_range": [t_lo, t_hi],
        "task_param_low": p_lo.astype(np.float64), "task_param_high": p_hi.astype(np.float64),
        "value_low": v_lo.astype(np.float64), "value_high": v_hi.astype(np.float64),
        "data_hash": entry.data_hash, "n_demos": entry.n_demos,
        "source": entry.source, "loaded_at": float(entry.loaded_at),
        "config": cfg.to_dict(),
        "partner": None if entry.partner is None else _partner_info(entry.partner),
    }


def _partner_info(model: CNMP) -> dict:
    """What a transfer query answers with: robot B's ``n_outputs``, ``output_names``, value range."""
    v_lo, v_hi = model.value_norm.range_np()
    return {"n_outputs": model.config.n_outputs, "output_names": list(model.config.output_names),
            "value_low": v_lo.astype(np.float64), "value_high": v_hi.astype(np.float64)}


def handle_info(registry: ModelRegistry, skill: str, _request=None) -> dict:
    """Answer an info query for ``skill`` (payload ignored); WireError ``unknown_skill`` if none."""
    return info_reply(registry.get(skill))
