#!/bin/sh
# Build ./Dockerfile into an image without a Docker engine (buildah), and optionally check it.
#   deploy/build-image.sh [--local-base] [--check] [--tag NAME]
# --local-base  no registry is reachable: build the base (Debian bookworm + Python 3.11 from
#               Debian's packages, with debootstrap) as localhost/depot-base:bookworm and build
#               FROM it (Dockerfile ARG BASE_IMAGE); without it the Dockerfile's default
#               python:3.11-slim-bookworm is pulled.
# --check       run the image: user 10001, no compiler and no pip in it, `depot --help`; and, when
#               DEPOT_DATABASE_URL is set, `depot migrate` against it and `depot serve` answering
#               /healthz and /readyz from the host (the container shares the host's network).
# --tag NAME    the image's name (default localhost/depot:latest).
# Environment: DEPOT_BUILD_DRIVER (containers storage driver, default overlay; vfs where overlay
# is refused, much slower), DEPOT_BUILD_ROOT (storage folder; default the system store),
# DEPOT_BUILD_CA (a CA bundle the build's pip must trust, e.g. behind a TLS-inspecting proxy;
# default: the host's bundle when /etc/pip.conf names one). Needs root (apt: buildah debootstrap).
set -eu
cd "$(dirname "$0")/.."
tag=localhost/depot:latest local_base=0 check=0
while [ $# -gt 0 ]; do
    case $1 in
        --local-base) local_base=1 ;;
        --check) check=1 ;;
        --tag) tag=${2:?--tag needs a name}; shift ;;
        *) echo "depot: build-image.sh: unknown argument $1 (--local-base, --check, --tag NAME)" >&2
           exit 2 ;;
    esac
    shift
done
command -v buildah >/dev/null || {
    echo "depot: buildah is not installed; apt-get install -y buildah (and debootstrap for --local-base)" >&2
    exit 2; }
b="buildah --storage-driver ${DEPOT_BUILD_DRIVER:-overlay}"
[ -n "${DEPOT_BUILD_ROOT:-}" ] && b="$b --root $DEPOT_BUILD_ROOT/storage --runroot $DEPOT_BUILD_ROOT/run"
base=localhost/depot-base:bookworm
rootfs='' container='' server=''
cleanup() {
    [ -z "$server" ] || { kill "$server" 2>/dev/null; wait "$server" 2>/dev/null || true; }
    [ -z "$container" ] || $b rm "$container" >/dev/null 2>&1 || true
    [ -z "$rootfs" ] || rm -rf "$rootfs"
}
trap cleanup EXIT

if [ "$local_base" = 1 ] && ! $b inspect --type image "$base" >/dev/null 2>&1; then
    command -v debootstrap >/dev/null || {
        echo "depot: --local-base needs debootstrap; apt-get install -y debootstrap" >&2; exit 2; }
    rootfs=$(mktemp -d)
    echo "building $base with debootstrap (a few minutes)" >&2
    debootstrap --variant=minbase bookworm "$rootfs" "${DEPOT_DEBIAN_MIRROR:-http://deb.debian.org/debian}" >&2
    cp /etc/resolv.conf "$rootfs/etc/resolv.conf"
    # python3.11-venv (for `python -m venv`) and python-is-python3 (the Dockerfile says python).
    chroot "$rootfs" sh -c 'export DEBIAN_FRONTEND=noninteractive
        apt-get update -qq && apt-get install -y -qq --no-install-recommends \
            python3.11 python3.11-venv python-is-python3 ca-certificates >/dev/null \
        && apt-get clean && rm -rf /var/lib/apt/lists/*' >&2
    : > "$rootfs/etc/resolv.conf"
    rm -rf "$rootfs/debootstrap"
    container=$($b from scratch)
    tar -C "$rootfs" -c . | tar -C "$($b mount "$container")" -x
    $b config --cmd python3 "$container"
    $b commit --rm "$container" "$base" >/dev/null
    container=''
    rm -rf "$rootfs"
    rootfs=''
fi

# The build's pip must trust the host's CA where TLS is inspected; mounted for RUN steps only
# (nothing of it is in the image).
ca=${DEPOT_BUILD_CA:-}
if [ -z "$ca" ] && grep -qs '^cert *=' /etc/pip.conf; then
    ca=$(sed -n 's/^cert *= *//p' /etc/pip.conf | head -n 1)
fi
set --
if [ -n "$ca" ]; then
    printf '[global]\ncert = /etc/depot-build-ca.crt\n' > "${TMPDIR:-/tmp}/depot-build-pip.conf"
    set -- -v "$ca:/etc/depot-build-ca.crt:ro" -v "${TMPDIR:-/tmp}/depot-build-pip.conf:/etc/pip.conf:ro"
fi
[ "$local_base" = 1 ] && set -- "$@" --build-arg "BASE_IMAGE=$base"
# docker format keeps the HEALTHCHECK (OCI images have none); chroot isolation needs no
# namespaces, so it runs inside a container or a sandbox too.
$b bud --isolation chroot --format docker --layers "$@" -t "$tag" -f Dockerfile . >&2
echo "built $tag" >&2

[ "$check" = 1 ] || exit 0
container=$($b from --pull-never "$tag")
c=$container
run() { $b run --isolation chroot "$@"; }
run "$c" -- sh -c '[ "$(id -u)" = 10001 ] || { echo "runs as $(id -u), not 10001"; exit 1; }
    for tool in gcc cc c++ make pip pip3; do
        if command -v "$tool" >/dev/null; then echo "the image has $tool"; exit 1; fi
    done
    if python -m pip --version >/dev/null 2>&1; then echo "the image has pip"; exit 1; fi
    [ ! -e /src ] || { echo "the image has the source tree"; exit 1; }' \
    || { echo "depot: the image fails its checks (above)" >&2; exit 1; }
run "$c" -- depot --help >/dev/null
echo "image checked: user 10001, no compiler, no pip, depot --help" >&2
[ -n "${DEPOT_DATABASE_URL:-}" ] || exit 0
run -e "DEPOT_DATABASE_URL=$DEPOT_DATABASE_URL" "$c" -- depot migrate >&2
port=${DEPOT_CHECK_PORT:-18000}
# buildah itself in the background (not a function's subshell), so that killing it stops
# the server inside.
$b run --isolation chroot -e "DEPOT_DATABASE_URL=$DEPOT_DATABASE_URL" "$c" -- \
    depot serve --host 127.0.0.1 --port "$port" --workers 1 >/dev/null 2>&1 &
server=$!
python3 - "$port" <<'EOF'
import sys, time, urllib.request
base = f"http://127.0.0.1:{sys.argv[1]}"
for _ in range(120):
    try:
        with urllib.request.urlopen(base + "/readyz", timeout=2) as answer:
            health = urllib.request.urlopen(base + "/healthz", timeout=2).read().decode()
            print(f"serve: /readyz {answer.status}, /healthz {health}", file=sys.stderr)
            sys.exit(0)
    except OSError:
        time.sleep(0.5)
sys.exit("depot: the image's server did not answer /readyz within 60 s")
EOF
