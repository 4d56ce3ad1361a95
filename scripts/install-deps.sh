#!/usr/bin/env bash
# Installs every Debian 12 package mesocap needs to build, test and run.
# Idempotent: when everything is already installed it asks apt nothing and
# returns in well under a second. Runs as root, or as a user through sudo.
set -euo pipefail

packages=(
  # toolchain; ccache keeps compiled objects across builds and clones
  # (every preset compiles through it: CMakePresets.json)
  build-essential cmake ninja-build pkg-config git ccache
  # numerics and vision
  libeigen3-dev libceres-dev libopencv-dev libopencv-contrib-dev libtbb-dev
  # content checksums of captured and processed files
  libxxhash-dev
  # images
  libopenimageio-dev openimageio-tools libopenexr-dev
  # ray tracing (simulated rig, CPU reference renderer)
  libembree-dev
  # devices: GigE Vision cameras (aravis-tools ships arv-fake-gv-camera-0.8
  # for tests), USB stepper controllers, GPIO lines
  libaravis-dev aravis-tools aravis-tools-cli libusb-1.0-0-dev libgpiod-dev
  # the served-camera tests' own network namespace (unshare, ip)
  util-linux iproute2
  # OpenGL 4.5 core through EGL (headless, Mesa llvmpipe) and GLFW (windowed)
  libegl-dev libgl-dev libgles-dev libegl-mesa0 libgl1-mesa-dri libglfw3-dev libepoxy-dev
  # application plumbing
  libcli11-dev nlohmann-json3-dev libspdlog-dev
  # the capture daemon: its HTTP server (libmicrohttpd), sd_notify and the
  # watchdog (libsystemd), and the client's HTTP over a Unix socket (libcurl)
  libmicrohttpd-dev libsystemd-dev libcurl4-openssl-dev
  # tests and benchmarks; chromium (/usr/bin/chromium) runs the daemon's
  # status page headless in a test; python3 runs the size check
  # (scripts/check_code_size.py); clang-format checks the layout (.clang-format)
  libgtest-dev libgmock-dev libbenchmark-dev chromium python3 clang-format
  # the benchmarks' PNG plots (bench/*_plot.sh)
  gnuplot-nox
  # fuzzing (scripts/fuzz.sh): clang and its runtimes, libFuzzer's among them
  clang libclang-rt-14-dev
)

missing=()
for p in "${packages[@]}"; do
  status=$(dpkg-query -W -f='${db:Status-Status}' "$p" 2>/dev/null || true)
  [[ "$status" == "installed" ]] || missing+=("$p")
done

if [[ ${#missing[@]} -eq 0 ]]; then
  echo "install-deps: all ${#packages[@]} packages already installed"
  exit 0
fi

if [[ $EUID -eq 0 ]]; then
  as_root=()
elif command -v sudo >/dev/null 2>&1; then
  as_root=(sudo)
else
  echo "install-deps: need root or sudo to install: ${missing[*]}" >&2
  exit 1
fi

echo "install-deps: installing ${#missing[@]} packages: ${missing[*]}"
export DEBIAN_FRONTEND=noninteractive
"${as_root[@]}" apt-get update -qq
"${as_root[@]}" env DEBIAN_FRONTEND=noninteractive \
  apt-get install -y -qq --no-install-recommends "${missing[@]}"
echo "install-deps: done"
