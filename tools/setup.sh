#!/usr/bin/env bash
# Install the Debian packages the build, the tests and the demo need, only
# those missing. Uses sudo only when not root. Does nothing when all are present.
set -euo pipefail

packages=(
  cmake ninja-build pkg-config gcc g++ make
  gcc-arm-none-eabi libnewlib-arm-none-eabi binutils-arm-none-eabi
  libcmocka-dev libeigen3-dev
  qemu-system-arm
  cppcheck clang clang-tidy clang-format libclang-rt-14-dev
  valgrind bc
  python3 python3-matplotlib python3-numpy python3-serial
  openocd
  libunicorn-dev
)

missing=()
for p in "${packages[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$p")
  fi
done
if [ ${#missing[@]} -eq 0 ]; then
  exit 0
fi

echo "setup: installing missing Debian packages: ${missing[*]}"
if [ "$(id -u)" -eq 0 ]; then
  sudo=()
elif command -v sudo >/dev/null 2>&1; then
  sudo=(sudo)
else
  echo "setup: not root and no sudo; install as root: apt-get install ${missing[*]}" >&2
  exit 1
fi
export DEBIAN_FRONTEND=noninteractive
"${sudo[@]}" apt-get update -q
"${sudo[@]}" apt-get install -y -q --no-install-recommends "${missing[@]}"
