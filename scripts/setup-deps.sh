#!/usr/bin/env bash
# Install every build and test dependency of vim-pipeline from Debian packages.
# Idempotent: packages that `dpkg -s` already reports as installed are skipped, and
# `apt-get update` runs once, only when something is missing.
set -euo pipefail

PACKAGES=(
  build-essential cmake pkg-config binutils
  libdeal.ii-dev
  libsuitesparse-dev   # CHOLMOD (the direct solver); deal.II pulls it in, named here because fem links it
  libinsighttoolkit5-dev
  libvtk9-dev
  libeigen3-dev
  zlib1g-dev
  libyaml-cpp-dev
  libcli11-dev
  libceres-dev   # the least-squares fit of --fit-forces
  nlohmann-json3-dev
  libtbb-dev
  libgtest-dev libgmock-dev
  libbenchmark-dev
  openmpi-bin libopenmpi-dev
  libopenblas0
  calculix-ccx gmsh
  pybind11-dev python3-dev python3-numpy python3-pytest python3-meshio
  libcairo2-dev fonts-dejavu-core
  clang-format
  clang libclang-rt-14-dev   # libFuzzer and the sanitizer runtimes for fuzz/ (scripts/fuzz.sh)
)

missing=()
for p in "${PACKAGES[@]}"; do
  if ! dpkg -s "$p" >/dev/null 2>&1; then
    missing+=("$p")
  fi
done

if [ ${#missing[@]} -eq 0 ]; then
  echo "setup-deps: all ${#PACKAGES[@]} packages already installed"
  exit 0
fi

SUDO=""
if [ "$(id -u)" -ne 0 ]; then SUDO="sudo"; fi
echo "setup-deps: installing ${missing[*]}"
export DEBIAN_FRONTEND=noninteractive
$SUDO apt-get update -q
$SUDO apt-get install -y -q --no-install-recommends "${missing[@]}"
echo "setup-deps: done"
