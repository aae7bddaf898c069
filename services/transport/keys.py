"""Key expressions of the deployment, built in one place so no module spells them by hand.

Every key starts with ``acnmp/<namespace>/`` so several deployments can share one zenoh network
without seeing each other. A process builds one :class:`Keyspace` for its namespace and asks it for
every key. Names that become one key chunk (namespace, skill, job, worker id, robot kind) are
restricted to ``[A-Za-z0-9_.-]`` (1-64 characters): that keeps them free of the zenoh wildcards
``*``/``**``, of ``$``, ``?``, ``#`` and ``/``, and usable as Rerun entity path parts.
"""
from __future__ import annotations

import re
from dataclasses import dataclass

ROOT = "acnmp"
DEFAULT_NAMESPACE = "default"

_NAME = re.compile(r"^[A-Za-z0-9_.\-]{1,64}$")

#: Event kinds (see services/recording/events.py); each is published under ``Keyspace.event``.
EVENT_KINDS = ("rollout", "latent", "model_version", "job_progress", "process", "metrics", "job")


def check_name(kind: str, value: str) -> str:
    """Return ``value`` if it is a valid single key chunk, else raise ValueError naming ``kind``."""
    if not isinstance(value, str) or not _NAME.match(value) or value in (".", ".."):
        raise ValueError(f"{kind}: {value!r} is not a valid name (1-64 characters of A-Z a-z 0-9 _ . -)")
    return value


def _chunk(key: str, kind: str, index: int) -> str:
    """Chunk ``index`` of an ``acnmp/<ns>/<kind>/<name>/...`` key; ValueError otherwise."""
    chunks = str(key).split("/")
    if len(chunks) <= index or chunks[0] != ROOT or chunks[2] != kind:
        raise ValueError(f"key: {key!r} is not an acnmp/<ns>/{kind}/<{kind}>/... key")
    return check_name(kind, chunks[index])


def skill_from_key(key: str) -> str:
    """The ``<skill>`` chunk of any ``acnmp/<ns>/skill/<skill>/...`` key; ValueError otherwise."""
    return _chunk(key, "skill", 3)


def job_from_key(key: str) -> str:
    """The ``<job>`` chunk of an ``acnmp/<ns>/job/<job>/...`` key; ValueError otherwise."""
    return _chunk(key, "job", 3)


def is_concrete(key) -> bool:
    """Whether ``key`` (a str or zenoh KeyExpr) is one concrete key: no ``*``/``**`` chunk, no ``$*``,
    no empty chunk. A sample, query or token on anything else is never acted on (services drop
    and count it): a wildcard must not stand for a name."""
    text = str(key)
    return bool(text) and all(c and "*" not in c and "$" not in c for c in text.split("/"))


def token_id(key, pattern: str) -> str | None:
    """The last chunk of a liveliness token's ``key`` when the key is concrete, matches ``pattern``
    (one ``*`` chunk for the id, e.g. ``acnmp/ns/worker/ur10/*``) and the chunk is a valid name;
    None otherwise (a forged or wildcard token, to be ignored)."""
    text = str(key)
    want = pattern.split("/")
    got = text.split("/")
    if not is_concrete(text) or len(got) != len(want):
        return None
    if any(w != "*" and w != g for w, g in zip(want, got)):
        return None
    try:
        return check_name("id", got[-1])
    except ValueError:
        return None


def last_chunk(key: str) -> str:
    """The last chunk of a key (a worker's id in its token ``.../worker/<robot>/<id>``)."""
    return str(key).rsplit("/", 1)[-1]


