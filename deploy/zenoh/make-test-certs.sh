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
# CLIENT defaults to: vessel-1 vessel-2 fleet-dashboard. When DIR already holds ca.pem
# and ca.key, that CA signs the new certificates (add a vessel to a fleet without
# invalidating the others'); the router's certificate is then kept too.
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
CNF=$(mktemp)
trap 'rm -f "$CNF"' EXIT
cat > "$CNF" <<CNF
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

if [ -s ca.pem ] && [ -s ca.key ]; then
    echo "$DIR: the CA already there signs the new certificates"
    reuse=1
else
    # shellcheck disable=SC2086 # $newkey is several words on purpose
    openssl req -x509 -config "$CNF" -extensions ca $newkey -days "$DAYS" \
        -subj "/CN=$CA_NAME" -keyout ca.key -out ca.pem 2>/dev/null
    reuse=0
fi

leaf() {  # stem, common name, extensions section
    # shellcheck disable=SC2086
    openssl req -new -config "$CNF" $newkey -subj "/CN=$2" -keyout "$1.key" -out "$1.csr" 2>/dev/null
    openssl x509 -req -in "$1.csr" -CA ca.pem -CAkey ca.key -set_serial "0x$(openssl rand -hex 8)" \
        -days "$DAYS" -extfile "$CNF" -extensions "$3" -out "$1.pem" 2>/dev/null
    rm -f "$1.csr"
}

[ "$reuse" = 1 ] && [ -s router.pem ] || leaf router localhost server
for name in "$@"; do
    case $name in
        */* | .* | "") echo "$0: not a certificate name: $name" >&2; exit 2 ;;
    esac
    leaf "$name" "$name" client
done
chmod 0644 ./*.pem
echo "$DIR: ca.pem, router.pem and $(printf '%s.pem ' "$@")(with their .key files)"
