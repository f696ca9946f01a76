#!/usr/bin/env bash
# Builds the image of ./Dockerfile with podman, runs it, and proves it: the
# plan across demo-city from the host's client, health, metrics, a drain on
# SIGTERM. Prints each phase's time and the image's size. Not part of CI (a
# cold build takes about half an hour on 2 cores). docs/deploy.md.
set -euo pipefail
export LC_ALL=C

usage() {
  cat <<'EOF'
Usage: bash scripts/image-build.sh [--no-cache] [--rebuild-base] [--tag=NAME]
                                   [--client=PATH] [--workdir=DIR] [--mirror=URL]

Builds ./Dockerfile, unchanged, with `podman build`, then runs the image:

  1. packages: podman, buildah, runc, debootstrap, python3-grpcio through
     scripts/install-deps.sh (nothing when they are installed);
  2. base images: docker.io/library/debian:12 and :12-slim, which the
     Dockerfile's FROM lines name, made with debootstrap (minbase bookworm)
     and `podman import` when local storage lacks them (no registry is
     reachable), and kept for later runs;
  3. build: `podman build --pull=never --network=host` (layers cached between
     runs; --no-cache for a cold build);
  4. the image: size, its user (not root), no compiler or build tool, every
     program's shared libraries resolve, `riskplan-server --help` works;
  5. serve: the image's ENTRYPOINT with a read-only root filesystem, on the
     host network, listening on free loopback ports (gRPC, health, metrics);
     time from `podman run` to the health port's SERVING;
  6. plan: the host's client (build/bin/riskplan) lists the maps and plans
     across demo-city against the container; the metrics page counts it;
  7. drain: `podman stop` (SIGTERM): health turns NOT_SERVING, the server
     exits 0 and logs its drain.

Exits non-zero, naming the phase, on any failure. Run as root. Settings for
podman come from deploy/podman/containers.conf (CONTAINERS_CONF).

  --no-cache       build every layer again (a cold build)
  --rebuild-base   make the debian:12 and debian:12-slim base images again
                   (their new ids make the next build cold)
  --tag=NAME       the image's name (default localhost/riskplan:latest)
  --client=PATH    the host's riskplan client (default build/bin/riskplan;
                   built with `ninja -C build riskplan` when missing and
                   build/ is configured)
  --workdir=DIR    scratch space for debootstrap and logs
                   (default /var/tmp/riskplan-image-build)
  --mirror=URL     Debian mirror for debootstrap (default http://deb.debian.org/debian)
  -h, --help       this text
EOF
}

PROG=image-build
SRC=$(cd "$(dirname "$0")/.." && pwd)
PODMAN_SRC=$SRC
# shellcheck source=scripts/podman-lib.sh
. "$SRC/scripts/podman-lib.sh"

NO_CACHE=0
REBUILD_BASE=0
TAG=localhost/riskplan:latest
CLIENT=$SRC/build/bin/riskplan
WORKDIR=/var/tmp/riskplan-image-build
MIRROR=http://deb.debian.org/debian
for arg in "$@"; do
  case "$arg" in
    -h | --help) usage; exit 0 ;;
    --no-cache) NO_CACHE=1 ;;
    --rebuild-base) REBUILD_BASE=1 ;;
    --tag=*) TAG=${arg#--tag=} ;;
    --client=*) CLIENT=${arg#--client=} ;;
    --workdir=*) WORKDIR=${arg#--workdir=} ;;
    --mirror=*) MIRROR=${arg#--mirror=} ;;
    *) die "unknown argument '$arg' (--help for usage)" ;;
  esac
