"""The recording wing: events, the one .rrd writer, the recorder process, reading recordings back.

========================  =========================================================
module                    one job
========================  =========================================================
``events``                zenoh-free: event builders and validation
``publisher``             :class:`EventPublisher`: puts events on a session
``recorded``              :class:`RecordedEvaluator`: publishes every roll-out it runs
``drawings``              how a robot's roll-out is drawn, one function per drawing kind
``rrd_writer``            :class:`RrdWriter`: events -> Rerun log calls, the file's footer
``event_ids``             zenoh-free: :class:`SeenEvents`, the event ids recorded (per publisher a mark)
``config``                :class:`RecorderOptions`: the recorder's options (rerun-free)
``recorder``              :class:`RecorderConfig`: the recorder process
``replay``                :func:`summarize` a recording (``acnmp replay``)
========================  =========================================================

Rerun is imported only by ``drawings``, ``rrd_writer``, ``recorder`` and ``replay``; the learner
and the experiment runners import ``events``, ``publisher`` and ``recorded`` only.
"""
