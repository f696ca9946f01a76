#!/usr/bin/env bash
# Checks every project #include against the dependency table of
# docs/architecture.md: a file may include headers of its own part and of the
# parts listed for it, and nothing of the parts above it. Third-party headers
# are checked where a part must stay free of them (cmdline, core, accel and
# geo/export: no gRPC, Protobuf, GDAL, PROJ, HTTP or Prometheus; geo and tools:
# no gRPC, Protobuf, HTTP or Prometheus; client: no GDAL or PROJ; web: no GDAL,
# PROJ or Prometheus).
# Usage: layering_test.sh SOURCE_DIR. Prints every offending include; exits 1
# if there is one, or if it found too few includes to have checked anything.
set -euo pipefail
cd "$1"

# Every #include line of the checked folders, as FILE<TAB>HEADER.
includes=$(find cmdline core accel $(ls -d net formats 2>/dev/null) geo tools server client web -name '*.h' -o -name '*.cc' | sort |
  xargs grep -HE '^#include [<"]' |
  sed -E 's/^([^:]+):#include [<"]([^>"]+)[>"].*/\1\t\2/')

# Every core source file belongs to one of its parts.
stray=$(find core -maxdepth 1 -name '*.h' -o -maxdepth 1 -name '*.cc')
if [ -n "$stray" ]; then
  echo "layering: not in a core part (base, map, risk, flight, planners): $stray"
  exit 1
fi

echo "$includes" | awk -F'\t' '
BEGIN {
  # part -> the project folders its files may include.
  allowed["cmdline"] = "cmdline"
  allowed["core/base"] = "core/base"
  allowed["core/map"] = "core/base core/map"
  allowed["core/risk"] = "core/base core/map core/risk"
  allowed["core/flight"] = "core/base core/map core/risk core/flight formats"
  allowed["core/planners"] = "core/base core/map core/risk core/flight core/planners formats"
  allowed["geo"] = "core geo"
  # The ground-station and GIS writers: plain values in, text out, so that
  # the client (which links neither core nor GDAL) can use them.
  allowed["geo/export"] = "geo/export"
  allowed["tools"] = "core geo tools cmdline"
  allowed["accel"] = "core accel net cmdline"
  # Sockets with deadlines and TLS: the shim link and the server both use them.
  allowed["net"] = "net"
  # The trajectory JSON rule, parsed once for core and the client (neither
  # links the other): abseil and nlohmann-json only.
  allowed["formats"] = "formats"
  # server/: one room a library, each using only the rooms below it:
  # models < api < observability < security < plan < fleet < flight < the service.
  srv = "core accel net geo riskplan cmdline"
  allowed["server/models"] = srv " server/models"
  allowed["server/api"] = allowed["server/models"] " server/api"
  allowed["server/observability"] = allowed["server/api"] " server/observability"
  allowed["server/security"] = allowed["server/observability"] " server/security"
  allowed["server/plan"] = allowed["server/security"] " server/plan"
  allowed["server/fleet"] = allowed["server/plan"] " server/fleet"
  allowed["server/flight"] = allowed["server/fleet"] " server/flight"
  allowed["server"] = allowed["server/flight"] " server"
  # client/ is the library; pictures, the load generator and the CLI use it.
  allowed["client"] = "client riskplan cmdline geo/export formats"
  allowed["client/picture"] = "client client/picture riskplan geo/export"
  allowed["client/load"] = "client client/load riskplan"
  allowed["client/cli"] = "client client/picture client/load client/cli riskplan cmdline geo/export"
  # riskplan-web: a client of the server through the public API only, and of
  # the client library only (not the CLI, pictures or load generator).
  allowed["web"] = "web client riskplan cmdline geo/export"
  # Rooms whose sub-rooms are listed one by one: "server" in a list allows
  # server/*.h only, not server/api/*.h.
  exact["server"] = 1; exact["client"] = 1
  # An include whose first folder is one of these is the project'"'"'s own.
  split("cmdline core accel net formats geo tools server client web riskplan tests bench", roots, " ")
  for (r in roots) own[roots[r]] = 1
  # Third-party prefixes a top-level part must not include.
  forbidden["cmdline"] = "grpc grpcpp google/protobuf gdal ogr cpl_ proj httplib prometheus"
  forbidden["core"] = "grpc grpcpp google/protobuf gdal ogr cpl_ proj httplib prometheus"
  forbidden["accel"] = "grpc grpcpp google/protobuf gdal ogr cpl_ proj httplib prometheus"
  forbidden["net"] = forbidden["accel"]
  forbidden["formats"] = forbidden["accel"]
  forbidden["geo"] = "grpc grpcpp google/protobuf httplib prometheus"
  forbidden["geo/export"] = "grpc grpcpp google/protobuf gdal ogr cpl_ proj geodesic httplib prometheus"
  forbidden["tools"] = "grpc grpcpp google/protobuf httplib prometheus"
  # The client links no map projection: WGS84 comes from the server.
  forbidden["client"] = "gdal ogr cpl_ proj geodesic png"
  # Only the pictures draw PNG files.
  forbidden["client/picture"] = "gdal ogr cpl_ proj geodesic"
  forbidden["client/cli"] = forbidden["client"]
  forbidden["client/load"] = forbidden["client"]
  # Nor does the gateway, which also serves no metrics of its own.
  forbidden["web"] = "gdal ogr cpl_ proj geodesic prometheus"
  failures = 0; checked = 0
}
{
  file = $1; inc = $2; checked++
  n = split(file, parts, "/")
  part = parts[1]
  if (part == "geo" && n >= 3 && parts[2] == "export") part = "geo/export"
  if ((part == "server" || part == "client") && n >= 3) {
    part = part "/" parts[2]
    if (!(part in allowed)) { print "layering: " file " is in " part ", which the table does not list"; failures++; next }
  }
  if (part == "core") {
    if (n < 3) { print "layering: " file " is not in a core part (base, map, risk, flight, planners)"; failures++; next }
    part = "core/" parts[2]
    if (!(part in allowed)) { print "layering: " file " is in " part ", which the table does not list"; failures++; next }
  }
  split(inc, ip, "/")
  if (ip[1] in own && index(inc, "/") > 0) {
    ok = 0
    m = split(allowed[part], list, " ")
    for (k = 1; k <= m; k++) {
      if (index(inc, list[k] "/") != 1) continue
      # An exact room allows its own headers, not those of its sub-rooms.
      if ((list[k] in exact) && index(substr(inc, length(list[k]) + 2), "/") > 0) continue
      ok = 1
    }
    if (!ok) { print "layering: " file " includes \"" inc "\", outside what " part " may use (" allowed[part] ")"; failures++ }
  }
  top = parts[1]
  if (part == "geo/export" || (part in forbidden)) top = part
  if (top in forbidden) {
    m = split(forbidden[top], bad, " ")
    for (k = 1; k <= m; k++) if (index(inc, bad[k]) == 1) { print "layering: " file " includes <" inc ">: " top " must not depend on " bad[k]; failures++; break }
  }
}
END {
  if (checked < 100) { print "layering: only " checked " includes found; is this the source tree?"; exit 1 }
  print "layering: " checked " includes checked, " failures " outside the table"
  exit failures > 0
}'
