"""Saving and loading CNMPs: weights, config, normalisation and a hash of the training data.

Loading uses ``torch.load(weights_only=True)``: a checkpoint can never execute code.
"""
from __future__ import annotations

import io
import os
import warnings
from pathlib import Path

import numpy as np
import torch

from ..errors import InputError, ShapeError, UnreadableFileError
from ..files import atomic_write_bytes
from .cnmp import CNMP, CNMPConfig

FORMAT_VERSION = 1


def checkpoint_bytes(model: CNMP, *, data_hash: str = "", meta: dict | None = None) -> bytes:
    """The bytes :func:`save_checkpoint` writes for ``model`` (a torch file of plain containers,
    tensors and strings): for a caller that writes them its own way (services/learner/store.py)."""
    payload = {
        "format": FORMAT_VERSION,
        "config": model.config.to_dict(),
        "state_dict": model.state_dict(),
        "data_hash": str(data_hash),
        "meta": dict(meta or {}),
    }
    buf = io.BytesIO()
    torch.save(payload, buf)
    return buf.getvalue()


def save_checkpoint(model: CNMP, path: str | os.PathLike, *, data_hash: str = "", meta: dict | None = None) -> Path:
    """Write ``model`` to ``path`` atomically and durably (acnmp_core/files.py) and return the path.

    ``data_hash`` identifies the training data (``DemoSet.content_hash()``); ``meta`` holds extra
    plain values (str, int, float, lists and dicts of them). Raises OSError when the file cannot
    be written (``path`` is then unchanged).
    """
    return atomic_write_bytes(path, checkpoint_bytes(model, data_hash=data_hash, meta=meta))


#: Why :func:`load_checkpoint` refuses a file torch cannot read. Not torch's own words: for a file
#: of unknown origin they suggest ``weights_only=False``, which would let the file run code.
NOT_READABLE = "not a readable checkpoint (truncated or not a torch file)"


def load_checkpoint(path: str | os.PathLike) -> tuple[CNMP, dict]:
    """Load a checkpoint written by :func:`save_checkpoint`.

    Returns (model in eval mode, info) where info has ``data_hash`` and ``meta``. Raises
    :class:`~acnmp_core.errors.UnreadableFileError` (a ValueError; ``reason`` says what is wrong)
    for a file that is missing, cannot be read, is not such a checkpoint (:data:`NOT_READABLE`),
    is one of another format version, or whose weights do not fit its config.
    """
    path = Path(path)
    if not path.is_file():
        raise UnreadableFileError(path, "missing", f"path: no checkpoint file at {path}")
    try:
        with warnings.catch_warnings():  # torch warns about what it finds in a foreign file, in its own words
            warnings.simplefilter("ignore")
            payload = torch.load(path, map_location="cpu", weights_only=True)
    except OSError as exc:
        raise UnreadableFileError(path, f"cannot be read ({exc.strerror or exc})") from None
    except Exception:  # torch raises many types for corrupt or unsafe files; its words mislead (above)
        raise UnreadableFileError(path, NOT_READABLE, f"path: {path} is {NOT_READABLE}") from None
    found = payload.get("format") if isinstance(payload, dict) else None
    if found != FORMAT_VERSION:
        reason = (f"an acnmp checkpoint of format {found!r}; this version reads format {FORMAT_VERSION}"
                  if found is not None else f"not an acnmp checkpoint of format {FORMAT_VERSION}")
        raise UnreadableFileError(path, reason, f"path: {path} is {reason}")
    try:
        model = CNMP(CNMPConfig.from_dict(payload["config"]))
        model.load_state_dict(payload["state_dict"])
        info = {"data_hash": str(payload["data_hash"]), "meta": dict(payload["meta"])}
    except Exception as exc:  # a checkpoint of format 1 whose parts do not fit together
        reason = f"an acnmp checkpoint whose parts do not fit together ({type(exc).__name__})"
        raise UnreadableFileError(path, reason, f"path: {path} is {reason}") from None
    model.eval()
    return model, info


def model_to_arrays(model: CNMP) -> tuple[dict, dict[str, "np.ndarray"]]:
    """(config as plain dict, {parameter/buffer name: numpy array}): a pickle-free form of a model,
    for sending weights over a wire."""
    return model.config.to_dict(), {k: v.detach().cpu().numpy().copy() for k, v in model.state_dict().items()}


def model_from_arrays(config: dict, arrays: dict) -> CNMP:
    """Rebuild a model from :func:`model_to_arrays` output; raises ValueError on a mismatch
    (:class:`~acnmp_core.errors.ShapeError` for an array of the wrong shape)."""
    model = CNMP(CNMPConfig.from_dict(config))
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
