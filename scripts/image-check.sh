#!/usr/bin/env bash
# Proves the Dockerfile's steps without a container engine: builds Debian 12
# roots with debootstrap and runs the Dockerfile in them with chroot.
#
# The Dockerfile itself is read and interpreted (FROM, WORKDIR, COPY, RUN,
# USER, EXPOSE, ENTRYPOINT; anything else is an error), so this script runs
# exactly the Dockerfile's RUN lines and cannot drift from it. Then it starts
# the runtime stage's ENTRYPOINT in the runtime root as the stage's USER, on a
# free loopback port, and plans across demo-city with the client of the same
# root. Not part of CI (a cold build: about half an hour on 2 cores).
set -euo pipefail

usage() {
  cat <<'EOF'
Usage: bash scripts/image-check.sh [--workdir=DIR] [--reuse] [--keep] [--mirror=URL]
       bash scripts/image-check.sh --print-dockerfile[=FILE]

Builds the image described by ./Dockerfile without a container engine:

  1. debootstrap --variant=minbase bookworm: one pristine Debian 12 root,
     copied for each stage (FROM debian:12 and FROM debian:12-slim);
  2. build stage: the checkout's tracked files (git ls-files) as the build
     context, the Dockerfile's COPY and RUN lines run in the root with chroot
     (install-deps.sh, then the cmake configure, build and strip);
  3. runtime stage: its RUN line (apt-get install of the runtime libraries,
     useradd) and the COPY --from=build of build/bin/ to /usr/local/bin/;
  4. starts the ENTRYPOINT (plus --listen=127.0.0.1:0) in the runtime root as
     the stage's USER, waits for it, runs `riskplan maps` and `riskplan plan`
     on demo-city with that root's client, checks that a trajectory was found,
     and stops the server with SIGTERM.

Prints the time of each phase and the total. Exits non-zero on any failure.
Run as root; installs debootstrap with apt-get when it is missing.

  --workdir=DIR  where the roots go (default /var/tmp/riskplan-image-check)
  --reuse        reuse the pristine bootstrap of an earlier run in DIR, if it
                 finished (default: start clean, deleting DIR's roots)
  --keep         keep the roots on disk at the end (default: delete them)
  --mirror=URL   Debian mirror for debootstrap (default http://deb.debian.org/debian)
  --print-dockerfile[=FILE]
                 print FILE's (default ./Dockerfile) instructions as this script
                 reads them, one a line (continuations joined, comments dropped),
                 and exit; needs neither root nor debootstrap
  -h, --help     this text
EOF
}

WORKDIR=/var/tmp/riskplan-image-check
REUSE=0
KEEP=0
MIRROR=http://deb.debian.org/debian
PRINT=""
for arg in "$@"; do
  case "$arg" in
    -h | --help) usage; exit 0 ;;
    --workdir=*) WORKDIR=${arg#--workdir=} ;;
    --reuse) REUSE=1 ;;
    --keep) KEEP=1 ;;
    --mirror=*) MIRROR=${arg#--mirror=} ;;
    --print-dockerfile) PRINT=Dockerfile ;;
    --print-dockerfile=*) PRINT=${arg#--print-dockerfile=} ;;
    *) echo "image-check: unknown argument '$arg' (--help for usage)" >&2; exit 1 ;;
  esac
done

die() { echo "image-check: FAILED: $*" >&2; exit 1; }

