"""The typed jobs that cross the wire: what a client asks the learner to run, checked on arrival,
with plain-value conversions for messages and job records.

- :mod:`.adapt`: an adaptation job (:class:`~acnmp_core.jobs.adapt.AdaptJob`) and its result.
- :mod:`.transfer`: a paired-skill training job (:class:`~acnmp_core.jobs.transfer.PairTrainJob`).
"""
