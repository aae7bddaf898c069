"""Give freed memory back to the system: glibc's allocator settings for a process that handles large
payloads (the model service).

glibc keeps the memory a process frees for its next allocations: a freed block inside a heap stays
mapped, and after the first large block it frees, glibc raises the size from which it maps a block
of its own (``M_MMAP_THRESHOLD``, "dynamic" up to 32 MiB), so later payload buffers of a few MiB
come from the heaps, one heap (arena) per thread that allocates. A model service that had decoded
predicts of 57-60 MB held 1.6 GB when idle again (issue 66). Two calls fix it:

* :func:`map_large_blocks` fixes the threshold (which also turns its dynamic raise off): every
  block of ``threshold`` bytes or more is a mapping of its own, unmapped when freed;
* :func:`trim` (``malloc_trim(0)``) hands the free pages inside the heaps back, after a large
  request was answered.

Both are no-ops where the C library is not glibc (they return False).
"""
from __future__ import annotations

import ctypes
import ctypes.util
import functools
import logging
import threading
import time

log = logging.getLogger(__name__)

#: glibc's mallopt parameter numbers (malloc.h).
M_TRIM_THRESHOLD = -1
M_MMAP_THRESHOLD = -3
#: Blocks from this size up get a mapping of their own (glibc's starting value; fixed, not raised).
MMAP_THRESHOLD = 128 * 1024


@functools.lru_cache(maxsize=1)
def _glibc():
    name = ctypes.util.find_library("c")
    try:
        libc = ctypes.CDLL(name) if name else None
        return libc if libc is not None and hasattr(libc, "malloc_trim") and hasattr(libc, "mallopt") else None
    except OSError:
        return None


def map_large_blocks(threshold: int = MMAP_THRESHOLD) -> bool:
    """Give every allocation of ``threshold`` bytes or more a mapping of its own (returned to the
    system when freed) and keep at most that much free at a heap's top; True when set (glibc)."""
    libc = _glibc()
    if libc is None:
        return False
    ok = bool(libc.mallopt(M_MMAP_THRESHOLD, int(threshold))) and bool(libc.mallopt(M_TRIM_THRESHOLD, int(threshold)))
    if not ok:
        log.warning("mallopt refused the thresholds; freed memory may stay with the process")
    return ok


def trim() -> bool:
    """Hand the free pages of every heap back to the system (``malloc_trim(0)``); True when it did (glibc)."""
    libc = _glibc()
    return libc is not None and bool(libc.malloc_trim(0))


#: A payload from this size up counts as large: once one was handled, :class:`Trimmer` trims.
LARGE_BYTES = 1 << 20


class Trimmer:
    """Trims (:func:`trim`) once a second while a large payload (:data:`LARGE_BYTES` or more) was
    received within the last ``linger`` seconds: its buffers are freed once it is answered, which
    may be a while after it arrived. A process that receives small payloads alone never trims.

    ``note(size)`` is called with every payload's size (cheap: a comparison); :meth:`start` runs
    the trimming on a daemon thread until :meth:`close`."""

    def __init__(self, period: float = 1.0, linger: float = 5.0):
        self.period, self.linger = float(period), float(linger)
        self.trims = 0
        self._last_large: float | None = None
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, name="heap-trim", daemon=True)

    def note(self, size: int) -> None:
        """A payload of ``size`` bytes was received."""
        if size >= LARGE_BYTES:
            self._last_large = time.monotonic()

    def start(self) -> "Trimmer":
        """Start trimming on a daemon thread; returns self."""
        self._thread.start()
        return self

    def _run(self) -> None:
        while not self._stop.wait(self.period):
            last = self._last_large
            if last is not None and time.monotonic() - last <= self.linger:
                if trim():
                    self.trims += 1

    def close(self) -> None:
        """Stop trimming (idempotent)."""
        self._stop.set()
        if self._thread.is_alive():
            self._thread.join(timeout=5)
