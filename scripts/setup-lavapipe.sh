#!/usr/bin/env bash
# Install Mesa's lavapipe (a CPU Vulkan driver) and the Vulkan loader, so that the wgpu
# backend (`--backend gpu`, tests/gpu*.rs) runs on machines without a GPU.
#
# Idempotent: nothing is installed when both packages are present (apt-get update runs only
# when something is missing). Meant for Debian 12 as root (no sudo); .ci/run calls it.
#
# Usage:
#   bash scripts/setup-lavapipe.sh            # install if missing, check the ICD file
#   PROBE=1 bash scripts/setup-lavapipe.sh    # also list wgpu's Vulkan adapters
#                                             # (`limitray gpu-info`, builds the CLI)
set -euo pipefail

ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"

is_installed() {
    dpkg-query -W -f='${Status}' "$1" 2>/dev/null | grep -q '^install ok installed$'
}

missing=()
for pkg in libvulkan1 mesa-vulkan-drivers; do
    if ! is_installed "$pkg"; then
        missing+=("$pkg")
    fi
done

if ((${#missing[@]} > 0)); then
    if [[ $(id -u) -ne 0 ]]; then
        echo "setup-lavapipe: need root to install: ${missing[*]}" >&2
        exit 1
    fi
    echo "setup-lavapipe: installing ${missing[*]}" >&2
    export DEBIAN_FRONTEND=noninteractive
    apt-get update
    apt-get install -y --no-install-recommends "${missing[@]}"
else
    echo "setup-lavapipe: libvulkan1 and mesa-vulkan-drivers already installed" >&2
fi

icd=$(ls /usr/share/vulkan/icd.d/lvp_icd*.json 2>/dev/null | head -n1 || true)
if [[ -z "$icd" ]]; then
    echo "setup-lavapipe: lavapipe's ICD file (/usr/share/vulkan/icd.d/lvp_icd*.json) is missing" >&2
    exit 1
fi
echo "setup-lavapipe: lavapipe ICD: $icd" >&2

if [[ "${PROBE:-0}" == 1 ]]; then
    # A wgpu adapter probe (no vulkaninfo needed): lists the Vulkan adapters wgpu sees.
    (cd "$ROOT" && NODEVICE_SELECT=1 cargo run --quiet --release -- gpu-info)
fi
