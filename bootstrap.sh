#!/usr/bin/env bash
# Sets mrcheck up on a fresh Debian machine and runs one of its entry points.
#
#   ./bootstrap.sh demo [-o DIR]     render the embedded sample scene in all modes
#   ./bootstrap.sh test [PYTEST...]  the checks below, then the test suite (this is what .ci/run calls);
#                                    `./bootstrap.sh test -m "not slow"` is the fast loop (tests/conftest.py)
#   ./bootstrap.sh check             ruff check, ruff format --check and mypy (files: [tool.mypy] in pyproject.toml)
#   ./bootstrap.sh bench [ARGS...]   also set up the benchmark's peers, then run `mrcheck bench ARGS`
#   ./bootstrap.sh shell             only set up; prints how to activate the environment
#   ./bootstrap.sh lock [UV-ARGS]    refresh the lock files to the newest versions pyproject.toml allows;
#                                    `lock --keep` keeps every pin it can (after editing pyproject.toml's
#                                    dependencies), `lock --upgrade-package numpy` moves one package.
#                                    A refresh is a commit of its own, made after `./bootstrap.sh test`
#                                    passed on it (docs/testing.md)
#
# Python packages come from the lock, exact versions with their hashes, so every machine installs
# what CI installed: requirements.lock (mrcheck's dependencies, the test, review and cluster extras,
# the tools and the build backend) and requirements-bench.lock (the same versions plus the bench
# extra). Set-up is idempotent: system packages are installed only when missing, the virtual
# environment (.venv/) is created once and reinstalled only when a lock file changes.
set -euo pipefail
caller=$PWD                 # demo and bench write their outputs relative to where they were called
cd "$(dirname "$0")"
repo=$PWD

# Debian packages the renderer and Open3D load at run time:
#   libegl1 + libgl1-mesa-dri  headless OpenGL 4.5 through EGL (Mesa llvmpipe on a CPU)
#   libgles2                   GL dispatch that Mesa's EGL pulls in
#   libusb-1.0-0 + libgomp1    shared libraries that Open3D's wheel links against
#   chromium                   the headless browser of the `mrcheck review` end-to-end test
#                              (Playwright drives /usr/bin/chromium; it never downloads one)
SYSTEM_PACKAGES=(libegl1 libgl1-mesa-dri libgles2 libusb-1.0-0 libgomp1 chromium)
# Only for `./bootstrap.sh bench`, whose peers include Open3D's renderer: headless, Open3D renders
# through Filament's Vulkan backend, on Mesa's software Vulkan driver (lavapipe) here.
BENCH_SYSTEM_PACKAGES=(libvulkan1 mesa-vulkan-drivers)

cmd=${1:-demo}
shift || true
if [[ $cmd == bench ]]; then
    SYSTEM_PACKAGES+=("${BENCH_SYSTEM_PACKAGES[@]}")
fi

missing=()
for pkg in "${SYSTEM_PACKAGES[@]}"; do
    if ! dpkg-query -W -f='${Status}' "$pkg" 2>/dev/null | grep -q "install ok installed"; then
        missing+=("$pkg")
    fi
done
if ((${#missing[@]})); then
    if [[ $(id -u) -eq 0 ]] && command -v apt-get >/dev/null; then
        echo "bootstrap: installing system packages: ${missing[*]}" >&2
        apt-get update -qq >/dev/null
        DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
    else
        echo "error: missing system packages: ${missing[*]} (install them with: sudo apt-get install ${missing[*]})" >&2
        exit 1
    fi
fi

PYTHON=${PYTHON:-python3}
if ! "$PYTHON" -c 'import sys; sys.exit(sys.version_info < (3, 11))' 2>/dev/null; then
    echo "error: mrcheck needs Python >= 3.11 ($PYTHON is $("$PYTHON" --version 2>&1 || echo missing)); set PYTHON=/path/to/python3.11" >&2
    exit 1
fi

LOCK=requirements.lock
BENCH_LOCK=requirements-bench.lock
if [[ ! -x .venv/bin/python ]]; then
    echo "bootstrap: creating .venv" >&2
    "$PYTHON" -m venv .venv
fi
# pip with --require-hashes installs exactly the lock's files; mrcheck itself goes in editable with
# the lock's build backend (hatchling), so nothing is resolved or downloaded beyond the lock.
install_lock() {  # LOCK-FILE STAMP-FILE
    local want
    want=$(cat "$1" pyproject.toml | sha256sum | cut -c1-16)  # pyproject.toml: entry points, editable install
    if [[ ! -f $2 || $(cat "$2") != "$want" ]]; then
        echo "bootstrap: installing mrcheck and $1 into .venv" >&2
        .venv/bin/python -m pip install -q --require-hashes -r "$1"
        .venv/bin/python -m pip install -q --no-deps --no-build-isolation -e .
        echo "$want" >"$2"
    fi
}
if [[ $cmd != lock || ! -x .venv/bin/uv ]]; then  # a refresh needs only uv: it also mends a lock that fails to install
    install_lock "$LOCK" .venv/.mrcheck-installed
fi
if [[ $cmd == bench ]]; then
    install_lock "$BENCH_LOCK" .venv/.mrcheck-bench-installed
fi

check() {  # all three run, so one run names every problem; fails when any failed
    local failed=0
    .venv/bin/ruff check . || failed=1
    .venv/bin/ruff format --check . || failed=1
    if grep -q '^\[tool\.mypy\]' pyproject.toml; then
        .venv/bin/mypy || failed=1
    else
        echo "bootstrap: pyproject.toml has no [tool.mypy] (the files mypy checks); mypy skipped" >&2
    fi
    return $failed
}

# One universal resolution (every platform and Python >= 3.11) of all extras and the build backend,
# then the default set-up's subset of it, held to the same versions by the first as constraints.
lock() {
    local build_requires  # the build backend, and what it needs for the editable install (hatchling: editables)
    build_requires=$(.venv/bin/python -c 'import importlib, tomllib
system = tomllib.load(open("pyproject.toml", "rb"))["build-system"]
backend = importlib.import_module(system["build-backend"])
print("\n".join(system["requires"] + backend.get_requires_for_build_editable()))')
    local compile=(.venv/bin/uv pip compile pyproject.toml - --universal --python-version 3.11 --fork-strategy fewest --generate-hashes
                   --annotation-style line --custom-compile-command "./bootstrap.sh lock")
    if [[ ${1:-} == --keep ]]; then
        shift
    elif ((! $#)); then
        set -- --upgrade
    fi
    echo "$build_requires" | "${compile[@]}" --all-extras -o "$BENCH_LOCK" "$@"
    echo "$build_requires" | "${compile[@]}" --extra test --extra review --extra cluster -c "$BENCH_LOCK" -o "$LOCK"
}

case "$cmd" in
    demo) cd "$caller" && exec "$repo/.venv/bin/mrcheck" demo "$@" ;;
    test) check; exec .venv/bin/python -m pytest "$@" ;;  # from the repository: its test paths
    check) check ;;
    bench) cd "$caller" && exec "$repo/.venv/bin/mrcheck" bench "$@" ;;
    shell) echo "set up; activate with: source .venv/bin/activate" ;;
    lock) lock "$@" ;;
    *) echo "usage: ./bootstrap.sh {demo|test|check|bench|shell|lock} [ARGS...]" >&2; exit 2 ;;
esac
