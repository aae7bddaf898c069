"""The Conditional Neural Movement Primitive and how it learns from demonstrations.

- :mod:`.cnmp`: the network (:class:`~acnmp_core.model.cnmp.CNMP`: encoder, mean-aggregated latent,
  decoder with a softplus std), its configuration and conditioned prediction.
- :mod:`.episodes`: the context/target episodes drawn from demonstrations for training.
- :mod:`.training`: supervised training on the Gaussian negative log-likelihood, and its metrics.
- :mod:`.normalization`: the affine normalisation fitted to the demonstrations.
- :mod:`.optim_step`: Adam on torch's fused kernel (:class:`~.optim_step.FusedAdam`) and the step of any optimiser.
- :mod:`.checkpoint`: saving and loading a model (torch files read with ``weights_only``).
- :mod:`.device`: which torch device to run on.
"""
