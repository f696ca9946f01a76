#!/usr/bin/env bash
# Fetches the real geodata that riskplan's tests and docs/geodata.md use, from
# Debian packages only, without installing them (no R is installed):
#   r-cran-terra      ex/elev.tif   DEM of Luxembourg, EPSG:4326, Int16 with nodata
#                     ex/lux.shp    Luxembourg's 12 cantons with POP and AREA
#                     ex/meuse.tif  a raster near the Meuse, Dutch RD (oblique stereographic)
#   r-cran-satellite  extdata/DEM.TIF  a DEM in UTM zone 32N
# `apt-get download` (signed by Debian's archive keys, as any apt download) into
# a cache directory, then `dpkg-deb -x`. Runs once per cache; concurrent callers
# wait for the first.
#
# Usage: scripts/fetch-geodata.sh [CACHE_DIR]   (default: build/geodata)
# Prints the directory that holds terra/ and satellite/ (R's site-library
# layout) as its last line. Exits 1, saying why, when the packages cannot be
# fetched: tests that need the data then fail; they never skip.
set -euo pipefail
here=$(cd "$(dirname "$0")/.." && pwd)
cache=${1:-$here/build/geodata}
mkdir -p "$cache"
cache=$(cd "$cache" && pwd)
packages=(r-cran-terra r-cran-satellite)
lib=$cache/root/usr/lib/R/site-library
needed=(terra/ex/elev.tif terra/ex/lux.shp terra/ex/lux.dbf terra/ex/lux.shx terra/ex/lux.prj
        terra/ex/meuse.tif satellite/extdata/DEM.TIF)

exec 9>"$cache/.lock"
flock 9
if [ -f "$cache/complete" ]; then
  echo "$lib"
  exit 0
fi

die() {
  echo "fetch-geodata: $*" >&2
  exit 1
}

cd "$cache"
rm -f ./*.deb
if ! apt-get download "${packages[@]}" >"$cache/apt.log" 2>&1; then
  # A fresh machine has no package lists yet.
  echo "fetch-geodata: apt-get download failed; running apt-get update" >&2
  apt-get update >>"$cache/apt.log" 2>&1 || die "apt-get update failed (is the archive reachable? see $cache/apt.log)"
  apt-get download "${packages[@]}" >>"$cache/apt.log" 2>&1 ||
    die "apt-get download ${packages[*]} failed (see $cache/apt.log)"
fi
rm -rf "$cache/root"
for deb in ./*.deb; do
  dpkg-deb -x "$deb" "$cache/root" || die "dpkg-deb -x $deb failed"
done
for f in "${needed[@]}"; do
  [ -f "$lib/$f" ] || die "$f is not in the packages ${packages[*]}"
done
touch "$cache/complete"
echo "$lib"
