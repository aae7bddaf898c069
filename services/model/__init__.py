"""The model wing: serves CNMP skills (predict, info) and hot-swaps the weights the learner publishes.

========================  =========================================================
module                    one job
========================  =========================================================
``handlers``              zenoh-free: the skill registry and the predict/info handlers
``weights``               the weights message (learner -> model service), pickle-free
``config``                :class:`ModelOptions`: the service's options (torch-free)
``service``               :class:`ModelService` on a session, :class:`ModelConfig` (runs it)
========================  =========================================================
"""
from __future__ import annotations

from typing import TYPE_CHECKING

from services.transport.lazy import lazy_exports

if TYPE_CHECKING:  # what a type checker sees; at run time the names come from __getattr__
    from .handlers import ModelRegistry, SkillModel, handle_info, handle_predict
    from .config import ModelOptions
    from .service import ModelConfig, ModelService
    from .weights import ModelWeights, decode_weights, encode_weights, weights_message

__all__ = [
    "ModelRegistry", "SkillModel", "handle_info", "handle_predict", "ModelConfig", "ModelOptions",
    "ModelService", "ModelWeights", "decode_weights", "encode_weights", "weights_message",
]
__getattr__ = lazy_exports(__name__, {
    "ModelRegistry": "handlers", "SkillModel": "handlers", "handle_info": "handlers",
    "handle_predict": "handlers", "ModelConfig": "service", "ModelOptions": "config",
    "ModelService": "service", "ModelWeights": "weights", "decode_weights": "weights",
    "encode_weights": "weights", "weights_message": "weights",
})
