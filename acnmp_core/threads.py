"""How many torch threads the library's training, assimilation and adaptation use.

The CNMPs here are small (a few hundred thousand weights, batches of 32 episodes): their matrix
products gain little from a second thread on an idle machine and lose a great deal when another
process holds a core, because torch's intra-op threads then wait on each other at every product.
One thread is the default (``benchmarks/studies/e3_wall/results/bench_thread_default.json`` compares one and two
threads, alone and beside a busy process). Set
``ACNMP_TORCH_THREADS=N`` (or call :func:`set_training_threads`) on a machine of your own whose
cores are free; the numbers computed do not depend on it.

:func:`training_threads_scope` applies the count for the duration of one call and restores the
caller's own torch setting afterwards, so importing or calling the library never changes the
thread count of the code around it.
"""
from __future__ import annotations

import functools
import os
from contextlib import contextmanager
from typing import Callable, Iterator, TypeVar

import torch

__all__ = ["DEFAULT_TRAINING_THREADS", "ENV_VAR", "set_training_threads", "training_threads",
           "training_threads_scope", "with_training_threads"]

DEFAULT_TRAINING_THREADS = 1
ENV_VAR = "ACNMP_TORCH_THREADS"
_chosen: int | None = None
F = TypeVar("F", bound=Callable)


def set_training_threads(n: int | None) -> None:
    """Use ``n`` torch threads (an int >= 1) in training, assimilation and adaptation from now on in
    this process; None goes back to ``$ACNMP_TORCH_THREADS`` or the default (1)."""
    global _chosen
    if n is not None and (isinstance(n, bool) or not isinstance(n, int) or n < 1):
        raise ValueError(f"threads: expected an integer >= 1, got {n!r}")
    _chosen = n


def training_threads() -> int:
    """The thread count training uses: :func:`set_training_threads`'s, else ``$ACNMP_TORCH_THREADS``,
    else :data:`DEFAULT_TRAINING_THREADS`. A malformed environment value raises ValueError naming it."""
    if _chosen is not None:
        return _chosen
    raw = os.environ.get(ENV_VAR, "").strip()
    if not raw:
        return DEFAULT_TRAINING_THREADS
    try:
        n = int(raw)
    except ValueError:
        n = 0
    if n < 1:
        raise ValueError(f"{ENV_VAR}: expected an integer >= 1, got {raw!r}")
    return n


@contextmanager
def training_threads_scope() -> Iterator[int]:
    """Run the body with :func:`training_threads` torch threads; the previous count is restored on
    exit (also on an exception). Yields the count in use. Nested scopes are cheap (no change made)."""
    want, before = training_threads(), torch.get_num_threads()
    if want != before:
        torch.set_num_threads(want)
    try:
        yield want
    finally:
        if want != before:
            torch.set_num_threads(before)


def with_training_threads(fn: F) -> F:
    """Decorator: ``fn`` runs inside :func:`training_threads_scope` (same signature and docstring)."""
    @functools.wraps(fn)
    def wrapper(*args, **kwargs):
        with training_threads_scope():
            return fn(*args, **kwargs)
    return wrapper  # type: ignore[return-value]
