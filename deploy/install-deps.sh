#!/usr/bin/env bash
# Installs every Debian 12 package touchmend's build, tests and benchmarks need.
# Idempotent: packages already present are left alone; safe to run any number of times.
# Usage: deploy/install-deps.sh [--no-bench]   (--no-bench skips the optional CGAL comparison)
set -euo pipefail

packages=(
  # toolchain
  build-essential cmake ninja-build ccache pkg-config git
  # geometry core
  libopenmesh-dev libeigen3-dev
  # command line, message formatting, JSON output
  libcli11-dev libfmt-dev nlohmann-json3-dev
  # wire protocol, transport (Asio/Beast), TLS, embedded store, structured logs
  libprotobuf-dev protobuf-compiler libboost-dev libssl-dev libsqlite3-dev libspdlog-dev
  # haptic station: devices over USB, the GLFW/OpenGL viewer, PNG screenshots
  libusb-1.0-0-dev libglfw3-dev libgl-dev libpng-dev
  # viewer tests and screenshots without a display: Xvfb with Mesa's software OpenGL
  xvfb xauth libgl1-mesa-dri
  # test tools: certificates for the TLS tests; strace injects fsync failures (EIO) into a
  # running server for its fail-stop test
  openssl strace
  # tests
  libgtest-dev libgmock-dev
)
if [[ "${1:-}" != "--no-bench" ]]; then
  # CGAL is used only by the optional comparison benchmark (GPL-3, never linked into the product).
  packages+=(libcgal-dev)
fi

missing=()
for p in "${packages[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$p")
  fi
done

if ((${#missing[@]} == 0)); then
  echo "install-deps: all ${#packages[@]} packages already installed"
  exit 0
fi

echo "install-deps: installing ${missing[*]}"
SUDO=""
if [[ $(id -u) -ne 0 ]]; then SUDO="sudo"; fi
export DEBIAN_FRONTEND=noninteractive
$SUDO apt-get update -qq
$SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}"
