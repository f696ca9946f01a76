#!/usr/bin/env bash
# Writes the seed corpus of geo_import_fuzz into DIR/geo_import/ (the
# committed fuzz/corpus/geo_import/ is its output): small inputs of every
# kind the importer reads, each covering the target's area near Luxembourg
# city (lat 49.6103-49.6117, lon 6.1286-6.1314), written by GDAL's own tools
# (gdal-bin) from text, in the target's format: a choice byte (see
# geo_import_fuzz.cc), the input's name line, its bytes, and any sibling
# file after a "%%file NAME" line.
# Usage: make_geo_seeds.sh DIR
set -euo pipefail
out=$1/geo_import
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
mkdir -p "$out"

# seed NAME CHOICE_BYTE_OCTAL INPUT_NAME FILE [SIBLING...]
seed() {
  local name=$1 choice=$2 input=$3 file=$4
  shift 4
  {
    printf "\\$choice"
    printf '%s\n' "$input"
    cat "$file"
    for sibling in "$@"; do
      printf '\n%%%%file %s\n' "$(basename "$sibling")"
      cat "$sibling"
    done
  } >"$out/$name"
}

# A DEM in EPSG:4326 as an ESRI ASCII grid (its CRS in dem.prj), and the same
# heights as a GeoTIFF in UTM 32N with a nodata value.
cat >"$tmp/dem.asc" <<'EOF'
ncols 8
nrows 6
xllcorner 6.126
yllcorner 49.608
cellsize 0.001
NODATA_value -9999
310 311 312 313 314 315 316 317
309 310 311 312 313 314 315 316
308 309 310 311 312 313 314 315
307 308 309 310 311 312 313 314
306 307 308 309 310 311 312 313
305 306 307 308 309 310 311 -9999
EOF
mkdir "$tmp/aai"
gdal_translate -q -a_srs EPSG:4326 -of AAIGrid "$tmp/dem.asc" "$tmp/aai/dem.asc"
seed terrain-ascii-grid 000 dem.asc "$tmp/aai/dem.asc" "$tmp/aai/dem.prj"
cat >"$tmp/utm.asc" <<'EOF'
ncols 8
nrows 8
xllcorner 292450
yllcorner 5499150
cellsize 50
NODATA_value -32768
300 301 302 303 304 305 306 307
301 302 303 304 305 306 307 308
302 303 304 305 306 307 308 309
303 304 305 306 307 308 309 310
304 305 306 307 308 309 310 311
305 306 307 308 309 310 311 312
306 307 308 309 310 311 312 313
307 308 309 310 311 312 313 -32768
EOF
gdal_translate -q -a_srs EPSG:32632 -ot Int16 -co COMPRESS=DEFLATE "$tmp/utm.asc" "$tmp/dem.tif"
seed terrain-geotiff-utm 000 dem.tif "$tmp/dem.tif"

# People per pixel (EPSG:4326, Float32), and land cover (WorldCover classes:
# 10 tree cover, 30 grassland, 50 built-up, 80 water), also read as CORINE
# codes and with open fields derived (choice 16 + 3 + 32 = 063 octal).
cat >"$tmp/pop.asc" <<'EOF'
ncols 4
nrows 3
xllcorner 6.126
yllcorner 49.608
cellsize 0.002
0 12.5 40 3
0 0 100 7.25
1 2 3 4
EOF
gdal_translate -q -a_srs EPSG:4326 -ot Float32 "$tmp/pop.asc" "$tmp/pop.tif"
seed population-geotiff 001 pop.tif "$tmp/pop.tif"
cat >"$tmp/lc.asc" <<'EOF'
ncols 8
nrows 6
xllcorner 6.126
yllcorner 49.608
cellsize 0.001
10 10 30 30 30 50 50 80
10 30 30 30 30 50 50 80
30 30 30 30 50 50 50 80
30 30 30 50 50 50 80 80
30 30 50 50 50 80 80 80
30 50 50 50 80 80 80 80
EOF
gdal_translate -q -a_srs EPSG:4326 -ot Byte "$tmp/lc.asc" "$tmp/lc.tif"
seed landcover-geotiff 003 lc.tif "$tmp/lc.tif"
seed landcover-corine-fields 063 lc.tif "$tmp/lc.tif"

