#!/usr/bin/env bash
# `cmake --install` puts riskplan-web in bin/ and the page's files, as they
# are in web/static, in share/riskplan/web/, where riskplan-web looks for them
# when the source tree it was built from is gone (tests/web/assets_dir_test.cc).
# Usage: install_test.sh BUILD_DIR SOURCE_DIR
set -euo pipefail
build=$1 source=$2
prefix=$(mktemp -d "${TMPDIR:-/tmp}/riskplan-install-test-XXXXXX")
trap 'rm -rf "$prefix"' EXIT
cmake --install "$build" --prefix "$prefix" >/dev/null
test -x "$prefix/bin/riskplan-web"
diff -r "$source/web/static" "$prefix/share/riskplan/web"
"$prefix/bin/riskplan-web" --help >/dev/null
echo "PASS: riskplan-web and its page installed under $prefix"
