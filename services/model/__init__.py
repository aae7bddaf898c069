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
