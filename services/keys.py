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
