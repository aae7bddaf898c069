"""Saving and loading CNMPs: weights, config, normalisation and a hash of the training data.

Loading uses ``torch.load(weights_only=True)``: a checkpoint can never execute code.
"""
from __future__ import annotations

import os
import tempfile
from pathlib import Path

import numpy as np
import torch

from .cnmp import CNMP, CNMPConfig
from .errors import InputError, ShapeError

FORMAT_VERSION = 1


def save_checkpoint(model: CNMP, path: str | os.PathLike, *, data_hash: str = "", meta: dict | None = None) -> Path:
    """Write ``model`` to ``path`` atomically (temp file + rename) and return the path.

    ``data_hash`` identifies the training data (``DemoSet.content_hash()``); ``meta`` holds extra
    plain values (str, int, float, lists and dicts of them).
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    payload = {
        "format": FORMAT_VERSION,
        "config": model.config.to_dict(),
        "state_dict": model.state_dict(),
        "data_hash": str(data_hash),
        "meta": dict(meta or {}),
    }
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=path.name, suffix=".tmp")
    os.close(fd)
    try:
        torch.save(payload, tmp)
        os.replace(tmp, path)
    finally:
        if os.path.exists(tmp):
            os.unlink(tmp)
    return path


def load_checkpoint(path: str | os.PathLike) -> tuple[CNMP, dict]:
    """Load a checkpoint written by :func:`save_checkpoint`.

    Returns (model in eval mode, info) where info has ``data_hash`` and ``meta``.
    Raises ValueError for a file that is not such a checkpoint.
    """
    path = Path(path)
    if not path.is_file():
        raise ValueError(f"path: no checkpoint file at {path}")
    try:
        payload = torch.load(path, map_location="cpu", weights_only=True)
    except Exception as exc:  # torch raises many types for corrupt or unsafe files
        raise ValueError(f"path: {path} is not a readable checkpoint ({exc})") from None
    if not isinstance(payload, dict) or payload.get("format") != FORMAT_VERSION:
        raise ValueError(f"path: {path} is not an acnmp checkpoint of format {FORMAT_VERSION}")
    model = CNMP(CNMPConfig(**payload["config"]))
    model.load_state_dict(payload["state_dict"])
    model.eval()
    return model, {"data_hash": payload["data_hash"], "meta": payload["meta"]}


def model_to_arrays(model: CNMP) -> tuple[dict, dict[str, "np.ndarray"]]:
    """(config as plain dict, {parameter/buffer name: numpy array}): a pickle-free form of a model,
    for sending weights over a wire."""
    return model.config.to_dict(), {k: v.detach().cpu().numpy().copy() for k, v in model.state_dict().items()}


def model_from_arrays(config: dict, arrays: dict) -> CNMP:
    """Rebuild a model from :func:`model_to_arrays` output; raises ValueError on a mismatch
    (:class:`~acnmp_core.errors.ShapeError` for an array of the wrong shape)."""
    model = CNMP(CNMPConfig(**config))
    expected = model.state_dict()
    if set(arrays) != set(expected):
        missing, extra = set(expected) - set(arrays), set(arrays) - set(expected)
        raise InputError(f"arrays: parameter names do not match the config (missing {sorted(missing)}, extra {sorted(extra)})")
    state = {}
    for k, ref in expected.items():
        t = torch.as_tensor(np.asarray(arrays[k])).to(ref.dtype)
        if t.shape != ref.shape:
            raise ShapeError(f"arrays[{k!r}]: expected shape {tuple(ref.shape)}, got {tuple(t.shape)}")
        state[k] = t
    model.load_state_dict(state)
    model.eval()
    return model
