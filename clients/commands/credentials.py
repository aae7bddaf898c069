"""``acnmp credentials DIR``: write the secrets and zenoh configs of a router deployment (compose,
several hosts): fresh passwords per role, the router's dictionary and ACL, one config per role."""
from __future__ import annotations


def register(subparsers) -> None:
    """Add the ``credentials`` sub-command."""
    from services.transport.argtypes import endpoint, non_empty

    p = subparsers.add_parser("credentials", help="write per-role passwords, the router's ACL and zenoh configs",
                              description=__doc__.split(": ", 1)[1])
    p.add_argument("directory", type=non_empty, metavar="DIR", help="where to write users.txt, router.json5, <role>.json5 (mode 0600)")
    p.add_argument("--listen", type=endpoint, default=None, metavar="EP",
                   help="the router's endpoint (default: tls/0.0.0.0:7447 with --tls, else tcp/0.0.0.0:7447)")
    p.add_argument("--connect", type=endpoint, default=None, metavar="EP",
                   help="the endpoint the processes connect to (default: tls/router:7447 with --tls, else tcp/router:7447)")
    p.add_argument("--tls", type=non_empty, default=None, metavar="CERT_DIR",
                   help="mutual TLS with the certificates of scripts/make_tls_certs.sh, at CERT_DIR as the processes see it")
    p.add_argument("--at", type=non_empty, default=None, metavar="PATH",
                   help="where the processes see DIR (e.g. /etc/acnmp in the containers; default: DIR)")
    p.set_defaults(func=run)


def run(args) -> int:
    """Write the files, print each path and the role it is for; exit 0."""
    from services.transport.auth import write_router_deployment

    scheme = "tls" if args.tls else "tcp"
    written = write_router_deployment(args.directory, args.listen or f"{scheme}/0.0.0.0:7447",
                                      args.connect or f"{scheme}/router:7447", tls_dir=args.tls, at=args.at)
    for name, path in written.items():
        print(f"wrote {path}")
    print("give each process the config of its role (--config DIR/<role>.json5); keep users.txt on the router only")
    return 0
