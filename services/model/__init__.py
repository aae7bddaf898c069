"""The model wing: serves CNMP skills (predict, info) and hot-swaps the weights the learner publishes.

========================  =========================================================
module                    one job
========================  =========================================================
``handlers``              zenoh-free: the skill registry and the predict/info handlers
``weights``               the weights message (learner -> model service), pickle-free
``service``               :class:`ModelService` on a session, :class:`ModelConfig`
========================  =========================================================
"""
from .handlers import ModelRegistry, SkillModel, handle_info, handle_predict
from .service import ModelConfig, ModelService
from .weights import ModelWeights, decode_weights, encode_weights, weights_message

__all__ = ["ModelRegistry", "SkillModel", "handle_info", "handle_predict", "ModelConfig", "ModelService",
           "ModelWeights", "decode_weights", "encode_weights", "weights_message"]
