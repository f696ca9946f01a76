#!/usr/bin/env bash
# Checks every project #include against the dependency table of
# docs/architecture.md: a file may include headers of its own part and of the
# parts listed for it, and nothing of the parts above it. Third-party headers
# are checked where a part must stay free of them (core: no gRPC, Protobuf,
# GDAL, HTTP or prometheus; accel: no gRPC or Protobuf).
# Usage: layering_test.sh SOURCE_DIR. Prints every offending line; exit 1 if any.
set -euo pipefail
cd "$1"

# part -> the project folders its files may include (besides third-party).
declare -A allowed=(
  [core/base]="core/base"
  [core/map]="core/base core/map"
  [core/risk]="core/base core/map core/risk"
  [core/flight]="core/base core/map core/risk core/flight"
  [core/planners]="core/base core/map core/risk core/flight core/planners"
  [core/tools]="core/base core/map core/risk core/flight core/planners core/tools"
  [accel]="core accel"
  [server]="core accel server riskplan"
  [client]="client riskplan"
)
# Project include roots: an include starting with one of these is ours.
project_roots="core accel server client riskplan tests bench"
# Third-party prefixes a part must not include.
declare -A forbidden=(
  [core]="grpc grpcpp google/protobuf riskplan/ gdal ogr cpl_ proj httplib prometheus"
  [accel]="grpc grpcpp google/protobuf riskplan/ prometheus"
)

failures=0
checked=0
for part in "${!allowed[@]}"; do
  [ -d "$part" ] || { echo "layering: folder $part is missing"; failures=$((failures + 1)); continue; }
  while IFS= read -r file; do
    # accel's part covers its sub-folders; core's parts are disjoint.
    while IFS= read -r line; do
      inc=${line#*\"}
      inc=${inc%%\"*}
      checked=$((checked + 1))
      root=${inc%%/*}
      case " $project_roots " in *" $root "*) ;; *) continue ;; esac
      ok=0
      for a in ${allowed[$part]}; do
        if [[ "$inc" == "$a/"* ]]; then ok=1; break; fi
      done
      if [ $ok -eq 0 ]; then
        echo "layering: $file includes \"$inc\", outside what $part may use (${allowed[$part]})"
        failures=$((failures + 1))
      fi
    done < <(grep -E '^#include "' "$file" || true)
  done < <(find "$part" -name '*.h' -o -name '*.cc' | sort)
done

for top in "${!forbidden[@]}"; do
  while IFS= read -r file; do
    while IFS= read -r line; do
      inc=$(echo "$line" | sed -E 's/^#include [<"]([^>"]+)[>"].*/\1/')
      for f in ${forbidden[$top]}; do
        if [[ "$inc" == "$f"* ]]; then
          echo "layering: $file includes <$inc>: $top must not depend on $f"
          failures=$((failures + 1))
        fi
      done
    done < <(grep -E '^#include [<"]' "$file" || true)
  done < <(find "$top" -name '*.h' -o -name '*.cc' | sort)
done

# Every core source file belongs to one of the parts above.
while IFS= read -r file; do
  echo "layering: $file is not in a core part (base, map, risk, flight, planners, tools)"
  failures=$((failures + 1))
done < <(find core -maxdepth 1 -name '*.h' -o -maxdepth 1 -name '*.cc')

if [ "$checked" -lt 100 ]; then
  echo "layering: only $checked includes found; is $1 the source tree?"
  exit 1
fi
echo "layering: $checked includes checked, $failures outside the table"
[ "$failures" -eq 0 ]
