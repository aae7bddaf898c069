"""The recorder's options (``acnmp serve recorder``, ``python -m services.recording``): rerun-free,
so a command line is built and checked without importing what the recorder runs;
:class:`~services.recording.recorder.RecorderConfig` adds what runs it (services/recording/recorder.py)."""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import ClassVar

from services.transport import Service, option
from services.transport.argtypes import int_at_least, non_empty


@dataclass
class RecorderOptions(Service):
    """The recorder's options; ``final`` is filled by
    :meth:`~services.recording.recorder.RecorderConfig.serve` with the counts written."""

    name: ClassVar[str] = "recorder"
    summary: ClassVar[str] = "the recorder: writes every event into a .rrd file"

    out: str = option("runs/recording.rrd", "recording to write (default: %(default)s)", short="-o",
                      metavar="FILE.rrd", type=non_empty)
    recording_id: str | None = option(None, "Rerun recording id (default: a new one); a recorder restarted by "
                                            "its launcher keeps the id, so its files merge into one recording",
                                      metavar="ID")
    seen: list[str] = option([], "a file an earlier recorder of this deployment wrote (repeatable, oldest first): "
                                 "its events are not recorded again when the publishers' caches replay them",
                             metavar="FILE.rrd")
    serve_grpc: int | None = option(None, "also stream what is recorded live over Rerun's gRPC server on "
                                          "127.0.0.1:PORT (viewers: rerun --connect rerun+http://127.0.0.1:PORT/proxy)",
                                    metavar="PORT", type=int_at_least(1, hi=65535))
    web_viewer: int | None = option(None, "with --serve-grpc: also host Rerun's web viewer on 127.0.0.1:PORT, "
                                          "connected to that stream", metavar="PORT", type=int_at_least(1, hi=65535))
    final: dict = field(default_factory=dict, init=False, repr=False)