# ---------------------------------------------------------------- Dockerfile
# The Dockerfile as one instruction per line: comments dropped, `\` line
# continuations joined (as Docker does: the backslash and the line break
# removed, the lines' text kept as it is), outer white space trimmed.
parse_dockerfile() {
  local line joined=""
  while IFS= read -r line || [ -n "$line" ]; do
    # Comment and empty lines are skipped, also inside a continued
    # instruction (as Docker does).
    [[ "$line" =~ ^[[:space:]]*(#|$) ]] && continue
    if [[ "$line" =~ ^(.*)\\[[:space:]]*$ ]]; then
      joined+="${BASH_REMATCH[1]}"
      continue
    fi
    joined+="$line"
    joined=$(sed -E 's/^[[:space:]]+//; s/[[:space:]]+$//' <<<"$joined")
    printf '%s\n' "$joined"
    joined=""
  done <"$1"
  [ -z "$joined" ] || printf '%s\n' "$joined"
}

if [ -n "$PRINT" ]; then
  [ -f "$PRINT" ] || die "no such file: $PRINT"
  parse_dockerfile "$PRINT"
  exit 0
fi

[ "$(id -u)" -eq 0 ] || die "must run as root (debootstrap, mount and chroot need it)"
case "$WORKDIR" in /*) ;; *) WORKDIR="$PWD/$WORKDIR" ;; esac
[ "$WORKDIR" != / ] || die "--workdir=/ is not allowed"

SRC=$(cd "$(dirname "$0")/.." && pwd)
DOCKERFILE="$SRC/Dockerfile"
[ -f "$DOCKERFILE" ] || die "no Dockerfile in $SRC"
git -C "$SRC" rev-parse --git-dir >/dev/null 2>&1 || die "$SRC is not a git checkout (the build context is its tracked files)"

if ! command -v debootstrap >/dev/null 2>&1; then
  if ! dpkg-query -W -f='${Status}' debootstrap 2>/dev/null | grep -q "install ok installed"; then
    echo "image-check: installing debootstrap" >&2
    apt-get update -qq
    DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends debootstrap >&2
  fi
  export PATH="$PATH:/usr/sbin:/sbin"
  command -v debootstrap >/dev/null 2>&1 || die "debootstrap is missing and could not be installed"
fi

# ---------------------------------------------------------------- timing
PHASES=()
TIMES=()
T_START=$(date +%s)
phase_start() { PHASE_NAME=$1; PHASE_T0=$(date +%s); echo "== image-check: $1 ==" >&2; }
phase_end() {
  local dt=$(($(date +%s) - PHASE_T0))
  PHASES+=("$PHASE_NAME"); TIMES+=("$dt")
  echo "== image-check: $PHASE_NAME done in ${dt} s ==" >&2
}
summary() {
  local i
  echo "image-check: phase times (s)"
  for i in "${!PHASES[@]}"; do printf '  %-60s %6d\n' "${PHASES[$i]}" "${TIMES[$i]}"; done
  printf '  %-60s %6d\n' "total" "$(($(date +%s) - T_START))"
}

# ---------------------------------------------------------------- cleanup
MOUNTS=()     # every mount made, unmounted in reverse order on exit
SERVER_PID=""
cleanup() {
  local rc=$? i m
  if [ -n "$SERVER_PID" ] && kill -0 "$SERVER_PID" 2>/dev/null; then
    kill -TERM "$SERVER_PID" 2>/dev/null || true
    sleep 2
    kill -KILL "$SERVER_PID" 2>/dev/null || true
  fi
  for ((i = ${#MOUNTS[@]} - 1; i >= 0; i--)); do
    m=${MOUNTS[$i]}
    if mountpoint -q "$m"; then
      umount "$m" 2>/dev/null || umount -l "$m" || echo "image-check: cannot unmount $m" >&2
    fi
  done
  # Nothing under WORKDIR may stay mounted (and nothing is deleted if it is).
  if grep -q " $WORKDIR/" /proc/mounts; then
    echo "image-check: mounts left under $WORKDIR:" >&2
    grep " $WORKDIR/" /proc/mounts >&2
    rc=1
  elif [ "$KEEP" -eq 0 ] && [ -d "$WORKDIR" ]; then
    rm -rf --one-file-system "$WORKDIR/root-"* "$WORKDIR/context" "$WORKDIR/base"
  fi
  if [ "${#PHASES[@]}" -gt 0 ]; then summary >&2; fi
  if [ "$rc" -ne 0 ]; then
    echo "image-check: FAILED (exit $rc) in phase: ${PHASE_NAME:-setup}" >&2
  fi
  exit "$rc"
}
trap cleanup EXIT
trap 'exit 130' INT
trap 'exit 143' TERM

mount_in() {  # mount_in ROOT: proc, sys, dev and dev/pts inside ROOT
  local root=$1
  mount -t proc proc "$root/proc"; MOUNTS+=("$root/proc")
  mount -t sysfs sysfs "$root/sys"; MOUNTS+=("$root/sys")
  # Binds made slaves: nothing mounted or unmounted under them reaches the
  # host's /dev (which may be a shared mount).
  mount --bind /dev "$root/dev"; MOUNTS+=("$root/dev"); mount --make-rslave "$root/dev"
  mount --bind /dev/pts "$root/dev/pts"; MOUNTS+=("$root/dev/pts"); mount --make-rslave "$root/dev/pts"
}
umount_in() {
  local root=$1 m
  for m in dev/pts dev sys proc; do
    if mountpoint -q "$root/$m"; then umount "$root/$m" || umount -l "$root/$m"; fi
  done
}

# in_root ROOT DIR COMMAND: runs COMMAND with /bin/sh -c in ROOT, from DIR,
# with the clean environment a container's RUN line has.
in_root() {
  local root=$1 dir=$2 cmd=$3
  chroot "$root" /usr/bin/env -i HOME=/root \
    PATH=/usr/local/sbin:/usr/local/bin:/usr/sbin:/usr/bin:/sbin:/bin \
    /bin/sh -c "mkdir -p \"\$1\" && cd \"\$1\" && $cmd" sh "$dir"
}

# The build context: the checkout's tracked files (with their working-tree
# contents), minus what .dockerignore excludes: what `COPY . .` would see in
# a clean clone.
make_context() {
  local ctx=$1
  rm -rf --one-file-system "$ctx"
  mkdir -p "$ctx"
  (cd "$SRC" && git ls-files -z --cached | while IFS= read -r -d '' f; do
    [ -e "$f" ] && printf '%s\0' "$f"
  done | tar --null -T - -cf -) | tar -xf - -C "$ctx"
  if [ -f "$SRC/.dockerignore" ]; then
    local pat
    while IFS= read -r pat; do
      [[ "$pat" =~ ^[[:space:]]*(#|$) ]] && continue
      [[ "$pat" == !* ]] && die ".dockerignore exceptions (!) are not supported by this script"
      pat=${pat#/}; pat=${pat%/}
      (cd "$ctx" && shopt -s nullglob dotglob && for p in $pat; do rm -rf --one-file-system "./$p"; done)
    done <"$SRC/.dockerignore"
  fi
}

# docker_copy FROM_DIR SRC DEST ROOT WORKDIR: COPY's semantics for one source:
# a directory's contents go into DEST; a file goes to DEST (or into it when
# DEST ends with /); DEST relative to WORKDIR.
docker_copy() {
  local from=$1 src=$2 dest=$3 root=$4 wd=$5
  [[ "$dest" == /* ]] || dest="$wd/$dest"
  local s="$from/${src#/}"
  [ -e "$s" ] || die "COPY: $src not found"
  if [ -d "$s" ]; then
    mkdir -p "$root$dest"
    cp -a "$s/." "$root$dest/"
  elif [[ "$dest" == */ ]]; then
    mkdir -p "$root$dest"
    cp -a "$s" "$root$dest"
  else
    mkdir -p "$(dirname "$root$dest")"
    cp -a "$s" "$root$dest"
  fi
}

