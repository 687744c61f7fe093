#!/usr/bin/env bash
# The project's test command (README, and .ci/run calls it). Installs what the tests need on a
# fresh Debian machine, then runs every test of the workspace.
set -euo pipefail
cd "$(dirname "$0")/.."

# System packages the tests need: Debian's software Vulkan driver (lavapipe) and the loader,
# so the wgpu gather tests (tests/tests/wgpu_gather.rs) have an adapter on a machine without a
# GPU. With CI=true (.ci/run) those tests fail rather than skip when no adapter is found.
need_packages=(mesa-vulkan-drivers libvulkan1)
missing=()
for p in "${need_packages[@]}"; do
    dpkg -s "$p" >/dev/null 2>&1 || missing+=("$p")
done
# A C compiler: radiosity-capi's tests compile its C example (radiosity-capi/examples/gather.c)
# with `cc` and link it against the crate's shared library.
command -v cc >/dev/null 2>&1 || missing+=(gcc libc6-dev)
if [ ${#missing[@]} -gt 0 ]; then
    echo "installing: ${missing[*]}"
    apt-get update -qq && apt-get install -y -qq --no-install-recommends "${missing[@]}"
fi

# Mesa's device-select layer complains about a missing XDG_RUNTIME_DIR on headless machines;
# the message is harmless, this silences it.
export NODEVICE_SELECT=1
cargo test --workspace "$@"

# The distributed bake through Ray (a local cluster of two workers) against the one-process bake,
# with a worker killed mid-shard (docs/distributed.md), on the binary the tests just built;
# installs Ray from scripts/ray-requirements.txt where it is missing.
scripts/ray_test.sh target/debug/radiosity
