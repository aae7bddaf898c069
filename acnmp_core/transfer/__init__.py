"""Skill transfer between two robots through a shared latent space (ACNMP paper Sec. 3.3).

- :mod:`.pair`: two CNMPs trained together with aligned latents
  (:class:`~acnmp_core.transfer.pair.TransferPair`, :func:`~acnmp_core.transfer.pair.train_pair`),
  and a skill shown on one robot decoded for the other.
"""
