"""The deployment's access control: default deny, and per role an explicit allow list.

:data:`GRANTS` is the single source. :func:`acl_config` turns it into the router's zenoh
``access_control`` section; :func:`grants_markdown` renders the table of docs/SECURITY.md
("Security"), and a test checks that the page shows exactly this table.

How zenoh 1.10 applies it (what the rules rely on):

* a rule matches a message when the rule's key expression **includes** the message's key
  expression. A put, query, declaration or token on a wider expression (``acnmp/NS/**``,
  ``acnmp/NS/skill/*/*``) is included in no grant, so the default (deny) drops it;
* ``**`` never matches a verbatim chunk (``@adv``), so zenoh-ext's advanced pub/sub keys
  (``<event key>/@adv/pub/...``, ``.../@adv/sub/...``) have grants of their own;
* the grants are checked where messages come **in** to the router (``ingress``). What the router
  sends out (``egress``) is allowed on the deployment's keys: it can only be a delivery that an
  ingress grant let someone ask for (a subscription, a query, a queryable, a liveliness
  subscriber), so denying it too would only duplicate the table.

Services check keys a second time (services/transport/keys.py, :func:`keys.concrete`): a grant may
include wildcard expressions (a worker's token ``acnmp/NS/worker/ur10/*`` is inside the worker's
grant), and only a concrete key is acted on.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Sequence

import zenoh

#: One zenoh username per role; a process of the deployment authenticates as its role.
ROLES = ("launcher", "learner", "model", "worker", "recorder", "operator", "client")

#: zenoh 1.10's ACL message kinds.
MESSAGES = ("put", "delete", "declare_subscriber", "query", "declare_queryable", "reply",
            "liveliness_token", "declare_liveliness_subscriber", "liveliness_query")

#: The roles that publish events (docs/EVENTS.md).
EVENT_PUBLISHERS = ("learner", "operator")

_TOKENS = ("acnmp/*/model/**", "acnmp/*/service/**", "acnmp/*/learner/**", "acnmp/*/worker/**",
           "acnmp/*/recorder/**", "acnmp/*/router/**")
_EVENT_ADV = "acnmp/*/event/*/*/@adv"


@dataclass(frozen=True)
class Grant:
    """One row of the access table: ``roles`` may send ``messages`` on key expressions included in
    one of ``keys``; ``why`` says what needs it."""

    id: str
    roles: tuple[str, ...]
    messages: tuple[str, ...]
    keys: tuple[str, ...]
    why: str


GRANTS: tuple[Grant, ...] = (
    Grant("discover", ROLES, ("declare_liveliness_subscriber", "liveliness_query"), _TOKENS,
          "find the live model services, learners, workers, recorders"),
    Grant("ask-model", ("client", "operator"), ("query",),
          ("acnmp/*/skill/*/predict", "acnmp/*/skill/*/predict/*", "acnmp/*/skill/*/info",
           "acnmp/*/skill/*/transfer"),
          "predict (of any process, or of one), info, transfer"),
    Grant("ask-status", ("client", "operator"), ("query",),
          ("acnmp/*/job/*/status", "acnmp/*/jobs", "acnmp/*/recorder/status", "acnmp/*/process/**"),
          "a job's status, the job list, the recorder's counts, each process's host (`acnmp status`)"),
    Grant("start-jobs", ("operator",), ("query",),
          ("acnmp/*/skill/*/train", "acnmp/*/skill/*/train_pair", "acnmp/*/skill/*/adapt", "acnmp/*/job/*/cancel"),
          "train, adapt, cancel"),
    Grant("read-weights", ("model", "operator"), ("query",), ("acnmp/*/skill/*/weights/latest",),
          "the newest weights (the model service at start, `ACNMPClient.weights`)"),
    Grant("follow-weights", ("model",), ("declare_subscriber",), ("acnmp/*/skill/*/weights",),
          "each new weights version"),
    Grant("serve-model", ("model",), ("declare_queryable", "reply"),
          ("acnmp/*/skill/*/predict", "acnmp/*/skill/*/predict/*", "acnmp/*/skill/*/info",
           "acnmp/*/skill/*/transfer"), "answer predict (for any process, or as this one), info, transfer"),
    Grant("model-tokens", ("model",), ("liveliness_token",),
          ("acnmp/*/model/*", "acnmp/*/model/*/*", "acnmp/*/service/model/*"),
          "say which skills are served, and by which process"),
    Grant("serve-learner", ("learner",), ("declare_queryable", "reply"),
          ("acnmp/*/skill/*/train", "acnmp/*/skill/*/train_pair", "acnmp/*/skill/*/adapt",
           "acnmp/*/job/*/status", "acnmp/*/jobs", "acnmp/*/job/*/cancel", "acnmp/*/skill/*/weights/latest"),
          "answer train, adapt, status, jobs, cancel, weights/latest"),
    Grant("publish-weights", ("learner",), ("put",), ("acnmp/*/skill/*/weights",), "each new weights version"),
    Grant("learner-token", ("learner",), ("liveliness_token",), ("acnmp/*/learner/*",), "say the learner is live"),
    Grant("call-workers", ("learner", "operator"), ("query",), ("acnmp/*/worker/*/*/rollout",),
          "execute roll-outs (jobs; `--distributed` experiments)"),
    Grant("serve-rollouts", ("worker",), ("declare_queryable", "reply"), ("acnmp/*/worker/*/*/rollout",),
          "execute roll-outs"),
    Grant("worker-token", ("worker",), ("liveliness_token",), ("acnmp/*/worker/*/*",), "say the worker is live"),
    Grant("ask-recorder", EVENT_PUBLISHERS, ("query",), ("acnmp/*/recorder/status",),
          "wait until the recorder holds what was published"),
    Grant("publish-events", EVENT_PUBLISHERS, ("put",), ("acnmp/*/event/*/*",), "roll-outs, latents, versions, progress"),
    Grant("event-caches", EVENT_PUBLISHERS,
          ("put", "delete", "declare_queryable", "reply", "liveliness_token", "declare_subscriber",
           "declare_liveliness_subscriber", "liveliness_query", "query"),
          (f"{_EVENT_ADV}/pub/**", f"{_EVENT_ADV}/sub/**"),
          "zenoh-ext advanced publishers: cache, heartbeat, subscriber detection"),
    Grant("event-replays", EVENT_PUBLISHERS, ("reply",), ("acnmp/*/event/*/*",), "a cache's replay to the recorder"),
    Grant("record", ("recorder",), ("declare_subscriber",), ("acnmp/*/event/**",), "every event"),
    Grant("record-history", ("recorder",),
          ("query", "liveliness_token", "declare_liveliness_subscriber", "liveliness_query", "declare_subscriber"),
          ("acnmp/*/event/**/@adv/**",), "zenoh-ext advanced subscriber: history, publisher detection"),
    Grant("serve-recorder", ("recorder",), ("declare_queryable", "reply"), ("acnmp/*/recorder/status",),
          "answer the recorder's status"),
    Grant("recorder-token", ("recorder",), ("liveliness_token",), ("acnmp/*/recorder/*",), "say the recorder is live"),
    Grant("about-process", ("launcher", "learner", "model", "worker", "recorder"), ("declare_queryable", "reply"),
          ("acnmp/*/process/*/*",), "say on which host and pid the process runs"),
)

#: What the router may send out, to every role (see the module docstring).
EGRESS_KEYS = ("acnmp/**", "acnmp/*/event/**/@adv/**")


def acl_config(roles: Sequence[str] = ROLES) -> dict:
    """The router's ``access_control`` section (JSON-able): ``default_permission: deny``, one
    ingress allow rule per :data:`GRANTS` row applied to its roles, and one egress allow rule on
    :data:`EGRESS_KEYS` for every role. Every link is authenticated (the dictionary), so every link
    matches exactly one role's subject."""
    rules, policies = [], []
    for grant in GRANTS:
        rules.append({"id": grant.id, "permission": "allow", "flows": ["ingress"],
                      "messages": list(grant.messages), "key_exprs": list(grant.keys)})
        subjects = [r for r in grant.roles if r in roles]
        if subjects:
            policies.append({"rules": [grant.id], "subjects": subjects})
    rules.append({"id": "deliver", "permission": "allow", "flows": ["egress"],
                  "messages": list(MESSAGES), "key_exprs": list(EGRESS_KEYS)})
    policies.append({"rules": ["deliver"], "subjects": list(roles)})
    return {"enabled": True, "default_permission": "deny", "rules": rules,
            "subjects": [{"id": r, "usernames": [r]} for r in roles], "policies": policies}


