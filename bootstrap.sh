#!/usr/bin/env bash
# Sets mrcheck up on a fresh Debian machine and runs one of its entry points.
#
#   ./bootstrap.sh demo [-o DIR]     render the embedded sample scene in all modes
#   ./bootstrap.sh test [PYTEST...]  run the test suite (this is what .ci/run calls)
#   ./bootstrap.sh bench [ARGS...]   also set up the benchmark's peers, then run `mrcheck bench ARGS`
#   ./bootstrap.sh shell             only set up; prints how to activate the environment
#
# Set-up is idempotent: system packages are installed only when missing, the virtual
# environment (.venv/) is created once and reinstalled only when pyproject.toml changes.
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

stamp=.venv/.mrcheck-installed
want=$(sha256sum pyproject.toml | cut -c1-16)
if [[ ! -x .venv/bin/python ]]; then
    echo "bootstrap: creating .venv" >&2
    "$PYTHON" -m venv .venv
fi
if [[ ! -f $stamp || $(cat "$stamp") != "$want" ]]; then
    echo "bootstrap: installing mrcheck and its dependencies into .venv" >&2
    .venv/bin/python -m pip install -q --upgrade pip >/dev/null
    .venv/bin/python -m pip install -q -e '.[test]'
    echo "$want" >"$stamp"
fi

bench_stamp=.venv/.mrcheck-bench-installed
if [[ $cmd == bench && ( ! -f $bench_stamp || $(cat "$bench_stamp") != "$want" ) ]]; then
    echo "bootstrap: installing the benchmark's peers (the bench extra: pyvista/VTK) into .venv" >&2
    .venv/bin/python -m pip install -q -e '.[bench]'
    echo "$want" >"$bench_stamp"
fi

case "$cmd" in
    demo) cd "$caller" && exec "$repo/.venv/bin/mrcheck" demo "$@" ;;
    test) exec .venv/bin/python -m pytest "$@" ;;          # from the repository: its test paths
    bench) cd "$caller" && exec "$repo/.venv/bin/mrcheck" bench "$@" ;;
    shell) echo "set up; activate with: source .venv/bin/activate" ;;
    *) echo "usage: ./bootstrap.sh {demo|test|bench|shell} [ARGS...]" >&2; exit 2 ;;
esac
