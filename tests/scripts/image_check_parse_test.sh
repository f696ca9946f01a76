#!/usr/bin/env bash
# Checks how scripts/image-check.sh reads a Dockerfile (--print-dockerfile):
# `\` continuations joined as Docker joins them, comment and empty lines
# skipped also inside a continued RUN, `&&` and quotes kept; and that the
# repository's Dockerfile reads into the instructions that script runs.
# Usage: image_check_parse_test.sh SOURCE_DIR. Needs neither root nor
# debootstrap. Exits 1 on the first difference.
set -euo pipefail
SRC=$1
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT

cat >"$tmp/Dockerfile" <<'DOCKERFILE'
# a comment before FROM
FROM debian:12 AS build

RUN apt-get update \
 && apt-get install -y a \
# a comment inside the RUN
      b c \

 && rm -rf /var/lib/apt/lists/*
RUN   echo "x && y" \
 || true
COPY --from=build /src/build/bin/ /usr/local/bin/
ENTRYPOINT ["/usr/local/bin/x", "--flag=1"]
DOCKERFILE
cat >"$tmp/want" <<'WANT'
FROM debian:12 AS build
RUN apt-get update  && apt-get install -y a       b c  && rm -rf /var/lib/apt/lists/*
RUN   echo "x && y"  || true
COPY --from=build /src/build/bin/ /usr/local/bin/
ENTRYPOINT ["/usr/local/bin/x", "--flag=1"]
WANT
bash "$SRC/scripts/image-check.sh" --print-dockerfile="$tmp/Dockerfile" >"$tmp/got"
if ! diff -u "$tmp/want" "$tmp/got"; then
  echo "image_check_parse_test: the fixture reads differently" >&2
  exit 1
fi

# The repository's Dockerfile: two stages, the build stage's two RUN lines
# (install-deps.sh, then cmake and strip as one line), only instructions the
# script interprets.
bash "$SRC/scripts/image-check.sh" --print-dockerfile="$SRC/Dockerfile" >"$tmp/real"
[ "$(grep -c '^FROM ' "$tmp/real")" -eq 2 ] || { echo "image_check_parse_test: want 2 stages" >&2; exit 1; }
grep -qx 'RUN bash scripts/install-deps.sh && rm -rf /var/lib/apt/lists/\*' "$tmp/real" ||
  { echo "image_check_parse_test: no install-deps RUN line" >&2; exit 1; }
grep -Eq '^RUN cmake -S \. -B build .* && cmake --build build +&& strip build/bin/\*$' "$tmp/real" ||
  { echo "image_check_parse_test: the cmake RUN line is not one joined line" >&2; exit 1; }
if grep -Ev '^(FROM|WORKDIR|COPY|RUN|USER|EXPOSE|LABEL|ENTRYPOINT) ' "$tmp/real"; then
  echo "image_check_parse_test: instructions above are not interpreted by image-check.sh" >&2
  exit 1
fi
echo "image_check_parse_test: OK"