def may(role: str, message: str, key_expr: str) -> bool:
    """Whether :func:`acl_config` lets ``role`` send ``message`` on ``key_expr`` into the router:
    some grant of ``role`` lists ``message`` and has a key expression that includes ``key_expr``
    (zenoh's own inclusion test). ValueError for an unknown role or message kind."""
    if role not in ROLES or message not in MESSAGES:
        raise ValueError(f"may: unknown role {role!r} or message {message!r}")
    asked = zenoh.KeyExpr(key_expr)
    return any(role in g.roles and message in g.messages and any(zenoh.KeyExpr(k).includes(asked) for k in g.keys)
               for g in GRANTS)


def grants_markdown() -> str:
    """The access table of docs/SECURITY.md: one markdown row per grant (roles, messages, keys, why)."""
    rows = ["| grant | roles | messages | key expressions | what for |", "| --- | --- | --- | --- | --- |"]
    for g in GRANTS:
        roles = "every role" if set(g.roles) == set(ROLES) else ", ".join(f"`{r}`" for r in g.roles)
        rows.append(f"| {g.id} | {roles} | {', '.join(g.messages)} | {', '.join(f'`{k}`' for k in g.keys)} | {g.why} |")
    return "\n".join(rows) + "\n"


if __name__ == "__main__":  # python -m services.transport.acl: the table for docs/SECURITY.md
    print(grants_markdown(), end="")
