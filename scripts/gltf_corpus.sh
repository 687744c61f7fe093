#!/usr/bin/env bash
# Bakes every glTF 2.0 file of Debian's assimp-testmodels package (its glTF2 directory) with
# default flags and prints, per file, `ok` or the bake's `error:` line; then the counts.
# Usage: scripts/gltf_corpus.sh [path/to/radiosity]   (default: target/release/radiosity)
# Needs: apt-get install -y assimp-testmodels
set -uo pipefail
bin=${1:-${CARGO_TARGET_DIR:-target}/release/radiosity}
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
ok=0 refused=0 other=0
while IFS= read -r f; do
    err=$("$bin" bake "$f" -o "$out/x.rad" 2>&1 >/dev/null)
    rc=$?
    errors=$(printf '%s\n' "$err" | grep -c '^error:')
    if [ $rc -eq 0 ]; then
        ok=$((ok + 1)); echo "ok       $f"
    elif [ "$errors" -eq 1 ]; then
        refused=$((refused + 1)); echo "refused  $(printf '%s\n' "$err" | grep '^error:')"
    else
        other=$((other + 1)); echo "BAD      $f (exit $rc, $errors error lines)"
    fi
done < <(dpkg -L assimp-testmodels | grep -i '/gltf2/' | grep -iE '\.(gltf|glb)$' | sort)
echo "baked $ok, refused with one error line $refused, other $other"
