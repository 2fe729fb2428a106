#!/bin/sh
# Test PKI for the TLS tests, made fresh in DIR each run (nothing secret is
# checked in): a CA, a server certificate for localhost / 127.0.0.1 and a
# client certificate, all signed by the CA, plus a second CA that signed
# nothing the daemon trusts. EC P-256 keys: fast to make.
#   make_test_certs.sh DIR
set -eu
dir="$1"
mkdir -p "$dir"
cd "$dir"
key() { openssl genpkey -algorithm EC -pkeyopt ec_paramgen_curve:P-256 -out "$1" 2>/dev/null; }
ca() {  # name subject
  key "$1.key"
  openssl req -x509 -new -key "$1.key" -subj "$2" -days 2 -out "$1.crt" \
    -addext basicConstraints=critical,CA:TRUE -addext keyUsage=critical,keyCertSign,cRLSign
}
leaf() {  # name subject extensions-file
  key "$1.key"
  openssl req -new -key "$1.key" -subj "$2" -out "$1.csr"
  openssl x509 -req -in "$1.csr" -CA ca.crt -CAkey ca.key -CAcreateserial -days 2 \
    -extfile "$3" -out "$1.crt" 2>/dev/null
}
ca ca "/CN=pbgi test CA"
ca other-ca "/CN=pbgi other CA"
printf 'subjectAltName=DNS:localhost,IP:127.0.0.1,IP:::1\nextendedKeyUsage=serverAuth\n' > server.ext
printf 'extendedKeyUsage=clientAuth\n' > client.ext
leaf server "/CN=localhost" server.ext
leaf client "/CN=pbgi test client" client.ext
chmod 600 ./*.key
