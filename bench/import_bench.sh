#!/usr/bin/env bash
# The import benchmark (docs/benchmarks.md, "Import"): riskplan-tool import of
# an 8 km x 8 km area at 5 m (1600 x 1600 = 2.56 M cells) from rasters in other
# CRSs than the map's, timed with /usr/bin/time -v (wall clock and peak RSS).
#
# Inputs, written once with GDAL's command-line tools into $OUT/inputs:
#   dem.tif        UTM zone 32N, 30 m pixels (SRTM-like), 10 km x 10 km of hills
#   pop.tif        EPSG:4326, 3 arc-seconds (WorldPop-like), people per pixel
#   landcover.tif  EPSG:4326, 1/12000 deg (ESA WorldCover-like), its classes
#   nofly.geojson  two polygons (EPSG:4326)
# and the import derives landing sites from the land cover's open fields.
#
# Usage: bench/import_bench.sh [RUNS]   (default 5; BUILD_DIR=build)
# Prints each run and the medians.
set -euo pipefail
cd "$(dirname "$0")/.."
runs=${1:-5}
build=${BUILD_DIR:-build}
tool=$build/bin/riskplan-tool
out=$build/bench-import
[ -x "$tool" ] || { echo "import_bench: build riskplan-tool first (scripts/build.sh)" >&2; exit 1; }
[ -x /usr/bin/time ] || { echo "import_bench: needs /usr/bin/time (apt-get install time)" >&2; exit 1; }
mkdir -p "$out/inputs"
in=$out/inputs

lat=49.6116
lon=6.1319

if [ ! -f "$in/complete" ]; then
  # DEM: 334 x 334 pixels of 30 m in UTM 32N around the centre.
  read -r e n < <(echo "$lon $lat" | gdaltransform -s_srs EPSG:4326 -t_srs EPSG:32632 -output_xy)
  awk -v e="$e" -v n="$n" 'BEGIN {
    nc = 334; nr = 334; s = 30
    printf "ncols %d\nnrows %d\nxllcorner %.3f\nyllcorner %.3f\ncellsize %d\n", nc, nr, e - 5010, n - 5010, s
    for (r = 0; r < nr; r++) {
      line = ""
      for (c = 0; c < nc; c++) {
        x = c * s; y = (nr - r) * s
        z = 300 + 60 * sin(x / 900) * cos(y / 1300) + 25 * sin((x + y) / 400)
        line = line sprintf("%.2f ", z)
      }
      print line
    }
  }' >"$in/dem.asc"
  gdal_translate -q -a_srs EPSG:32632 -ot Float32 -co TILED=YES "$in/dem.asc" "$in/dem.tif"

  # Population: 3 arc-second pixels (1/1200 deg) over 0.18 x 0.12 deg.
  awk -v lat="$lat" -v lon="$lon" 'BEGIN {
    p = 1 / 1200; nc = 216; nr = 144; srand(11)
    printf "ncols %d\nnrows %d\nxllcorner %.9f\nyllcorner %.9f\ncellsize %.12f\n", nc, nr, lon - nc * p / 2, lat - nr * p / 2, p
    for (r = 0; r < nr; r++) {
      line = ""
      for (c = 0; c < nc; c++) {
        d = sqrt((c - nc / 2) ^ 2 + (r - nr / 2) ^ 2)
        line = line sprintf("%.2f ", 400 * exp(-d / 25) * (0.5 + rand()))
      }
      print line
    }
  }' >"$in/pop.asc"
  gdal_translate -q -a_srs EPSG:4326 -ot Float32 -co TILED=YES "$in/pop.asc" "$in/pop.tif"

  # Land cover: 1/12000 deg pixels over 0.15 x 0.10 deg, blocks of about
  # 200 m of trees, grass, crops, built-up, bare ground and water.
  awk -v lat="$lat" -v lon="$lon" 'BEGIN {
    p = 1 / 12000; nc = 1800; nr = 1200
    split("10 30 40 50 50 50 60 80 30 50", cls, " ")
    printf "ncols %d\nnrows %d\nxllcorner %.9f\nyllcorner %.9f\ncellsize %.12f\n", nc, nr, lon - nc * p / 2, lat - nr * p / 2, p
    for (r = 0; r < nr; r++) {
      line = ""
      for (c = 0; c < nc; c++) {
        k = (int(c / 28) * 7 + int(r / 19) * 13) % 10 + 1
        line = line cls[k] " "
      }
      print line
    }
  }' >"$in/landcover.asc"
  gdal_translate -q -a_srs EPSG:4326 -ot Byte -co TILED=YES -co COMPRESS=DEFLATE \
    "$in/landcover.asc" "$in/landcover.tif"

  cat >"$in/nofly.geojson" <<EOF
{"type": "FeatureCollection", "features": [
 {"type": "Feature", "properties": {"name": "airfield"}, "geometry": {"type": "Polygon",
  "coordinates": [[[6.17, 49.62], [6.16, 49.64], [6.15, 49.635], [6.16, 49.615], [6.17, 49.62]]]}},
 {"type": "Feature", "properties": {"name": "hospital"}, "geometry": {"type": "Polygon",
  "coordinates": [[[6.10, 49.60], [6.105, 49.60], [6.105, 49.603], [6.10, 49.603], [6.10, 49.60]]]}}
]}
EOF
  rm -f "$in"/*.asc "$in"/*.prj
  touch "$in/complete"
fi

command=("$tool" import --out="$out/map" --center="$lat,$lon" --size_m=8000 --res_m=5
         --terrain="$in/dem.tif" --population="$in/pop.tif" --population_unit=per_cell
         --landcover="$in/landcover.tif" --landcover_classes=worldcover
         --nofly="$in/nofly.geojson" --nofly_buffer_m=100 --landing_min_area_m2=20000
         --threads=2)
echo "command: ${command[*]}"
walls=()
cpus=()
rss=()
for k in $(seq "$runs"); do
  /usr/bin/time -v "${command[@]}" >"$out/run.log" 2>"$out/time.log"
  wall=$(awk -F': ' '/Elapsed \(wall clock\)/ {n = split($2, t, ":"); s = 0; for (i = 1; i <= n; i++) s = s * 60 + t[i]; print s}' "$out/time.log")
  kb=$(awk -F': ' '/Maximum resident set size/ {print $2}' "$out/time.log")
  cpu=$(awk -F': ' '/User time|System time/ {s += $2} END {print s}' "$out/time.log")
  walls+=("$wall")
  cpus+=("$cpu")
  rss+=("$kb")
  printf 'run %d: %.2f s wall, %.2f s CPU, %.0f MiB peak RSS; %s\n' "$k" "$wall" "$cpu" "$((kb / 1024))" \
    "$(grep '^note          timings' "$out/run.log" | sed 's/^note *//')"
done
median() { printf '%s\n' "$@" | sort -g | awk '{a[NR] = $1} END {print (NR % 2) ? a[(NR + 1) / 2] : (a[NR / 2] + a[NR / 2 + 1]) / 2}'; }
printf 'median of %d runs: %.2f s wall, %.2f s CPU (user + system), %.0f MiB peak RSS; load average %s\n' \
  "$runs" "$(median "${walls[@]}")" "$(median "${cpus[@]}")" \
  "$(echo "$(median "${rss[@]}") / 1024" | bc -l)" "$(cut -d' ' -f1-3 /proc/loadavg)"
grep -E '^(map|people|no-fly|landing sites) ' "$out/run.log"