# ---------------------------------------------------------------- bootstrap
mkdir -p "$WORKDIR"
BASE="$WORKDIR/base"
if grep -q " $WORKDIR/" /proc/mounts; then
  die "something is still mounted under $WORKDIR (an earlier run?): $(grep " $WORKDIR/" /proc/mounts | cut -d' ' -f2 | tr '\n' ' ')"
fi
phase_start "debootstrap (minbase bookworm)"
if [ "$REUSE" -eq 1 ] && [ -f "$BASE/.image-check-bootstrap-done" ]; then
  echo "image-check: reusing the finished bootstrap in $BASE (--reuse)" >&2
else
  rm -rf --one-file-system "$WORKDIR/root-"* "$WORKDIR/context" "$BASE"
  debootstrap --variant=minbase bookworm "$BASE" "$MIRROR" >"$WORKDIR/debootstrap.log" 2>&1 \
    || { tail -n 30 "$WORKDIR/debootstrap.log" >&2; die "debootstrap failed (log: $WORKDIR/debootstrap.log)"; }
  # apt as on the host (Debian's own sources only: third-party ones need
  # keyrings the root lacks), and its name resolution.
  rm -f "$BASE/etc/apt/sources.list"
  copied=0
  for f in /etc/apt/sources.list /etc/apt/sources.list.d/*.list /etc/apt/sources.list.d/*.sources; do
    [ -f "$f" ] || continue
    if grep -Eq '^[^#]*(https?://[^ ]*debian\.org)' "$f" \
       && ! grep -E '^[^#]*(URIs:|deb) ' "$f" | grep -Eqv 'debian\.org'; then
      mkdir -p "$BASE$(dirname "$f")"
      cp "$f" "$BASE$f"
      copied=1
    fi
  done
  if [ "$copied" -eq 0 ]; then
    echo "deb $MIRROR bookworm main" >"$BASE/etc/apt/sources.list"
  fi
  # Proxy settings, if the host's apt uses one.
  for f in /etc/apt/apt.conf.d/*; do
    if [ -f "$f" ] && grep -qi 'proxy' "$f"; then cp "$f" "$BASE$f"; fi
  done
  touch "$BASE/.image-check-bootstrap-done"
fi
phase_end

# ---------------------------------------------------------------- stages
make_context "$WORKDIR/context"
mapfile -t INSTR < <(parse_dockerfile "$DOCKERFILE")
declare -A STAGE_ROOT=()   # stage name or index -> root
STAGE=-1
ROOT=""
SLABEL=""
WD=/
USER_NAME=root
ENTRYPOINT_JSON=""
RUN_INDEX=0

finish_stage() {
  if [ -n "$ROOT" ]; then umount_in "$ROOT"; fi
}

for ins in "${INSTR[@]}"; do
  keyword=${ins%%[[:space:]]*}
  rest=${ins#"$keyword"}
  rest=$(sed -E 's/^[[:space:]]+//' <<<"$rest")
  [ -n "$ROOT" ] || [ "${keyword^^}" = FROM ] || die "$keyword before the first FROM"
  case "${keyword^^}" in
    FROM)
      finish_stage
      STAGE=$((STAGE + 1))
      read -r image as name <<<"$rest"
      case "$image" in
        debian:12 | debian:bookworm | debian:12-slim | debian:bookworm-slim) ;;
        *) die "FROM $image: only Debian 12 images can be made with debootstrap" ;;
      esac
      ROOT="$WORKDIR/root-$STAGE"
      SLABEL="stage $STAGE ${name:-$image}"
      phase_start "$SLABEL: root (a copy of the bootstrap)"
      rm -rf --one-file-system "$ROOT"
      cp -a "$BASE" "$ROOT"
      rm -f "$ROOT/.image-check-bootstrap-done"
      cp -L /etc/resolv.conf "$ROOT/etc/resolv.conf"
      mount_in "$ROOT"
      phase_end
      STAGE_ROOT[$STAGE]=$ROOT
      if [ "${as^^}" = AS ] && [ -n "$name" ]; then STAGE_ROOT[$name]=$ROOT; fi
      WD=/; USER_NAME=root; ENTRYPOINT_JSON=""; RUN_INDEX=0
      ;;
    WORKDIR)
      [[ "$rest" == /* ]] || rest="$WD/$rest"
      WD=$rest
      mkdir -p "$ROOT$WD"
      ;;
    COPY)
      from_dir="$WORKDIR/context"
      if [[ "$rest" == --from=* ]]; then
        ref=${rest%%[[:space:]]*}; ref=${ref#--from=}
        [ -n "${STAGE_ROOT[$ref]:-}" ] || die "COPY --from=$ref: no such stage"
        from_dir=${STAGE_ROOT[$ref]}
        rest=$(sed -E 's/^[^[:space:]]+[[:space:]]+//' <<<"$rest")
      fi
      [[ "$rest" == --* ]] && die "COPY flag not supported: $rest"
      read -r -a parts <<<"$rest"
      [ "${#parts[@]}" -ge 2 ] || die "COPY needs a source and a destination: $ins"
      dest=${parts[-1]}
      for src in "${parts[@]:0:${#parts[@]}-1}"; do
        docker_copy "$from_dir" "$src" "$dest" "$ROOT" "$WD"
      done
      echo "image-check: COPY $rest" >&2
      ;;
    RUN)
      [[ "$rest" == \[* ]] && die "RUN in exec form is not supported: $ins"
      RUN_INDEX=$((RUN_INDEX + 1))
      label="$SLABEL: RUN $(cut -c1-36 <<<"$rest")..."
      phase_start "$label"
      echo "+ $rest" >&2
      in_root "$ROOT" "$WD" "$rest" || die "$label exited $?"
      phase_end
      ;;
    USER) USER_NAME=$rest ;;
    EXPOSE | LABEL) ;;
    ENTRYPOINT) ENTRYPOINT_JSON=$rest ;;
    *) die "Dockerfile instruction not supported by this script: $keyword" ;;
  esac
done
finish_stage
[ "$STAGE" -ge 1 ] || die "the Dockerfile has no runtime stage"
[ -n "$ENTRYPOINT_JSON" ] || die "the runtime stage has no ENTRYPOINT"

# ---------------------------------------------------------------- serve + plan
phase_start "server + plan (runtime root, as $USER_NAME)"
RT=$ROOT
mount_in "$RT"
# ENTRYPOINT ["a", "b", ...] -> words (no commas or quotes inside the words).
[[ "$ENTRYPOINT_JSON" =~ ^\[(.*)\]$ ]] || die "ENTRYPOINT must be in exec (JSON) form"
mapfile -t ENTRY < <(sed -E 's/^[[:space:]]*"//; s/"[[:space:]]*$//; s/"[[:space:]]*,[[:space:]]*"/\n/g' <<<"${BASH_REMATCH[1]}")
SERVER_BIN=${ENTRY[0]}
CLIENT_BIN="$(dirname "$SERVER_BIN")/riskplan"
[ -x "$RT$SERVER_BIN" ] || die "$SERVER_BIN is not in the runtime root"
[ -x "$RT$CLIENT_BIN" ] || die "$CLIENT_BIN is not in the runtime root"
pw=$(grep "^$USER_NAME:" "$RT/etc/passwd") || die "USER $USER_NAME does not exist in the runtime root"
uid=$(cut -d: -f3 <<<"$pw"); gid=$(cut -d: -f4 <<<"$pw")
[ "$uid" -ne 0 ] || die "USER $USER_NAME is root"

# Every shared library of every program resolves in the runtime root (all
# the missing ones are listed before failing).
lacking=""
for b in "$RT"/usr/local/bin/*; do
  missing=$(chroot "$RT" /usr/bin/ldd "/usr/local/bin/${b##*/}" 2>&1 | grep 'not found' |
    awk '{print $1}' | tr '\n' ' ' || true)
  [ -z "$missing" ] || lacking+=$'\n'"  ${b##*/}: $missing"
