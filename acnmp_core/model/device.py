"""Where a CNMP's networks run: ``cpu``, ``cuda`` or ``auto`` (CUDA when there is one, else CPU).

Only the encoder and decoder move (:meth:`acnmp_core.model.cnmp.CNMP.to_device`): the normalisers, the
data, the optimiser's bookkeeping and every result stay on the CPU; inputs go to the networks' device
in :meth:`~acnmp_core.model.cnmp.CNMP.forward` and outputs come back as CPU tensors or numpy arrays. So
``train``, ``adapt``/``assimilate`` and ``predict`` run on whichever device the model is on, and a
checkpoint saved from any device loads on any other (it is always loaded to the CPU first).
"""
from __future__ import annotations

import torch

#: The values ``--device`` takes.
DEVICES = ("cpu", "cuda", "auto")


def resolve_device(name: str | torch.device | None = "cpu") -> torch.device:
    """The torch device ``name`` means: ``cpu`` (and None), ``cuda`` / ``cuda:N``, or ``auto``
    (``cuda`` when torch sees a CUDA device, else ``cpu``). ValueError, one line, for an unknown
    name or a CUDA device this machine does not have."""
    if isinstance(name, torch.device):
        name = str(name)
    name = (name or "cpu").strip().lower()
    if name == "auto":
        return torch.device("cuda" if torch.cuda.is_available() else "cpu")
    if name == "cpu":
        return torch.device("cpu")
    if name == "cuda" or name.startswith("cuda:"):
        if not torch.cuda.is_available():
            build = "a CPU-only build" if torch.version.cuda is None else f"built for CUDA {torch.version.cuda}"
            raise ValueError(f"--device {name}: torch {torch.__version__} ({build}) sees no CUDA device here; "
                             "use --device cpu or auto")
        device = torch.device(name)
        if device.index is not None and device.index >= torch.cuda.device_count():
            raise ValueError(f"--device {name}: this machine has {torch.cuda.device_count()} CUDA device(s)")
        return device
    raise ValueError(f"--device {name}: expected one of {', '.join(DEVICES)} (or cuda:N)")


def available_devices() -> list[torch.device]:
    """Every device a benchmark can measure here: the CPU, then each CUDA device."""
    return [torch.device("cpu"), *(torch.device(f"cuda:{i}") for i in range(torch.cuda.device_count()))]