@dataclass(frozen=True)
class Keyspace:
    """Every key expression of one namespace (docs/PROTOCOL.md lists them all).

    ``skill`` arguments may be ``*`` (one queryable or subscription for every skill); every
    other name is checked by :func:`check_name` (ValueError).
    """

    namespace: str = DEFAULT_NAMESPACE

    def __post_init__(self) -> None:
        check_name("namespace", self.namespace)

    @property
    def prefix(self) -> str:
        """``acnmp/<ns>``: the prefix of every key of this namespace."""
        return f"{ROOT}/{self.namespace}"

    # ----- skills: model service and learner ------------------------------------------------
    def skill(self, skill: str, *parts: str) -> str:
        """``acnmp/<ns>/skill/<skill>/<parts...>``."""
        name = skill if skill == "*" else check_name("skill", skill)
        return "/".join([self.prefix, "skill", name, *(check_name("key part", p) for p in parts)])

    def predict(self, skill: str) -> str:
        """``.../skill/<skill>/predict``: the model service's predict queryable."""
        return self.skill(skill, "predict")

    def predict_at(self, skill: str, zid: str) -> str:
        """``.../skill/<skill>/predict/<zid>``: the predict queryable of one model process (``zid``
        its zenoh id, or ``*``), which a client uses to share predicts between several processes."""
        return f"{self.predict(skill)}/{zid if zid == '*' else check_name('zid', zid)}"

    def info(self, skill: str) -> str:
        """``.../skill/<skill>/info``: the model service's info queryable."""
        return self.skill(skill, "info")

    def transfer(self, skill: str) -> str:
        """``.../skill/<skill>/transfer``: the model service's transfer queryable (paired skills)."""
        return self.skill(skill, "transfer")

    def weights(self, skill: str) -> str:
        """``.../skill/<skill>/weights``: where the learner puts each new weights version."""
        return self.skill(skill, "weights")

    def weights_latest(self, skill: str) -> str:
        """``.../skill/<skill>/weights/latest``: the learner's queryable for the newest weights."""
        return self.skill(skill, "weights", "latest")

    def train(self, skill: str) -> str:
        """``.../skill/<skill>/train``: the learner's queryable that trains a skill from demos."""
        return self.skill(skill, "train")

    def train_pair(self, skill: str) -> str:
        """``.../skill/<skill>/train_pair``: the learner's queryable that queues a paired skill's training."""
        return self.skill(skill, "train_pair")

    def adapt(self, skill: str) -> str:
        """``.../skill/<skill>/adapt``: the learner's queryable that queues an adaptation job."""
        return self.skill(skill, "adapt")

    def job_status(self, job: str = "*") -> str:
        """``.../job/<job>/status``: a job's status queryable (``*``: the learner's, for every job)."""
        name = job if job == "*" else check_name("job", job)
        return f"{self.prefix}/job/{name}/status"

    def jobs(self) -> str:
        """``.../jobs``: the learner's queryable listing its jobs, newest first."""
        return f"{self.prefix}/jobs"

    def job_cancel(self, job: str = "*") -> str:
        """``.../job/<job>/cancel``: cancel a job (``*``: the learner's queryable, for every job)."""
        name = job if job == "*" else check_name("job", job)
        return f"{self.prefix}/job/{name}/cancel"

    # ----- liveliness tokens ------------------------------------------------------------------
    def token(self, service: str, *parts: str) -> str:
        """``acnmp/<ns>/<service>/<parts...>``: a liveliness token of a running process."""
        return "/".join([self.prefix, check_name("service", service), *(check_name("key part", p) for p in parts)])

    def tokens(self, service: str) -> str:
        """``acnmp/<ns>/<service>/**``: every token of that service."""
        return f"{self.prefix}/{check_name('service', service)}/**"

    def model_token(self, skill: str = "*") -> str:
        """``.../model/<skill>``: a model service has weights for ``skill`` (``*``: any skill)."""
        return f"{self.prefix}/model/{skill if skill == '*' else check_name('skill', skill)}"

    def model_process_token(self, skill: str = "*", zid: str = "*") -> str:
        """``.../model/<skill>/<zid>``: the model process ``zid`` serves ``skill`` (``*``: any)."""
        return "/".join([self.model_token(skill), zid if zid == "*" else check_name("zid", zid)])

    def model_service_token(self, zid: str = "*") -> str:
        """``.../service/model/<zid>``: a model process is live (with or without skills loaded)."""
        return f"{self.prefix}/service/model/{zid if zid == '*' else check_name('zid', zid)}"

    def learner_token(self, learner_id: str = "*") -> str:
        """``.../learner/<id>``: a learner is live (``*``: any learner)."""
        return f"{self.prefix}/learner/*" if learner_id == "*" else self.token("learner", learner_id)

    def recorder_token(self, zid: str) -> str:
        """``.../recorder/<zid>``: a recorder is live (its subscriber exists)."""
        return self.token("recorder", zid)

    def recorder_status(self) -> str:
        """``.../recorder/status``: the recorder's status queryable."""
        return f"{self.prefix}/recorder/status"

    def router_token(self, zid: str) -> str:
        """``.../router/<zid>``: a router started with a namespace is live."""
        return self.token("router", zid)

    # ----- processes ----------------------------------------------------------------------------
    def process(self, service: str, zid: str) -> str:
        """``.../process/<service>/<zid>``: the ``about`` queryable of one process (services/transport/about.py)."""
        return f"{self.prefix}/process/{check_name('service', service)}/{check_name('zid', zid)}"

    def processes(self) -> str:
        """``.../process/**``: what ``acnmp status`` asks to learn every process's host."""
        return f"{self.prefix}/process/**"

    # ----- workers ------------------------------------------------------------------------------
    def worker_token(self, robot: str, worker_id: str = "*") -> str:
        """``.../worker/<robot>/<id>``: a worker of robot kind ``robot`` (``*``: every one)."""
        name = worker_id if worker_id == "*" else check_name("worker id", worker_id)
        return f"{self.prefix}/worker/{check_name('robot', robot)}/{name}"

    def worker_rollout(self, robot: str, worker_id: str) -> str:
        """``.../worker/<robot>/<id>/rollout``: a worker's roll-out queryable."""
        return f"{self.worker_token(robot, check_name('worker id', worker_id))}/rollout"

    # ----- events -----------------------------------------------------------------------------
    def event(self, kind: str, ident: str) -> str:
        """``.../event/<kind>/<ident>``: where one event is published (``ident``: the job id for
        rollout and job_progress events, the skill for latent and model_version events, the
        process name for process events)."""
        if kind not in EVENT_KINDS:
            raise ValueError(f"event kind {kind!r} is not one of {EVENT_KINDS}")
        return f"{self.prefix}/event/{kind}/{check_name('event id', ident)}"

    def events(self) -> str:
        """``.../event/**``: what the recorder subscribes to."""
        return f"{self.prefix}/event/**"