# Census polygons with a count, building footprints (GeoJSON, and the same as
# a shapefile with its .shx, .dbf and .prj), no-fly zones (a polygon and a
# point, buffered), landing sites (points, names filtered by OGR SQL), and
# no-fly zones in OpenStreetMap XML.
cat >"$tmp/census.geojson" <<'EOF'
{"type":"FeatureCollection","features":[
{"type":"Feature","properties":{"pop":120},"geometry":{"type":"Polygon","coordinates":[[[6.126,49.608],[6.130,49.608],[6.130,49.614],[6.126,49.614],[6.126,49.608]]]}},
{"type":"Feature","properties":{"pop":35.5},"geometry":{"type":"Polygon","coordinates":[[[6.130,49.608],[6.134,49.608],[6.134,49.614],[6.130,49.614],[6.130,49.608]]]}}]}
EOF
seed population-polygons 002 census.geojson "$tmp/census.geojson"
cat >"$tmp/buildings.geojson" <<'EOF'
{"type":"FeatureCollection","features":[
{"type":"Feature","properties":{"building":"yes"},"geometry":{"type":"Polygon","coordinates":[[[6.1290,49.6105],[6.1293,49.6105],[6.1293,49.6108],[6.1290,49.6108],[6.1290,49.6105]]]}},
{"type":"Feature","properties":{"building":"house"},"geometry":{"type":"MultiPolygon","coordinates":[[[[6.1300,49.6110],[6.1302,49.6110],[6.1302,49.6111],[6.1300,49.6110]]]]}}]}
EOF
seed buildings-geojson 004 buildings.geojson "$tmp/buildings.geojson"
ogr2ogr -q -f "ESRI Shapefile" "$tmp/shp" "$tmp/buildings.geojson" -nln buildings
seed buildings-shapefile 004 buildings.shp "$tmp/shp/buildings.shp" "$tmp/shp/buildings.shx" \
  "$tmp/shp/buildings.dbf" "$tmp/shp/buildings.prj"
cat >"$tmp/zones.geojson" <<'EOF'
{"type":"FeatureCollection","features":[
{"type":"Feature","properties":{},"geometry":{"type":"Polygon","coordinates":[[[6.1295,49.6106],[6.1299,49.6106],[6.1299,49.6109],[6.1295,49.6106]]]}},
{"type":"Feature","properties":{},"geometry":{"type":"Point","coordinates":[6.1308,49.6113]}}]}
EOF
seed nofly-geojson 005 zones.geojson "$tmp/zones.geojson"
cat >"$tmp/sites.geojson" <<'EOF'
{"type":"FeatureCollection","features":[
{"type":"Feature","properties":{"name":"park"},"geometry":{"type":"Point","coordinates":[6.1290,49.6112]}},
{"type":"Feature","properties":{"name":null},"geometry":{"type":"Polygon","coordinates":[[[6.1305,49.6104],[6.1310,49.6104],[6.1310,49.6108],[6.1305,49.6104]]]}}]}
EOF
seed landing-geojson 006 'sites.geojson|where=name IS NOT NULL' "$tmp/sites.geojson"
cat >"$tmp/zones.osm" <<'EOF'
<?xml version="1.0" encoding="UTF-8"?>
<osm version="0.6">
<node id="1" lat="49.6106" lon="6.1295"/><node id="2" lat="49.6106" lon="6.1299"/>
<node id="3" lat="49.6109" lon="6.1299"/><node id="4" lat="49.6109" lon="6.1295"/>
<way id="10"><nd ref="1"/><nd ref="2"/><nd ref="3"/><nd ref="4"/><nd ref="1"/>
<tag k="aeroway" v="heliport"/><tag k="area" v="yes"/></way>
</osm>
EOF
seed nofly-osm 005 'zones.osm|layername=multipolygons' "$tmp/zones.osm"