done
[ "$(id -u)" -eq 0 ] || die "must run as root (podman builds and runs as root here)"
case "$WORKDIR" in /*) ;; *) WORKDIR="$PWD/$WORKDIR" ;; esac
[ "$WORKDIR" != / ] || die "--workdir=/ is not allowed"
mkdir -p "$WORKDIR"

CONTAINER=riskplan-image-build-$$
cleanup() {
  local rc=$?
  if podman container exists "$CONTAINER" 2>/dev/null; then
    podman rm -f -t 5 "$CONTAINER" >/dev/null 2>&1 || true
  fi
  if [ "${#PHASES[@]}" -gt 0 ]; then summary >&2; fi
  if [ "$rc" -ne 0 ]; then say "FAILED (exit $rc) in phase: ${PHASE_NAME:-setup}"; fi
  exit "$rc"
}
trap cleanup EXIT
trap 'exit 130' INT
trap 'exit 143' TERM

# ---------------------------------------------------------------- 1, 2
phase_start "packages (install-deps.sh + podman, runc, catatonit, debootstrap, ...)"
install_podman_deps
say "$(podman --version), $(runc --version | head -1), CONTAINERS_CONF=$CONTAINERS_CONF"
phase_end

phase_start "base images debian:12 and debian:12-slim (debootstrap + podman import)"
ensure_base_images "$WORKDIR/base" "$MIRROR" "$REBUILD_BASE"
phase_end

# ---------------------------------------------------------------- 3
# The build context: the checkout's tracked files (with their working-tree
# contents), what a clean clone holds; podman applies .dockerignore to it.
# Untracked files (a build/ directory, scratch files) never reach the image
# or its layer cache.
make_context() {
  local ctx=$1
  rm -rf --one-file-system "$ctx"
  mkdir -p "$ctx"
  (cd "$SRC" && git ls-files -z --cached | while IFS= read -r -d '' f; do
    [ -e "$f" ] && printf '%s\0' "$f"
  done | tar --null -T - -cf -) | tar -xf - -C "$ctx"
}
git -C "$SRC" rev-parse --git-dir >/dev/null 2>&1 || die "$SRC is not a git checkout (the build context is its tracked files)"
phase_start "podman build$([ "$NO_CACHE" -eq 1 ] && echo ' --no-cache')"
make_context "$WORKDIR/context"
say "context: $(git -C "$SRC" ls-files | wc -l) tracked files of $(git -C "$SRC" rev-parse --short HEAD)$(git -C "$SRC" diff --quiet HEAD -- . && echo '' || echo ' (with uncommitted changes)')"
build_args=(build --pull=never --network=host -f "$WORKDIR/context/Dockerfile" -t "$TAG")
[ "$NO_CACHE" -eq 0 ] || build_args+=(--no-cache)
podman "${build_args[@]}" "$WORKDIR/context" >"$WORKDIR/build.log" 2>&1 \
  || { tail -n 40 "$WORKDIR/build.log" >&2; die "podman build failed (log: $WORKDIR/build.log)"; }
grep -c -- '--> Using cache' "$WORKDIR/build.log" | xargs -I{} echo "image-build: {} layers from the cache" >&2 || true
phase_end

# ---------------------------------------------------------------- 4
phase_start "the image: size, user, contents, --help"
SIZE_MB=$(image_mb "$TAG")
USER_OF=$(podman image inspect --format '{{.Config.User}}' "$TAG")
[ -n "$USER_OF" ] && [ "$USER_OF" != root ] && [ "$USER_OF" != 0 ] || die "the image runs as '${USER_OF:-root}'"
RUN=(podman run --rm --network=host --read-only --read-only-tmpfs=false)
ids=$("${RUN[@]}" --entrypoint /usr/bin/id "$TAG")
say "runs as: $ids"
[[ "$ids" == uid=10001* ]] || die "the image's user is not uid 10001: $ids"
tools=$("${RUN[@]}" --entrypoint /bin/sh "$TAG" -c \
  'for t in gcc g++ cc c++ cpp ld ld.lld make cmake ninja ccache protoc strip as; do command -v $t || true; done')
# Debian 12's minbase has no compiler; `as`, `ld`, `strip` come with binutils.
[ -z "$tools" ] || die "build tools in the runtime image: $(tr '\n' ' ' <<<"$tools")"
devs=$("${RUN[@]}" --entrypoint /usr/bin/dpkg-query "$TAG" -W -f='${Package}\n' | grep -E -- '-dev(:|$)' || true)
[ -z "$devs" ] || die "development packages in the runtime image: $(tr '\n' ' ' <<<"$devs")"
# What the runtime stage adds to debian:12-slim: every package with its
# installed size (KiB), largest first.
"${RUN[@]}" --entrypoint /usr/bin/dpkg-query docker.io/library/debian:12-slim -W -f='${Package}\n' \
  | sort >"$WORKDIR/slim-packages.txt"
"${RUN[@]}" --entrypoint /usr/bin/dpkg-query "$TAG" -W -f='${Package} ${Installed-Size}\n' \
  | sort | join -v 1 - "$WORKDIR/slim-packages.txt" | sort -k2,2nr >"$WORKDIR/runtime-packages.txt"
say "the runtime stage adds $(wc -l <"$WORKDIR/runtime-packages.txt") packages to debian:12-slim, $(awk '{ s += $2 } END { printf "%.0f", s / 1024 }' "$WORKDIR/runtime-packages.txt") MiB installed (list: $WORKDIR/runtime-packages.txt); the largest:"
head -n 12 "$WORKDIR/runtime-packages.txt" | awk '{ printf "    %-36s %7.1f MiB\n", $1, $2 / 1024 }' >&2
lacking=$("${RUN[@]}" --entrypoint /bin/sh "$TAG" -c \
  'for b in /usr/local/bin/*; do m=$(ldd "$b" | grep "not found"); [ -z "$m" ] || echo "${b##*/}: $m"; done')
[ -z "$lacking" ] || die "programs lack shared libraries in the image: $lacking"
progs=$("${RUN[@]}" --entrypoint /bin/ls "$TAG" /usr/local/bin | tr '\n' ' ')
npkgs=$("${RUN[@]}" --entrypoint /usr/bin/dpkg-query "$TAG" -W -f='.\n' | wc -l)
"${RUN[@]}" "$TAG" --help >"$WORKDIR/help.out" 2>&1 || die "riskplan-server --help exited non-zero in the image"
grep -q 'riskplan-server --listen=HOST:PORT' "$WORKDIR/help.out" || die "riskplan-server --help printed no usage"
say "image $TAG: $SIZE_MB MB, $npkgs Debian packages, programs: $progs"
phase_end