done
[ -z "$lacking" ] || die "programs lack shared libraries in the runtime root (add their packages to the runtime stage's apt-get install):$lacking"

# The command line that runs a program in the runtime root as the stage's
# USER, with a clean environment (chroot and env exec: the pid of a program
# started in the background through it is the program's own).
AS_USER=(chroot --userspec="$uid:$gid" "$RT" /usr/bin/env -i HOME=/
  PATH=/usr/local/sbin:/usr/local/bin:/usr/sbin:/usr/bin:/sbin:/bin)
SERVER_OUT="$WORKDIR/server.out"
SERVER_ERR="$WORKDIR/server.err"
echo "+ ${ENTRY[*]} --listen=127.0.0.1:0" >&2
"${AS_USER[@]}" "${ENTRY[@]}" --listen=127.0.0.1:0 >"$SERVER_OUT" 2>"$SERVER_ERR" &
SERVER_PID=$!
ADDRESS=""
for _ in $(seq 1 600); do
  line=$(grep -m1 '^riskplan-server listening on ' "$SERVER_OUT" || true)
  if [ -n "$line" ]; then ADDRESS=${line#riskplan-server listening on }; break; fi
  kill -0 "$SERVER_PID" 2>/dev/null || { cat "$SERVER_ERR" >&2; die "riskplan-server exited before serving"; }
  sleep 0.1
done
[ -n "$ADDRESS" ] || { cat "$SERVER_ERR" >&2; die "riskplan-server did not say it listens within 60 s"; }
echo "image-check: riskplan-server (uid $uid) listening on $ADDRESS" >&2
"${AS_USER[@]}" "$CLIENT_BIN" --server="$ADDRESS" maps || die "riskplan maps failed"
PLAN_OUT="$WORKDIR/plan.out"
set +e
"${AS_USER[@]}" "$CLIENT_BIN" --server="$ADDRESS" plan --map=demo-city --start=1200,1500,250,0.785 \
  --goal=6800,6500,250,0.785 --budget_ms=10000 | tee "$PLAN_OUT"
plan_rc=${PIPESTATUS[0]}
set -e
[ "$plan_rc" -eq 0 ] || die "riskplan plan exited $plan_rc (3: no trajectory)"
grep -q '^best: risk ' "$PLAN_OUT" || die "riskplan plan printed no trajectory"
kill -TERM "$SERVER_PID"
stopped=0
for _ in $(seq 1 300); do
  if ! kill -0 "$SERVER_PID" 2>/dev/null; then stopped=1; break; fi
  sleep 0.1
done
[ "$stopped" -eq 1 ] || die "riskplan-server did not exit within 30 s of SIGTERM"
set +e
wait "$SERVER_PID"
server_rc=$?
set -e
SERVER_PID=""
[ "$server_rc" -eq 0 ] || { cat "$SERVER_ERR" >&2; die "riskplan-server exited $server_rc after SIGTERM"; }
umount_in "$RT"
phase_end
echo "image-check: OK: the image builds, its runtime stage has every library, and it plans demo-city" >&2
