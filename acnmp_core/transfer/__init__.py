"""Skill transfer between two robots through a shared latent space (ACNMP paper Sec. 3.3).

- :mod:`.config`: :class:`~acnmp_core.transfer.config.TransferConfig` (a paired training's settings)
  and :class:`~acnmp_core.transfer.config.PairTrainResult` (its losses), torch-free;
- :mod:`.pair`: two CNMPs trained together with aligned latents
  (:class:`~acnmp_core.transfer.pair.TransferPair`, :func:`~acnmp_core.transfer.pair.train_pair`),
  and a skill shown on one robot decoded for the other.
"""

from ..moved import forward

__getattr__ = forward(__name__)  # this package was a module: its old names, with a warning