# ---------------------------------------------------------------- 5
phase_start "serve: podman run to SERVING (read-only root, host network, loopback)"
GRPC_PORT=$(free_port); HEALTH_PORT=$(free_port); METRICS_PORT=$(free_port)
# The ENTRYPOINT as it is (--listen=0.0.0.0:50051), then the flags the
# Kubernetes manifest would add; the last --listen wins: loopback only.
podman run -d --name "$CONTAINER" --network=host --read-only --read-only-tmpfs=false --stop-timeout=30 "$TAG" \
  --listen=127.0.0.1:"$GRPC_PORT" --health_listen=127.0.0.1:"$HEALTH_PORT" \
  --metrics_listen=127.0.0.1:"$METRICS_PORT" --grace_period_ms=5000 >/dev/null \
  || die "podman run failed"
wait_serving 127.0.0.1:"$HEALTH_PORT" 120 || { podman logs "$CONTAINER" >&2; die "the health port did not say SERVING"; }
podman logs "$CONTAINER" 2>/dev/null | grep -q "^riskplan-server listening on 127.0.0.1:$GRPC_PORT" \
  || { podman logs "$CONTAINER" >&2; die "no readiness line 'riskplan-server listening on 127.0.0.1:$GRPC_PORT'"; }
say "serving: gRPC 127.0.0.1:$GRPC_PORT, health 127.0.0.1:$HEALTH_PORT, metrics 127.0.0.1:$METRICS_PORT"
phase_end

# ---------------------------------------------------------------- 6
phase_start "plan across demo-city from the host's client"
if [ ! -x "$CLIENT" ] && [ "$CLIENT" = "$SRC/build/bin/riskplan" ] && [ -f "$SRC/build/build.ninja" ]; then
  ninja -C "$SRC/build" riskplan >&2 || die "building the host's client failed"
fi
[ -x "$CLIENT" ] || die "no host client at $CLIENT (build it: README, or give --client=PATH)"
"$CLIENT" --server=127.0.0.1:"$GRPC_PORT" maps | tee "$WORKDIR/maps.out" >&2 || die "riskplan maps failed"
grep -q demo-city "$WORKDIR/maps.out" || die "the server has no demo-city"
set +e
"$CLIENT" --server=127.0.0.1:"$GRPC_PORT" plan --map=demo-city --start=1200,1500,250,0.785 \
  --goal=6800,6500,250,0.785 --budget_ms=10000 >"$WORKDIR/plan.out" 2>&1
plan_rc=$?
set -e
tail -n 3 "$WORKDIR/plan.out" >&2
[ "$plan_rc" -eq 0 ] || die "riskplan plan exited $plan_rc (3: no trajectory)"
grep -q '^best: risk ' "$WORKDIR/plan.out" || die "riskplan plan printed no trajectory"
/usr/bin/python3 - "$METRICS_PORT" >"$WORKDIR/metrics.out" <<'EOF' || die "the metrics page could not be read"
import sys, urllib.request
print(urllib.request.urlopen(f"http://127.0.0.1:{sys.argv[1]}/metrics", timeout=5).read().decode())
EOF
grep -E '^riskplan_[a-z_]+' "$WORKDIR/metrics.out" >/dev/null || die "the metrics page has no riskplan_ series"
grep -E '^riskplan_missions_in_flight' "$WORKDIR/metrics.out" >&2 || die "no riskplan_missions_in_flight on the metrics page"
grep -E '^grpc_server_handled_total|^riskplan_rpcs_total|PlanTrajectory' "$WORKDIR/metrics.out" | head -3 >&2 || true
phase_end

# ---------------------------------------------------------------- 7
phase_start "drain: podman stop (SIGTERM) to exit"
podman stop -t 30 "$CONTAINER" >/dev/null &
stop_pid=$!
# While it drains, the health port says NOT_SERVING (or is already closed).
st=$(health_status 127.0.0.1:"$HEALTH_PORT")
wait "$stop_pid" || die "podman stop failed"
exit_code=$(podman inspect --format '{{.State.ExitCode}}' "$CONTAINER")
podman logs "$CONTAINER" >"$WORKDIR/server.log" 2>&1 || true
[ "$exit_code" -eq 0 ] || { tail -n 20 "$WORKDIR/server.log" >&2; die "riskplan-server exited $exit_code after SIGTERM"; }
say "health during the stop: $st; exit code $exit_code; last log lines:"
tail -n 3 "$WORKDIR/server.log" >&2
phase_end

echo "image-build: OK: $TAG ($SIZE_MB MB) builds from the Dockerfile, runs read-only as uid 10001, plans demo-city, drains on SIGTERM" >&2
