#!/usr/bin/env bash
# Installs the Debian 12 packages f16race needs. Idempotent: installs only what is missing,
# and uses sudo only when not already root.
set -euo pipefail

packages=(
  cmake g++ make
  libtorch-dev       # LibTorch 1.13 (CPU): the learning layers
  libgloo-dev        # the headers of c10d's Gloo process group (distributed runs: lib/dist)
  libeigen3-dev libyaml-cpp-dev libspdlog-dev libcli11-dev libgtest-dev
  gnuplot-nox        # figures
  python3-torch      # tests load exported TorchScript policies with plain PyTorch
  pybind11-dev python3-dev python3-numpy  # the `f16race` Python module (python/) and its tests
  libopenblas0-pthread  # LibTorch calls the system BLAS: OpenBLAS is 3-7x faster than the reference one
)

missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -eq 0 ]; then
  echo "setup: all ${#packages[@]} packages present"
  exit 0
fi

as_root=()
if [ "$(id -u)" -ne 0 ]; then
  command -v sudo >/dev/null || { echo "setup: need root or sudo to install: ${missing[*]}" >&2; exit 1; }
  as_root=(sudo)
fi
echo "setup: installing ${missing[*]}"
export DEBIAN_FRONTEND=noninteractive
"${as_root[@]}" apt-get update -qq
"${as_root[@]}" apt-get install -y -qq --no-install-recommends "${missing[@]}"
