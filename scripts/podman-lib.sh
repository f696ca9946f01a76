# Shared by scripts/image-build.sh and scripts/kube-drill.sh (sourced, not
# run): podman's settings, the Debian 12 base images made with debootstrap,
# phase timing, free loopback ports and the gRPC health probe.
# docs/deploy.md.

PODMAN_SRC=${PODMAN_SRC:-$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)}
# The project's podman settings (lowered ulimits, runc, cgroupfs); never
# written to /etc.
export CONTAINERS_CONF=${CONTAINERS_CONF:-$PODMAN_SRC/deploy/podman/containers.conf}
export PATH="$PATH:/usr/sbin:/sbin"

# The label that marks a base image as this script's debootstrap import.
BASE_LABEL=org.riskplan.base

die() { echo "${PROG:-podman-lib}: FAILED: $*" >&2; exit 1; }
say() { echo "${PROG:-podman-lib}: $*" >&2; }

# ---------------------------------------------------------------- timing
PHASES=()
TIMES=()
T_START=$(date +%s.%N)
now() { date +%s.%N; }
phase_start() { PHASE_NAME=$1; PHASE_T0=$(now); echo "== ${PROG}: $1 ==" >&2; }
phase_end() {
  local dt
  dt=$(awk -v a="$PHASE_T0" -v b="$(now)" 'BEGIN { printf "%.1f", b - a }')
  PHASES+=("$PHASE_NAME"); TIMES+=("$dt")
  echo "== ${PROG}: $PHASE_NAME done in ${dt} s ==" >&2
}
summary() {
  local i
  echo "${PROG}: phase times (s)"
  for i in "${!PHASES[@]}"; do printf '  %-72s %8s\n' "${PHASES[$i]}" "${TIMES[$i]}"; done
  printf '  %-72s %8s\n' "total" "$(awk -v a="$T_START" -v b="$(now)" 'BEGIN { printf "%.1f", b - a }')"
}

# The packages these scripts need, through the project's installer (which
# changes nothing when they are all there).
install_podman_deps() {
  bash "$PODMAN_SRC/scripts/install-deps.sh" podman buildah runc catatonit debootstrap python3-grpcio "$@" \
    || die "installing podman, buildah, runc, catatonit, debootstrap and python3-grpcio failed"
  command -v podman >/dev/null || die "podman is not installed"
  command -v runc >/dev/null || die "runc is not installed"
  command -v debootstrap >/dev/null || die "debootstrap is not installed"
}

# A free TCP port on 127.0.0.1 (nothing listens on it when asked).
free_port() {
  /usr/bin/python3 -c 'import socket; s = socket.socket(); s.bind(("127.0.0.1", 0)); print(s.getsockname()[1]); s.close()'
}

# health_status HOST:PORT: grpc.health.v1.Health/Check of the whole server
# (service ""), printed as SERVING, NOT_SERVING, ... or the call's error.
health_status() {
  /usr/bin/python3 "$PODMAN_SRC/scripts/grpc-health.py" "$1" 2>&1 || true
}

# wait_serving HOST:PORT SECONDS: until the health port says SERVING.
wait_serving() {
  local addr=$1 limit=$2 i st=""
  for ((i = 0; i < limit * 10; i++)); do
    st=$(health_status "$addr")
    [ "$st" = SERVING ] && return 0
    sleep 0.1
  done
  say "health of $addr after ${limit} s: $st"
  return 1
}

