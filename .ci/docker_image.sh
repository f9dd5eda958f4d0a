#!/usr/bin/env bash
# The Docker image, built and run for real: a stage of .ci/run, or by hand as root on Debian bookworm.
#
#   bash .ci/docker_image.sh prepare   the network part: Debian's docker.io and debootstrap, a daemon of our own,
#                                      the two base images made by debootstrap, the wheelhouse
#   bash .ci/docker_image.sh test      offline: `docker build --network none` from the wheelhouse, then
#                                      tests/test_docker.py against the image (started on the host network)
#   bash .ci/docker_image.sh stop      the daemon stops; its images, containers and directories go with it
#   bash .ci/docker_image.sh           all three
#
# No image registry is reachable from CI, so nothing is pulled: the runtime's base is Debian bookworm with
# python3 (debootstrap, imported), the build's base is the same with g++ and Python's headers (apt, in a
# container on the host network, committed), and pip finds every package, the build's own included, in a PEP 503
# directory made from `pip download` into the build context (build/wheelhouse; see the Dockerfile's arguments).
# The daemon is our own (its socket, data and state in a temporary directory, noted in build/docker.env), started
# without the default bridge (`--bridge=none --iptables=false`): containers use the host's network or none.
# When this machine cannot run containers at all, `prepare` notes why and `test` says SKIPPED with the reason
# (exit 0): a failed build or a failed test fails.
set -euo pipefail
cd "$(dirname "$0")/.."
STATE=build/docker.env
WHEELHOUSE=build/wheelhouse
DOCKER=/usr/bin/docker  # Debian's client, the daemon's own version (a newer client elsewhere on PATH needs buildx)
PYTHON=${PYTHON:-.venv/bin/python}
MIRROR=${DEBIAN_MIRROR:-http://deb.debian.org/debian}
BASE=dynamics-base:bookworm BUILD=dynamics-build:bookworm IMAGE=dynamics:ci

say() { echo "== docker image: $*"; }
timed() {  # timed WHAT COMMAND...: run it, say how long it took
    local what=$1 t0=$SECONDS
    shift
    "$@"
    say "$what in $((SECONDS - t0)) s"
}
skip() {  # the reason this machine cannot run containers, for `test` to report
    echo "SKIP=$(printf %q "$1")" >>"$STATE"
    say "SKIPPED: $1"
    exit 0
}
load_state() {
    [ -f "$STATE" ] || { echo "no $STATE: run 'bash .ci/docker_image.sh prepare' first" >&2; exit 1; }
    # shellcheck disable=SC1090
    source "$STATE"
    export DOCKER_HOST="unix://$DIR/docker.sock" DOCKER_BUILDKIT=1
}

debian_base() {  # the runtime's base: bookworm's minimal variant and python3, without apt's lists, docs, locales
    debootstrap --variant=minbase --include=python3 bookworm "$DIR/rootfs" "$MIRROR" >"$DIR/debootstrap.log" 2>&1 \
        || { tail -20 "$DIR/debootstrap.log"; return 1; }
    tar -C "$DIR/rootfs" -c --exclude='./var/cache/apt/archives/*.deb' --exclude='./var/cache/apt/*.bin' \
        --exclude='./var/lib/apt/lists/*' --exclude='./usr/share/doc/*' --exclude='./usr/share/man/*' \
        --exclude='./usr/share/locale/*' --exclude='./usr/share/info/*' . \
        | $DOCKER import --change 'ENV PATH=/usr/local/sbin:/usr/local/bin:/usr/sbin:/usr/bin:/sbin:/bin' \
            --change 'ENV LANG=C.UTF-8' --change 'CMD ["python3"]' - "$BASE" >/dev/null
    rm -rf "$DIR/rootfs"
}

build_base() {  # the build stage's base: the runtime's, a C++ compiler and Python's headers (apt, on the host network)
    $DOCKER run --name dynamics-build-base --network host "$BASE" sh -c 'apt-get update -q >/dev/null \
        && DEBIAN_FRONTEND=noninteractive apt-get install -y -q --no-install-recommends g++ python3-dev python3-venv \
           >/dev/null && rm -rf /var/lib/apt/lists/* /var/cache/apt/*.bin /var/cache/apt/archives/*.deb'
    $DOCKER commit --change 'CMD ["python3"]' dynamics-build-base "$BUILD" >/dev/null
    $DOCKER rm dynamics-build-base >/dev/null
}

wheelhouse() {  # every package the build and the service need, as wheels for the image's Python, in PEP 503 form
    local version
    version=$($DOCKER run --rm --network none "$BASE" python3 -c 'import sys; print("%d.%d" % sys.version_info[:2])')
    rm -rf "$WHEELHOUSE"
    mkdir -p "$WHEELHOUSE/files"
    python3 - "$WHEELHOUSE" "$version" <<'EOF'
import html, pathlib, re, subprocess, sys, tomllib
root, version = pathlib.Path(sys.argv[1]), sys.argv[2]
project = tomllib.load(open("pyproject.toml", "rb"))
# the service's dependencies, the build backend's, and what scikit-build-core asks for when the system has no
# cmake or ninja (the build image has neither)
wanted = project["project"]["dependencies"] + project["build-system"]["requires"] + ["cmake>=3.18", "ninja"]
subprocess.run([sys.executable, "-m", "pip", "download", "--quiet", "--only-binary=:all:", "--python-version", version,
                "--dest", str(root / "files"), *wanted], check=True)
projects = {}
for wheel in sorted((root / "files").glob("*.whl")):
    projects.setdefault(re.sub(r"[-_.]+", "-", wheel.name.split("-")[0]).lower(), []).append(wheel.name)
for name, files in projects.items():  # simple/<name>/index.html, as pip reads a file:// index
    (root / "simple" / name).mkdir(parents=True)
    (root / "simple" / name / "index.html").write_text("".join(
        f'<a href="../../files/{html.escape(f)}">{html.escape(f)}</a><br>\n' for f in files))
print(f"{len(projects)} projects, {sum(f.stat().st_size for f in (root / 'files').iterdir()) / 1e6:.0f} MB")
EOF
}

prepare() {
    mkdir -p build
    if [ -f "$STATE" ]; then stop; fi
    DIR=$(mktemp -d /tmp/dynamics-docker.XXXXXX)
    echo "DIR=$DIR" >"$STATE"
    # the daemon's files in memory (about 2 GB at the end, 8 GB at most): the build writes faster, and `stop`
    # frees them at once, where deleting them from the disk took a minute; on the disk where tmpfs cannot be mounted
    mount -t tmpfs -o size=8g,mode=0700 dynamics-docker "$DIR" 2>/dev/null || say "no tmpfs: the daemon's files on disk"
    export DOCKER_HOST="unix://$DIR/docker.sock"
    if ! command -v dockerd >/dev/null || ! command -v debootstrap >/dev/null || [ ! -x $DOCKER ]; then
        timed "docker.io and debootstrap installed" apt-get install -y -q --no-install-recommends docker.io debootstrap \
            >"$DIR/apt.log" 2>&1 || { tail -5 "$DIR/apt.log"; skip "Debian's docker.io cannot be installed here"; }
    fi
    # no bridge: no container may take the default bridge's private addresses on these machines
    dockerd --bridge=none --iptables=false --host "$DOCKER_HOST" --data-root "$DIR/data" --exec-root "$DIR/exec" \
        --pidfile "$DIR/dockerd.pid" >"$DIR/dockerd.log" 2>&1 &
    echo "DOCKERD=$!" >>"$STATE"
    for _ in $(seq 60); do $DOCKER version >/dev/null 2>&1 && break; sleep 0.5; done
    $DOCKER version >/dev/null 2>&1 || { tail -20 "$DIR/dockerd.log"; skip "dockerd does not start here"; }
    timed "base image $BASE made by debootstrap" debian_base
    $DOCKER run --rm --network none "$BASE" true 2>"$DIR/run.err" \
        || { cat "$DIR/run.err"; skip "the daemon runs but cannot start a container: $(tail -1 "$DIR/run.err")"; }
    # apt and pip download both wait on the network: side by side
    timed "wheelhouse made" wheelhouse >"$DIR/wheelhouse.log" 2>&1 &
    local wheels=$!
    timed "build image $BUILD made" build_base
    wait $wheels || { cat "$DIR/wheelhouse.log"; return 1; }
    grep -v "^WARNING: Location '.*' is ignored" "$DIR/wheelhouse.log" || true  # (a local pip.conf's index)
}

build_image() {  # the build sees no network: everything comes from the two images and the wheelhouse
    $DOCKER build --network none --progress plain --tag "$IMAGE" \
        --build-arg BUILD_IMAGE="$BUILD" --build-arg BASE_IMAGE="$BASE" \
        --build-arg PIP_INDEX_URL="file:///context/$WHEELHOUSE/simple" . >"$DIR/build.log" 2>&1 \
        || { tail -60 "$DIR/build.log"; return 1; }
}

test_image() {
    load_state
    if [ -n "${SKIP:-}" ]; then say "SKIPPED: $SKIP"; return 0; fi
    timed "image built offline" build_image
    say "image size: $($DOCKER image inspect --format '{{.Size}}' "$IMAGE" | awk '{printf "%.0f MB", $1 / 1e6}')" \
        "(base $($DOCKER image inspect --format '{{.Size}}' "$BASE" | awk '{printf "%.0f MB", $1 / 1e6}'))"
    DYNAMICS_DOCKER_IMAGE=$IMAGE DOCKER=$DOCKER timed "image tested" \
        "$PYTHON" -m pytest -q -p no:cacheprovider -rs tests/test_docker.py -o addopts="" -s
}

stop() {  # our daemon only (its pid), then its directories: every image and container of the stage goes too
    [ -f "$STATE" ] || return 0
    # shellcheck disable=SC1090
    source "$STATE"
    local t0=$SECONDS
    if [ -n "${DOCKERD:-}" ] && kill "$DOCKERD" 2>/dev/null; then
        for _ in $(seq 60); do kill -0 "$DOCKERD" 2>/dev/null || break; sleep 0.5; done
    fi
    # what the daemon leaves mounted (its network namespace's file, its data), innermost first, then the tmpfs
    awk -v dir="$DIR/" 'index($2, dir) == 1 {print $2}' /proc/mounts | sort -r | xargs -r umount
    if mountpoint -q "$DIR"; then umount "$DIR"; fi
    rm -rf "$DIR" "$STATE" "$WHEELHOUSE"
    say "daemon stopped, its images and files gone in $((SECONDS - t0)) s"
}

case "${1:-all}" in
    prepare) prepare ;;
    test) test_image ;;
    stop) stop ;;
    all) trap stop EXIT; prepare; test_image ;;
    *) echo "usage: $0 [prepare|test|stop]" >&2; exit 2 ;;
esac
