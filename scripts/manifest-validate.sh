#!/usr/bin/env bash
# Validates Kubernetes manifests offline against the Kubernetes OpenAPI
# schemas bundled by the npm package kubernetes-models (the version pinned in
# deploy/validate/package-lock.json; its Kubernetes version is
# deploy/validate/package.json's kubernetesVersion): types, required fields,
# enums, formats, and unknown fields as an API server's strict field
# validation refuses them. No API server and no cluster: `kubectl apply
# --dry-run=client` cannot do this (it asks an API server for discovery).
# docs/deploy.md.
set -euo pipefail

usage() {
  cat <<'USAGE'
Usage: bash scripts/manifest-validate.sh [FILE.yaml ...]

Validates every object of every FILE (default: deploy/kubernetes/*.yaml).
Installs the pinned validator with `npm ci` (from the npm registry, once,
into $RISKPLAN_VALIDATE_DIR, default /var/tmp/riskplan-manifest-validate;
again only when deploy/validate/package-lock.json changes). Needs node and
npm (Debian 12's nodejs and npm, installed through scripts/install-deps.sh
when missing and run as root), and python3-yaml to read the YAML. Exit 0: all valid; 1: an object is
invalid (each error printed with its file, document and field path); 2: the
validator could not be installed or run.
USAGE
}

for arg in "$@"; do
  case "$arg" in -h | --help) usage; exit 0 ;; esac
done

SRC=$(cd "$(dirname "$0")/.." && pwd)
VDIR=${RISKPLAN_VALIDATE_DIR:-/var/tmp/riskplan-manifest-validate}
if [ "$#" -eq 0 ]; then
  set -- "$SRC"/deploy/kubernetes/*.yaml
fi
# node and npm: Debian 12's nodejs and npm, installed through the project's
# installer when missing and run as root (an installed node that brings its
# own npm is left alone).
missing=()
command -v node >/dev/null || missing+=(nodejs)
command -v npm >/dev/null || missing+=(npm)
if [ "${#missing[@]}" -gt 0 ]; then
  if [ "$(id -u)" -eq 0 ]; then
    bash "$SRC/scripts/install-deps.sh" "${missing[@]}" >&2 \
      || { echo "manifest-validate: installing ${missing[*]} failed" >&2; exit 2; }
  else
    echo "manifest-validate: ${missing[*]} not installed (as root: bash scripts/install-deps.sh ${missing[*]})" >&2
    exit 2
  fi
fi
/usr/bin/python3 -c 'import yaml' 2>/dev/null || { echo "manifest-validate: python3-yaml is not installed" >&2; exit 2; }

# The validator, installed from the lock file (exact versions and hashes).
mkdir -p "$VDIR"
if ! cmp -s "$SRC/deploy/validate/package-lock.json" "$VDIR/package-lock.json" \
   || [ ! -d "$VDIR/node_modules/kubernetes-models" ]; then
  cp "$SRC/deploy/validate/package.json" "$SRC/deploy/validate/package-lock.json" "$VDIR/"
  (cd "$VDIR" && npm ci --ignore-scripts --no-audit --no-fund --loglevel=error >&2) \
    || { rm -f "$VDIR/package-lock.json"; echo "manifest-validate: npm ci failed in $VDIR" >&2; exit 2; }
fi

# YAML -> one JSON of every document (empty documents skipped), then node.
/usr/bin/python3 - "$@" <<'PY' | NODE_PATH="$VDIR/node_modules" node "$SRC/deploy/validate/validate.js"
import json, sys, yaml
docs = []
for name in sys.argv[1:]:
    try:
        with open(name) as f:
            for i, obj in enumerate(yaml.safe_load_all(f)):
                if obj is not None:
                    docs.append({"file": name, "index": i, "object": obj})
    except (OSError, yaml.YAMLError) as e:
        print(f"manifest-validate: {name}: {e}", file=sys.stderr)
        sys.exit(2)
json.dump({"documents": docs}, sys.stdout, default=str)
PY
