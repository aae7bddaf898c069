#!/usr/bin/env bash
# Make a private CA and certificates for zenoh TLS with mutual authentication (docs/PROTOCOL.md §1).
# Usage: bash scripts/make_tls_certs.sh DIR [ROUTER_HOST]
#   DIR/ca.pem, ca-key.pem        the CA (keep ca-key.pem offline)
#   DIR/router.pem, router-key.pem  the router's certificate, valid for ROUTER_HOST (default localhost)
#                                   and 127.0.0.1
#   DIR/client.pem, client-key.pem  one client certificate shared by the services (mTLS)
# Needs openssl. Certificates are valid for 365 days.
set -euo pipefail
dir=${1:?usage: make_tls_certs.sh DIR [ROUTER_HOST]}
host=${2:-localhost}
mkdir -p "$dir"
cd "$dir"
openssl req -x509 -newkey rsa:2048 -nodes -days 365 -subj "/CN=acnmp-ca" \
    -keyout ca-key.pem -out ca.pem 2>/dev/null
for name in router client; do
    openssl req -newkey rsa:2048 -nodes -subj "/CN=$name" -keyout "$name-key.pem" -out "$name.csr" 2>/dev/null
    if [ "$name" = router ]; then
        san="subjectAltName=DNS:$host,DNS:localhost,IP:127.0.0.1"
    else
        san="subjectAltName=DNS:client"
    fi
    openssl x509 -req -in "$name.csr" -CA ca.pem -CAkey ca-key.pem -CAcreateserial -days 365 \
        -extfile <(printf '%s\nbasicConstraints=CA:FALSE\n' "$san") -out "$name.pem" 2>/dev/null
    rm -f "$name.csr"
done
rm -f ca.srl
echo "wrote $dir/{ca,router,client}.pem and their keys"
