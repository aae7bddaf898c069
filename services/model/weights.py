"""The weights message: how the learner hands a trained CNMP to the model service, pickle-free.

Published by the learner on ``acnmp/<ns>/skill/<skill>/weights`` and answered on
``acnmp/<ns>/skill/<skill>/weights/latest``; read by the model service (services/model/service.py)::

    {"v": 1, "skill": str, "version": int >= 0, "config": CNMPConfig.to_dict(),
     "state": {name: array}, "data_hash": str, "n_demos": int >= 0,
     "partner"?: {"config": CNMPConfig.to_dict(), "state": {name: array}}}

``partner`` is robot B's CNMP of a **paired skill** (a transfer pair: ``config``/``state`` are
robot A's); both have no task parameters and latents of one size.

``state`` is :func:`acnmp_core.model.checkpoint.model_to_arrays` (float32 weights, float64 normaliser
buffers, a 0-d bool ``fitted``); :func:`acnmp_core.model.checkpoint.model_from_arrays` rebuilds the model
and checks every name and shape against ``config``, so a message can never run code or smuggle in
a half-built model.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from acnmp_core.model.checkpoint import model_from_arrays, model_to_arrays
from acnmp_core.model.cnmp import CNMP, CNMPConfig
from services.transport.errors import wire_error
from services.transport.keys import check_name
from services.transport.wire import WireError, decode, encode, field

#: Largest model accepted over the wire (parameters + buffers); ~256 MB of float32.
MAX_PARAMETERS = 64_000_000


@dataclass
class ModelWeights:
    """A decoded weights message: the rebuilt ``model`` (eval mode) and its provenance."""

    skill: str
    version: int
    model: CNMP
    data_hash: str = ""
    n_demos: int = 0
    partner: CNMP | None = None  # robot B's model of a paired skill


def weights_message(skill: str, version: int, model: CNMP, *, data_hash: str = "", n_demos: int = 0,
                    partner: CNMP | None = None) -> dict:
    """Build the weights message map for ``model`` (a fitted CNMP) and, for a paired skill, robot
    B's ``partner``; encode it with wire.encode.

    Raises ValueError for a bad skill name, a negative version or an unfitted model (its
    normaliser ranges are still infinite and could not travel anyway).
    """
    check_name("skill", skill)
    if isinstance(version, bool) or not isinstance(version, (int, np.integer)) or version < 0:
        raise ValueError(f"version: expected an integer >= 0, got {version!r}")
    for what, m in (("model", model), ("partner", partner)):
        if m is not None and not bool(m.fitted):
            raise ValueError(f"{what}: normalisation is not fitted; train it before publishing")
    config, state = model_to_arrays(model)
    msg = {"v": 1, "skill": skill, "version": int(version), "config": config, "state": state,
           "data_hash": str(data_hash), "n_demos": int(n_demos)}
    if partner is not None:
        p_config, p_state = model_to_arrays(partner)
        msg["partner"] = {"config": p_config, "state": p_state}
    return msg


def encode_weights(skill: str, version: int, model: CNMP, *, data_hash: str = "", n_demos: int = 0,
                   partner: CNMP | None = None) -> bytes:
    """:func:`weights_message` encoded to msgpack bytes, ready for ``session.put`` or ``query.reply``."""
    return encode(weights_message(skill, version, model, data_hash=data_hash, n_demos=n_demos, partner=partner))


def check_model_size(config: dict, *, what: str = "field 'config'") -> CNMPConfig:
    """The :class:`CNMPConfig` of a config map, if the network it describes has at most
    :data:`MAX_PARAMETERS` parameters (counted from the widths, nothing allocated).

    Raises WireError ``too_large`` (too many parameters) or ``bad_request`` (a config the CNMP
    refuses). The learner applies the same bound to a train request's model.
    """
    try:
        cfg = CNMPConfig.from_dict(config)
    except TypeError as exc:  # unknown or missing CNMPConfig keys
        raise WireError("bad_request", f"{what}: config: {exc}") from None
    except ValueError as exc:
        err = wire_error(exc, default="bad_request")
        raise WireError(err.code, f"{what}: config: {err.message}") from None
    if cfg.n_parameters > MAX_PARAMETERS:
        raise WireError("too_large", f"{what}: the config describes {cfg.n_parameters} parameters, "
                                     f"at most {MAX_PARAMETERS}")
    return cfg


def parse_weights(msg: dict) -> ModelWeights:
    """Validate a decoded weights message map and rebuild its model.

    Raises :class:`WireError`: ``bad_request`` (missing/mistyped field, bad skill name, config
    the CNMP refuses), ``bad_shape`` (a state array that does not fit the config), ``too_large``.
    """
    skill = field(msg, "skill", str)
    try:
        check_name("skill", skill)
    except ValueError as exc:
        raise WireError("bad_request", str(exc)) from None
    version = field(msg, "version", int)
    if version < 0:
        raise WireError("bad_request", f"field 'version': must be >= 0, got {version}")
    model = _parse_model(field(msg, "config", dict), field(msg, "state", dict), f"weights of skill {skill!r}")
    partner = None
    pair = field(msg, "partner", dict, default=None)
    if pair is not None:
        what = f"weights of skill {skill!r}: partner"
        try:
            p_config, p_state = field(pair, "config", dict), field(pair, "state", dict)
        except WireError as exc:
            raise WireError(exc.code, f"{what}: {exc.message}") from None
        partner = _parse_model(p_config, p_state, what)
        for m, side in ((model, "A"), (partner, "B")):
            if m.config.n_task_params:
                raise WireError("bad_request", f"{what}: robot {side}'s model has task parameters; a pair has none")
        if partner.config.latent_dim != model.config.latent_dim:
            raise WireError("bad_request", f"{what}: latent size {partner.config.latent_dim} differs from "
                                           f"robot A's {model.config.latent_dim}")
    return ModelWeights(skill=skill, version=version, model=model,
                        data_hash=field(msg, "data_hash", str, default=""),
                        n_demos=field(msg, "n_demos", int, default=0), partner=partner)


def _parse_model(config: dict, state: dict, what: str) -> CNMP:
    """Rebuild one CNMP from its config and state maps, bounded by :data:`MAX_PARAMETERS` before
    anything is allocated; WireError ``bad_request``/``bad_shape``/``too_large`` naming ``what``."""
    n_params = 0
    for name, arr in state.items():
        if not isinstance(arr, np.ndarray):
            raise WireError("bad_request", f"{what}: field 'state.{name}': expected an array, got {type(arr).__name__}")
        n_params += arr.size
    if n_params > MAX_PARAMETERS:
        raise WireError("too_large", f"{what}: field 'state': {n_params} values, at most {MAX_PARAMETERS}")
    check_model_size(config, what=what)
    try:
        model = model_from_arrays(config, state)
    except TypeError as exc:  # unknown or missing CNMPConfig keys
        raise WireError("bad_request", f"{what}: field 'config': {exc}") from None
    except ValueError as exc:  # a config the CNMP refuses, or arrays that do not fit it
        err = wire_error(exc, default="bad_request")
        raise WireError(err.code, f"{what}: {err.message}") from None
    if not bool(model.fitted):
        raise WireError("bad_request", f"{what}: the model's normalisation is not fitted")
    return model


def decode_weights(payload: bytes) -> ModelWeights:
    """Decode msgpack bytes of a weights message and rebuild the model; raises :class:`WireError`."""
    return parse_weights(decode(payload))
