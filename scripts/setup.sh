#!/usr/bin/env bash
# Installs the Debian 12 packages f16race needs, then three.js for the replay page (npm ci in
# apps/viewer). Idempotent: installs only what is missing, and uses sudo only when not already root.
set -euo pipefail
cd "$(dirname "$0")/.."

packages=(
  cmake g++ make ninja-build
  libtorch-dev       # LibTorch 1.13 (CPU): the learning layers
  libgloo-dev        # the headers of c10d's Gloo process group (distributed runs: lib/dist)
  libeigen3-dev libyaml-cpp-dev libspdlog-dev libcli11-dev libgtest-dev
  gnuplot-nox        # figures
  python3-torch      # tests load exported TorchScript policies with plain PyTorch
  pybind11-dev python3-dev python3-numpy  # the `f16race` Python module (python/) and its tests
  libopenblas0-pthread  # LibTorch calls the system BLAS: OpenBLAS is 3-7x faster than the reference one
  nodejs npm         # npm installs three.js, which the build embeds in the replay page (apps/viewer)
  chromium           # the replay page's test renders it headless (tests/viewer)
)

# A package counts as present when it is installed, or when an installed package provides it:
# NodeSource's nodejs provides npm (and conflicts with Debian's), which must then not be installed.
provided=" $(dpkg-query -W -f='${db:Status-Status} ${Provides}\n' 2>/dev/null |
              awk '$1 == "installed" { $1 = ""; print }' | tr ',' '\n' | sed 's/(.*)//' | tr -d ' ' | tr '\n' ' ') "
missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" && continue
  [[ "$provided" == *" $p "* ]] && continue
  missing+=("$p")
done
if [ ${#missing[@]} -eq 0 ]; then
  echo "setup: all ${#packages[@]} packages present"
else
  as_root=()
  if [ "$(id -u)" -ne 0 ]; then
    command -v sudo >/dev/null || { echo "setup: need root or sudo to install: ${missing[*]}" >&2; exit 1; }
    as_root=(sudo)
  fi
  echo "setup: installing ${missing[*]}"
  export DEBIAN_FRONTEND=noninteractive
  "${as_root[@]}" apt-get update -qq
  "${as_root[@]}" apt-get install -y -qq --no-install-recommends "${missing[@]}"
fi

# three.js at the version apps/viewer/package-lock.json pins, as the calling user (no root needed).
# `npm ls` succeeds when node_modules already holds it, so a second run changes nothing offline.
if (cd apps/viewer && npm ls --depth=0 >/dev/null 2>&1); then
  echo "setup: apps/viewer/node_modules up to date"
else
  echo "setup: npm ci in apps/viewer"
  (cd apps/viewer && npm ci --no-audit --no-fund --loglevel=error)
fi
