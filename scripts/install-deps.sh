#!/usr/bin/env bash
# Installs the Debian 12 packages riskplan needs to build, test and run.
# Idempotent: when every package is already installed it changes nothing and
# does not touch the network. Run as root (or with sudo available).
set -euo pipefail

PACKAGES=(
  build-essential cmake ninja-build ccache pkg-config git
  # LLVM's linker: links the suite's many test programs in a third of the time.
  lld
  libabsl-dev nlohmann-json3-dev libssl-dev libpng-dev
  libgtest-dev libgmock-dev libbenchmark-dev
  libgrpc++-dev libprotobuf-dev protobuf-compiler protobuf-compiler-grpc
  prometheus-cpp-dev
  libgdal-dev libproj-dev gdal-bin
  # riskplan-web: its HTTP server, the page's libraries, and the browser
  # that its test drives (headless, through selenium and chromedriver).
  libcpp-httplib-dev libjs-leaflet libjs-chart.js
  chromium chromium-driver python3-selenium
  # The TLS tests make their certificates with the openssl CLI.
  openssl
  # The check of deploy/kubernetes reads its YAML.
  python3-yaml
)
# Extra packages a caller asks for (e.g. the benchmark script adds OMPL).
PACKAGES+=("$@")

missing=()
for p in "${PACKAGES[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$p")
  fi
done
if [ ${#missing[@]} -eq 0 ]; then
  exit 0
fi

SUDO=""
if [ "$(id -u)" -ne 0 ]; then SUDO="sudo"; fi
echo "install-deps: installing ${missing[*]}" >&2
$SUDO apt-get update -qq
DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}" >&2
