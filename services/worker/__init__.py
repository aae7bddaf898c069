"""The worker wing: executes roll-outs of one robot kind, and the evaluator that spreads them.

========================  =========================================================
module                    one job
========================  =========================================================
``core``                  zenoh-free: :class:`Worker`, the roll-out request/reply codec,
                          :class:`ExecutedBatch` (a RolloutBatch with its worker ids)
``remote``                :class:`RemoteEvaluator`: a RolloutEvaluator over the live workers
``service``               :class:`WorkerConfig`: the worker process
========================  =========================================================
"""
