"""What every PyBullet simulator of the project shares: it owns one headless physics client."""
from __future__ import annotations

import pybullet as p


class PhysicsClient:
    """Base of a simulator that owns one PyBullet physics client, ``self._cid`` (set by the
    subclass's constructor, e.g. ``p.connect(p.DIRECT)``): :attr:`client_id` while it is open,
    :meth:`close` (idempotent), a context manager, and a best-effort close when collected (an
    un-closed client would leak its physics world)."""

    _cid: int | None = None

    @property
    def client_id(self) -> int:
        """The PyBullet client id; RuntimeError once the simulator is closed."""
        if self._cid is None:
            raise RuntimeError(f"{type(self).__name__}: the simulator is closed")
        return self._cid

    def close(self) -> None:
        """Disconnect the physics client (idempotent)."""
        if self._cid is not None:
            try:
                p.disconnect(physicsClientId=self._cid)
            finally:
                self._cid = None

    def __enter__(self):
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def __del__(self) -> None:
        try:
            self.close()
        except Exception:
            pass
