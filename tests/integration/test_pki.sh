#!/usr/bin/env bash
# A throw-away PKI for the TLS tests, made with the openssl CLI at test time
# (no key material is committed). EC P-256 keys: fast to generate on a busy
# machine.
#
#   test_pki.sh init DIR
#       two CAs, DIR/ca-a.{pem,key} and DIR/ca-b.{pem,key}, each with its
#       openssl-ca database under DIR/ca-a/ and DIR/ca-b/
#   test_pki.sh issue DIR NAME CA CN SAN KIND START END
#       DIR/NAME.{pem,key}: CN, subjectAltName SAN ("" for none), signed by
#       CA (a or b), KIND server or client (extendedKeyUsage), valid from
#       START to END (YYYYMMDDHHMMSSZ, UTC)
#   test_pki.sh revoke DIR NAME CA
#       revokes DIR/NAME.pem and writes CA's CRL into DIR/crl-CA/ under its
#       hash name (what --tls_crl_dir and OpenSSL's hash lookup read)
#   test_pki.sh mismatch DIR NAME
#       DIR/NAME-other.key: a fresh key that does not match DIR/NAME.pem
set -euo pipefail

ca_config() {  # DIR CA
  local d="$1/ca-$2"
  cat <<EOF
[ca]
default_ca = ca_section
[ca_section]
database = $d/index.txt
new_certs_dir = $d/new
serial = $d/serial
crlnumber = $d/crlnumber
default_md = sha256
default_crl_days = 30
policy = policy_any
unique_subject = no
[policy_any]
commonName = supplied
EOF
}

case "$1" in
  init)
    dir=$2
    mkdir -p "$dir"
    for ca in a b; do
      mkdir -p "$dir/ca-$ca/new" "$dir/crl-$ca"
      : >"$dir/ca-$ca/index.txt"
      echo 1000 >"$dir/ca-$ca/serial"
      echo 1000 >"$dir/ca-$ca/crlnumber"
      ca_config "$dir" "$ca" >"$dir/ca-$ca/ca.cnf"
      openssl req -x509 -newkey ec -pkeyopt ec_paramgen_curve:P-256 -nodes -days 30 \
        -subj "/O=riskplan test/CN=riskplan test CA $ca" \
        -addext basicConstraints=critical,CA:TRUE -addext keyUsage=critical,keyCertSign,cRLSign \
        -keyout "$dir/ca-$ca.key" -out "$dir/ca-$ca.pem" 2>/dev/null
    done
    ;;
  issue)
    dir=$2 name=$3 ca=$4 cn=$5 san=$6 kind=$7 start=$8 end=$9
    ext="$dir/$name.ext"
    {
      echo "[v3]"
      echo "basicConstraints = CA:FALSE"
      echo "keyUsage = critical, digitalSignature, keyEncipherment"
      if [ "$kind" = server ]; then echo "extendedKeyUsage = serverAuth"; else echo "extendedKeyUsage = clientAuth"; fi
      if [ -n "$san" ]; then echo "subjectAltName = $san"; fi
    } >"$ext"
    openssl req -new -newkey ec -pkeyopt ec_paramgen_curve:P-256 -nodes \
      -subj "/O=riskplan test/CN=$cn" -keyout "$dir/$name.key" -out "$dir/$name.csr" 2>/dev/null
    openssl ca -batch -notext -config "$dir/ca-$ca/ca.cnf" -cert "$dir/ca-$ca.pem" \
      -keyfile "$dir/ca-$ca.key" -in "$dir/$name.csr" -out "$dir/$name.pem" \
      -startdate "$start" -enddate "$end" -extfile "$ext" -extensions v3 2>/dev/null
    rm -f "$dir/$name.csr" "$ext"
    ;;
  revoke)
    dir=$2 name=$3 ca=$4
    openssl ca -batch -config "$dir/ca-$ca/ca.cnf" -cert "$dir/ca-$ca.pem" -keyfile "$dir/ca-$ca.key" \
      -revoke "$dir/$name.pem" 2>/dev/null
    openssl ca -batch -config "$dir/ca-$ca/ca.cnf" -cert "$dir/ca-$ca.pem" -keyfile "$dir/ca-$ca.key" \
      -gencrl -out "$dir/crl-$ca.pem" 2>/dev/null
    rm -f "$dir/crl-$ca"/*
    cp "$dir/crl-$ca.pem" "$dir/crl-$ca/$(openssl crl -hash -noout -in "$dir/crl-$ca.pem").r0"
    ;;
  mismatch)
    dir=$2 name=$3
    openssl genpkey -algorithm ec -pkeyopt ec_paramgen_curve:P-256 -out "$dir/$name-other.key" 2>/dev/null
    ;;
  *)
    echo "usage: test_pki.sh init|issue|revoke|mismatch DIR ..." >&2
    exit 2
    ;;
esac
