"""Publishing events on a session: the sending side of the recording."""
from __future__ import annotations

import zenoh

from services.transport import Keyspace, encode, wait_for_liveliness

from .events import event_key, validate_event


class EventPublisher:
    """Publishes the events of one namespace on an open session.

    Puts use ``CongestionControl.BLOCK``: an event is a record of what happened (the recorder
    must count every roll-out once), so it is better to slow the sender than to drop it.
    """

    def __init__(self, session: zenoh.Session, keys: Keyspace | str):
        self.session = session
        self.keys = keys if isinstance(keys, Keyspace) else Keyspace(keys)

    def publish(self, msg: dict) -> None:
        """Validate, encode and put one event (any kind)."""
        validate_event(msg)
        self.session.put(event_key(self.keys, msg), encode(msg), congestion_control=zenoh.CongestionControl.BLOCK)

    def wait_for_recorder(self, timeout: float = 10.0) -> bool:
        """Block until a recorder of this namespace is live (its liveliness token); True if found.

        Call it before the first event: a put made before the subscriber is known is lost.
        """
        try:
            wait_for_liveliness(self.session, self.keys.tokens("recorder"), timeout=timeout)
            return True
        except TimeoutError:
            return False
