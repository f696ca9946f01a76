#!/usr/bin/env bash
# deploy/kubernetes against the Kubernetes schemas, offline
# (scripts/manifest-validate.sh, the version pinned in deploy/validate/): every
# object is valid; and copies with known mistakes are refused, each named
# with its file, object and field path (a typo'd field, a port given as a
# name where a number is due, an unknown field deep in a volume). The first
# run installs the pinned validator from the npm registry (a few seconds);
# later runs take about a second.
# Usage: manifest_schema_test.sh SOURCE_DIR
set -euo pipefail
SRC=${1:?usage: manifest_schema_test.sh SOURCE_DIR}
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
fail() { echo "manifest_schema_test: $*" >&2; exit 1; }

bash "$SRC/scripts/manifest-validate.sh" "$SRC"/deploy/kubernetes/*.yaml >"$tmp/good" \
  || { cat "$tmp/good"; fail "deploy/kubernetes is not valid (above)"; }
grep -q ' 0 invalid (Kubernetes ' "$tmp/good" || { cat "$tmp/good"; fail "no summary line"; }
for kind in Deployment Service HorizontalPodAutoscaler NetworkPolicy ConfigMap; do
  grep -q "^valid .* $kind " "$tmp/good" || fail "no $kind was validated"
done

/usr/bin/python3 - "$SRC/deploy/kubernetes/riskplan-server.yaml" >"$tmp/bad.yaml" <<'PY'
import sys, yaml
docs = list(yaml.safe_load_all(open(sys.argv[1])))
d = docs[0]
c = d["spec"]["template"]["spec"]["containers"][0]
c["readinesProbe"] = c.pop("readinessProbe")
c["ports"][0]["containerPort"] = "grpc"
d["spec"]["template"]["spec"]["volumes"][1]["secret"]["defaultMod"] = 288
print(yaml.safe_dump_all([d, docs[1]]))
PY
set +e
bash "$SRC/scripts/manifest-validate.sh" "$tmp/bad.yaml" >"$tmp/bad" 2>&1
rc=$?
set -e
[ "$rc" -eq 1 ] || { cat "$tmp/bad"; fail "a broken manifest exited $rc, want 1"; }
for want in \
  'Deployment "riskplan-server": /spec/template/spec/containers/0/readinesProbe: unknown field "readinesProbe"' \
  'Deployment "riskplan-server": /spec/template/spec/containers/0/ports/0/containerPort must be integer' \
  'Deployment "riskplan-server": /spec/template/spec/volumes/1/secret/defaultMod: unknown field "defaultMod"' \
  'valid   '"$tmp"'/bad.yaml [document 1] v1 Service "riskplan-server"' \
  '2 objects, 1 invalid'; do
  grep -qF -- "$want" "$tmp/bad" || { cat "$tmp/bad"; fail "missing: $want"; }
done
echo "manifest_schema_test: OK ($(tail -n 1 "$tmp/good"))"
