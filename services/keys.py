"""Key expressions of the deployment, built in one place so no module spells them by hand.

Every key starts with ``acnmp/<namespace>/`` so several deployments can share one zenoh network
without seeing each other. Names that become one key chunk (namespace, skill, job, worker id,
robot kind) are restricted to ``[A-Za-z0-9_.-]`` (1-64 characters): that keeps them free of the
zenoh wildcards ``*``/``**``, of ``$``, ``?``, ``#`` and ``/``, and usable as Rerun entity path parts.
"""
from __future__ import annotations

import re

ROOT = "acnmp"
DEFAULT_NAMESPACE = "default"

_NAME = re.compile(r"^[A-Za-z0-9_.\-]{1,64}$")

#: Event kinds (see services/events.py); each is published under event_key(ns, kind, ident).
EVENT_KINDS = ("rollout", "latent", "model_version", "job_progress")


def check_name(kind: str, value: str) -> str:
    """Return ``value`` if it is a valid single key chunk, else raise ValueError naming ``kind``."""
    if not isinstance(value, str) or not _NAME.match(value) or value in (".", ".."):
        raise ValueError(f"{kind}: {value!r} is not a valid name (1-64 characters of A-Z a-z 0-9 _ . -)")
    return value


def prefix(ns: str) -> str:
    """``acnmp/<ns>``: the prefix of every key of namespace ``ns``."""
    return f"{ROOT}/{check_name('namespace', ns)}"


def event_key(ns: str, kind: str, ident: str) -> str:
    """``acnmp/<ns>/event/<kind>/<ident>``: where one event is published.

    ``ident`` is the job id for rollout and job_progress events, the skill name for latent and
    model_version events.
    """
    if kind not in EVENT_KINDS:
        raise ValueError(f"event kind {kind!r} is not one of {EVENT_KINDS}")
    return f"{prefix(ns)}/event/{kind}/{check_name('event id', ident)}"


def event_subscription(ns: str) -> str:
    """``acnmp/<ns>/event/**``: what the recorder subscribes to."""
    return f"{prefix(ns)}/event/**"


def liveliness_key(ns: str, service: str, *parts: str) -> str:
    """``acnmp/<ns>/<service>/<parts...>``: a liveliness token of a running process.

    For example ``liveliness_key(ns, "worker", "planar3", "w0")`` or
    ``liveliness_key(ns, "recorder", zid)``.
    """
    chunks = [check_name("service", service)] + [check_name("key part", p) for p in parts]
    return "/".join([prefix(ns), *chunks])


def liveliness_pattern(ns: str, service: str) -> str:
    """``acnmp/<ns>/<service>/**``: matches every token of that service."""
    return f"{prefix(ns)}/{check_name('service', service)}/**"


def recorder_status_key(ns: str) -> str:
    """``acnmp/<ns>/recorder/status``: the recorder's status queryable."""
    return f"{prefix(ns)}/recorder/status"


# --- model service ---


def skill_key(ns: str, skill: str, *parts: str) -> str:
    """``acnmp/<ns>/skill/<skill>/<parts...>``; ``skill`` may be ``*`` for a subscription/catch-all."""
    name = skill if skill == "*" else check_name("skill", skill)
    return "/".join([prefix(ns), "skill", name, *parts])


def skill_predict_key(ns: str, skill: str) -> str:
    """``acnmp/<ns>/skill/<skill>/predict``: the model service's predict queryable."""
    return skill_key(ns, skill, "predict")


def skill_info_key(ns: str, skill: str) -> str:
    """``acnmp/<ns>/skill/<skill>/info``: the model service's info queryable."""
    return skill_key(ns, skill, "info")


def skill_weights_key(ns: str, skill: str) -> str:
    """``acnmp/<ns>/skill/<skill>/weights``: where the learner puts each new weights version."""
    return skill_key(ns, skill, "weights")


def skill_weights_latest_key(ns: str, skill: str) -> str:
    """``acnmp/<ns>/skill/<skill>/weights/latest``: the learner's queryable for the newest weights."""
    return skill_key(ns, skill, "weights", "latest")


def skill_from_key(key: str) -> str:
    """The ``<skill>`` chunk of any ``acnmp/<ns>/skill/<skill>/...`` key; ValueError otherwise."""
    chunks = str(key).split("/")
    if len(chunks) < 4 or chunks[0] != ROOT or chunks[2] != "skill":
        raise ValueError(f"key: {key!r} is not an acnmp/<ns>/skill/<skill>/... key")
    return check_name("skill", chunks[3])


def model_token_key(ns: str, skill: str) -> str:
    """``acnmp/<ns>/model/<skill>``: liveliness token of a model service that has weights for ``skill``."""
    return liveliness_key(ns, "model", skill)


def model_service_token_key(ns: str, zid: str) -> str:
    """``acnmp/<ns>/service/model/<zid>``: liveliness token of a running model process (with or
    without skills loaded), so a launcher can wait for it before any skill is trained."""
    return liveliness_key(ns, "service", "model", zid)


# --- learner and workers ---


def skill_train_key(ns: str, skill: str) -> str:
    """``acnmp/<ns>/skill/<skill>/train``: the learner's queryable that trains a skill from demos."""
    return skill_key(ns, skill, "train")


def skill_adapt_key(ns: str, skill: str) -> str:
    """``acnmp/<ns>/skill/<skill>/adapt``: the learner's queryable that queues an adaptation job."""
    return skill_key(ns, skill, "adapt")


def skill_any_key(ns: str, *parts: str) -> str:
    """``acnmp/<ns>/skill/*/<parts...>``: one queryable for every skill (the learner's side)."""
    return "/".join([prefix(ns), "skill", "*", *(check_name("key part", p) for p in parts)])


def job_status_key(ns: str, job: str) -> str:
    """``acnmp/<ns>/job/<job>/status``: the learner's queryable for an adaptation job's state."""
    return f"{prefix(ns)}/job/{check_name('job', job)}/status"


def job_status_pattern(ns: str) -> str:
    """``acnmp/<ns>/job/*/status``: what the learner declares to answer every job's status."""
    return f"{prefix(ns)}/job/*/status"


def job_from_key(key: str) -> str:
    """The ``<job>`` chunk of an ``acnmp/<ns>/job/<job>/...`` key; ValueError otherwise."""
    chunks = str(key).split("/")
    if len(chunks) < 4 or chunks[0] != ROOT or chunks[2] != "job":
        raise ValueError(f"key: {key!r} is not an acnmp/<ns>/job/<job>/... key")
    return check_name("job", chunks[3])


def learner_token_key(ns: str, learner_id: str) -> str:
    """``acnmp/<ns>/learner/<id>``: liveliness token of a running learner."""
    return liveliness_key(ns, "learner", learner_id)


def worker_token_key(ns: str, robot: str, worker_id: str) -> str:
    """``acnmp/<ns>/worker/<robot>/<id>``: liveliness token of a worker of robot kind ``robot``."""
    return liveliness_key(ns, "worker", robot, worker_id)


def worker_robot_pattern(ns: str, robot: str) -> str:
    """``acnmp/<ns>/worker/<robot>/*``: every worker token of one robot kind."""
    return f"{prefix(ns)}/worker/{check_name('robot', robot)}/*"


def worker_rollout_key(ns: str, robot: str, worker_id: str) -> str:
    """``acnmp/<ns>/worker/<robot>/<id>/rollout``: a worker's roll-out queryable."""
    return f"{worker_token_key(ns, robot, worker_id)}/rollout"
