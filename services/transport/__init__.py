"""The transport wing: everything about talking over zenoh, nothing about robots or models.

======================  ===============================================================
module                  one job
======================  ===============================================================
``wire``                the msgpack codec (schema version, arrays, bounds), error codes,
                        field helpers, :func:`jsonable`
``errors``              exception -> wire error code, by type
``keys``                :class:`Keyspace`: every key expression of a namespace
``session``             zenoh config (loopback, no multicast), opening sessions,
                        :class:`SessionOptions` (the shared command-line options)
``lifetime``            signals, launcher watch, the stop event
``liveliness``          waiting for and listing liveliness tokens
``rpc``                 :func:`call` (the one RPC caller) and :func:`declare_rpc`
``service``             :class:`Service`, :func:`option`, :func:`run_service`, :func:`main`:
                        one way to configure and run any process
``argtypes``            argparse types with bounds, shared by every command line
``router``              :class:`RouterConfig`, a zenoh router process
``auth``                per-deployment passwords per role, the router's ACL, configs
``runfile``             the run file of a running deployment (discovery on one machine)
======================  ===============================================================
"""
from .errors import wire_error
from .keys import DEFAULT_NAMESPACE, Keyspace, check_name
from .lifetime import install_shutdown_handlers, wait_until_stopped
from .liveliness import alive_tokens, wait_for_liveliness, wait_for_liveliness_gone
from .rpc import RpcQueryable, call, declare_rpc
from .service import Ready, Service, main, option, run_service
from .session import SessionOptions, free_port, loopback_endpoint, make_config, open_session
from .wire import ERROR_CODES, SCHEMA_VERSION, WireError, decode, encode, jsonable

__all__ = [
    "wire_error", "DEFAULT_NAMESPACE", "Keyspace", "check_name", "install_shutdown_handlers", "wait_until_stopped",
    "alive_tokens", "wait_for_liveliness", "wait_for_liveliness_gone", "RpcQueryable", "call", "declare_rpc", "Ready", "Service", "main",
    "option", "run_service", "SessionOptions", "free_port", "loopback_endpoint", "make_config", "open_session",
    "ERROR_CODES", "SCHEMA_VERSION", "WireError", "decode", "encode", "jsonable",
]
