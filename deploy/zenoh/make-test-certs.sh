#!/bin/sh
# A throwaway certificate authority and certificates for trying mutual TLS between
# zenoh routers and clients (router-tls.json5, the ship's router's link to shore):
#
#   deploy/zenoh/make-test-certs.sh DIR [CLIENT ...]
#
# writes into DIR (made if missing):
#   ca.pem, ca.key                 the CA (its key signs the others: keep it off the ships)
#   router.pem, router.key         the router's certificate, for ROUTER_NAMES
#   CLIENT.pem, CLIENT.key         one client certificate per CLIENT, its common name
#                                  being CLIENT (what router-tls.json5's access control
#                                  matches: vessel-<id>, fleet-dashboard)
# CLIENT defaults to: vessel-1 vessel-2 fleet-dashboard.
# Environment: ROUTER_NAMES (subjectAltName, default DNS:localhost,IP:127.0.0.1),
# DAYS (validity, default 30), CA_NAME (default "edged test site CA").
# For a real fleet use your organisation's PKI; these keys are not protected.
set -eu

if [ $# -lt 1 ]; then
    echo "usage: $0 DIR [CLIENT ...]" >&2
    exit 2
fi
command -v openssl >/dev/null || { echo "$0: openssl is not installed" >&2; exit 1; }
DIR=$1
shift
[ $# -gt 0 ] || set -- vessel-1 vessel-2 fleet-dashboard
ROUTER_NAMES=${ROUTER_NAMES:-DNS:localhost,IP:127.0.0.1}
DAYS=${DAYS:-30}
CA_NAME=${CA_NAME:-edged test site CA}

mkdir -p "$DIR"
cd "$DIR"
umask 077
cat > openssl.cnf <<CNF
[req]
distinguished_name = dn
prompt = no
[dn]
CN = unused
[ca]
basicConstraints = critical, CA:TRUE
keyUsage = critical, keyCertSign, cRLSign
subjectKeyIdentifier = hash
[server]
basicConstraints = critical, CA:FALSE
extendedKeyUsage = serverAuth
subjectAltName = $ROUTER_NAMES
[client]
basicConstraints = critical, CA:FALSE
extendedKeyUsage = clientAuth
CNF

newkey="-newkey ec -pkeyopt ec_paramgen_curve:prime256v1 -nodes"
serial=1000

# shellcheck disable=SC2086 # $newkey is several words on purpose
openssl req -x509 -config openssl.cnf -extensions ca $newkey -days "$DAYS" \
    -subj "/CN=$CA_NAME" -keyout ca.key -out ca.pem 2>/dev/null

leaf() {  # stem, common name, extensions section
    serial=$((serial + 1))
    # shellcheck disable=SC2086
    openssl req -new -config openssl.cnf $newkey -subj "/CN=$2" -keyout "$1.key" -out "$1.csr" 2>/dev/null
    openssl x509 -req -in "$1.csr" -CA ca.pem -CAkey ca.key -set_serial "$serial" -days "$DAYS" \
        -extfile openssl.cnf -extensions "$3" -out "$1.pem" 2>/dev/null
    rm -f "$1.csr"
}

leaf router localhost server
for name in "$@"; do
    case $name in
        */* | .* | "") echo "$0: not a certificate name: $name" >&2; exit 2 ;;
    esac
    leaf "$name" "$name" client
done
rm -f openssl.cnf
chmod 0644 ./*.pem
echo "$DIR: ca.pem, router.pem and $(printf '%s.pem ' "$@")(with their .key files)"
