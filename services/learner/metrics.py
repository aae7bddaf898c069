"""The learner's loss and return curves: a ``metrics`` event per validation or iteration for the
recording (services/recording/events.py), and one line every few seconds on stderr per skill or job."""
from __future__ import annotations

import logging
import time
from typing import Callable

from services.recording.events import metrics_event

log = logging.getLogger("services.learner")

#: Seconds between two stderr lines of one skill or job (the first and the last always print).
LINE_EVERY = 5.0


class MetricsReporter:
    """``report(...)``: publish a metrics event (a failure to publish is logged, never raised: a
    recording is not worth a training) and log ``line`` when ``every`` seconds passed since the
    source's last line, or when ``last``."""

    def __init__(self, publish: Callable[[dict], None], every: float = LINE_EVERY,
                 clock: Callable[[], float] = time.monotonic) -> None:
        self.publish, self.every, self.clock = publish, every, clock
        self._last_line: dict[str, float] = {}

    def report(self, source: str, phase: str, step: int, values: dict[str, float | None], line: str, *,
               last: bool = False) -> None:
        """One point of ``source``'s ``phase`` curves at ``step``; ``values`` None entries are left out."""
        try:
            self.publish(metrics_event(source, phase, step, values))
        except Exception:
            log.exception("could not publish the metrics of %s", source)
        now = self.clock()
        before = self._last_line.get(source)
        if last or before is None or now - before >= self.every:
            self._last_line[source] = now
            log.info("%s", line)
        if last:
            self._last_line.pop(source, None)
