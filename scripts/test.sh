#!/usr/bin/env bash
# The project's test command (README, and .ci/run calls it). Installs what the tests need on a
# fresh Debian machine, then runs every test of the workspace.
set -euo pipefail
cd "$(dirname "$0")/.."

# System packages the tests need. None yet: the wgpu tests (GPU-backend issue) will add Debian's
# software Vulkan driver here (mesa-vulkan-drivers libvulkan1).
need_packages=()
missing=()
for p in "${need_packages[@]}"; do
    dpkg -s "$p" >/dev/null 2>&1 || missing+=("$p")
done
if [ ${#missing[@]} -gt 0 ]; then
    echo "installing: ${missing[*]}"
    apt-get update -qq && apt-get install -y -qq --no-install-recommends "${missing[@]}"
fi

cargo test --workspace "$@"