# ---------------------------------------------------------------- base images
# ensure_base_images WORKDIR MIRROR REBUILD: docker.io/library/debian:12 and
# :12-slim in podman's local storage, made with debootstrap (minbase
# bookworm, as Debian's official images are) and `podman import`, because no
# registry can be reached. Kept between runs (the Dockerfile's FROM lines
# find them by name); REBUILD=1 makes them again.
ensure_base_images() {
  local wd=$1 mirror=$2 rebuild=$3 have=0 img
  # Present is enough: no registry can be reached, so they were made here
  # (new ones carry the label $BASE_LABEL). Making them again changes their
  # ids, and so every cached layer of the image's build.
  for img in docker.io/library/debian:12 docker.io/library/debian:12-slim; do
    if podman image exists "$img"; then have=$((have + 1)); fi
  done
  if [ "$have" -eq 2 ] && [ "$rebuild" -eq 0 ]; then
    say "base images debian:12 and debian:12-slim are in local storage (made $(podman image inspect --format '{{.Created}}' docker.io/library/debian:12 | cut -c1-19)); --rebuild-base makes them again"
    return 0
  fi
  mkdir -p "$wd"
  local root="$wd/bookworm" slim="$wd/bookworm-slim"
  rm -rf --one-file-system "$root" "$slim"
  debootstrap --variant=minbase bookworm "$root" "$mirror" >"$wd/debootstrap.log" 2>&1 \
    || { tail -n 30 "$wd/debootstrap.log" >&2; die "debootstrap failed (log: $wd/debootstrap.log)"; }
  # apt as on the host, Debian's own sources only (third-party ones need
  # keyrings the root lacks); else the mirror given.
  rm -f "$root/etc/apt/sources.list"
  local f copied=0
  for f in /etc/apt/sources.list /etc/apt/sources.list.d/*.list /etc/apt/sources.list.d/*.sources; do
    [ -f "$f" ] || continue
    if grep -Eq '^[^#]*(https?://[^ ]*debian\.org)' "$f" \
       && ! grep -E '^[^#]*(URIs:|deb) ' "$f" | grep -Eqv 'debian\.org'; then
      mkdir -p "$root$(dirname "$f")"
      cp "$f" "$root$f"
      copied=1
    fi
  done
  [ "$copied" -eq 1 ] || echo "deb $mirror bookworm main" >"$root/etc/apt/sources.list"
  for f in /etc/apt/apt.conf.d/*; do
    if [ -f "$f" ] && grep -qi 'proxy' "$f"; then cp "$f" "$root$f"; fi
  done
  # As in Debian's images: no package lists or downloaded packages, an empty
  # resolv.conf (the engine provides it) and hostname.
  rm -rf "$root"/var/lib/apt/lists/* "$root"/var/cache/apt/archives/*.deb "$root"/var/cache/apt/*.bin
  : >"$root/etc/resolv.conf"
  echo localhost >"$root/etc/hostname"
  # The slim variant: Debian's slim images drop documentation (but the
  # copyright files), manuals and translations, now and in every later
  # package installation (dpkg path exclusions).
  cp -a "$root" "$slim"
  cat >"$slim/etc/dpkg/dpkg.cfg.d/riskplan-slim" <<'EOF'
path-exclude /usr/share/doc/*
path-include /usr/share/doc/*/copyright
path-exclude /usr/share/man/*
path-exclude /usr/share/groff/*
path-exclude /usr/share/info/*
path-exclude /usr/share/lintian/*
path-exclude /usr/share/linda/*
path-exclude /usr/share/locale/*
EOF
  find "$slim/usr/share/doc" -mindepth 1 ! -type d ! -name copyright -delete
  find "$slim/usr/share/doc" -mindepth 1 -type d -empty -delete
  rm -rf "$slim"/usr/share/{man,groff,info,lintian,linda,locale}/*
  local stamp
  stamp=$(date -u +%Y-%m-%dT%H:%M:%SZ)
  tar -C "$root" --numeric-owner -cf - . |
    podman import --change 'CMD ["bash"]' --change "LABEL $BASE_LABEL=debootstrap-bookworm-$stamp" \
      - docker.io/library/debian:12 >/dev/null || die "podman import of debian:12 failed"
  tar -C "$slim" --numeric-owner -cf - . |
    podman import --change 'CMD ["bash"]' --change "LABEL $BASE_LABEL=debootstrap-bookworm-slim-$stamp" \
      - docker.io/library/debian:12-slim >/dev/null || die "podman import of debian:12-slim failed"
  rm -rf --one-file-system "$root" "$slim"
  say "base images: debian:12 $(image_mb docker.io/library/debian:12) MB, debian:12-slim $(image_mb docker.io/library/debian:12-slim) MB"
}

# image_mb IMAGE: its size in MB (10^6 bytes), as `podman images` counts it.
image_mb() {
  podman image inspect --format '{{.Size}}' "$1" | awk '{ printf "%.1f", $1 / 1e6 }'
}
