#!/usr/bin/env bash
# Runs every fuzz target (or the ones named) for SECONDS each, one after another.
#
#   fuzz/run.sh SECONDS [TARGET...]
#
# Needs a nightly toolchain and cargo-fuzz (`cargo install cargo-fuzz`); without them it says so
# and exits 0, so CI and machines without nightly are not broken by it. New inputs libFuzzer
# finds go to fuzz/corpus-work/<target>/ (git-ignored); the committed seeds in corpus/ and the
# regressions/ are read, never written. A crash stops the run with a non-zero status and leaves
# its input in fuzz/artifacts/<target>/: minimise it (`cargo +nightly fuzz tmin`) and commit it
# to fuzz/regressions/<target>/ (README.md).
set -euo pipefail

usage="usage: fuzz/run.sh SECONDS [TARGET...]"
secs=${1:?$usage}
shift
if ! [[ $secs =~ ^[0-9]+$ ]]; then
    echo "$usage" >&2
    exit 2
fi
cd "$(dirname "$0")"

if ! cargo +nightly --version >/dev/null 2>&1; then
    echo "fuzz/run.sh: no nightly toolchain (rustup toolchain install nightly): not fuzzing."
    exit 0
fi
if ! cargo +nightly fuzz --version >/dev/null 2>&1; then
    echo "fuzz/run.sh: cargo-fuzz is not installed (cargo install cargo-fuzz): not fuzzing."
    exit 0
fi

targets=("$@")
if [ ${#targets[@]} -eq 0 ]; then
    targets=(decode_blocks parse_container encode_roundtrip)
fi

for t in "${targets[@]}"; do
    # Per target: the longest input, and the largest single allocation libFuzzer allows.
    # parse_container: 128 KiB inputs, 1 MiB allocations: the parser may not allocate more
    # than a small multiple of its input (tests/tests/fuzz_corpus.rs measures it exactly).
    case $t in
    decode_blocks) extra=(-max_len=4096 -malloc_limit_mb=64) ;;
    parse_container) extra=(-max_len=131072 -malloc_limit_mb=1) ;;
    encode_roundtrip) extra=(-max_len=4096 -malloc_limit_mb=64) ;;
    *)
        echo "fuzz/run.sh: unknown target $t" >&2
        exit 2
        ;;
    esac
    mkdir -p "corpus-work/$t" "regressions/$t"
    echo "=== fuzz/run.sh: $t for ${secs}s"
    # One process, one thread (no -jobs/-workers): the machines are small and shared.
    cargo +nightly fuzz run "$t" "corpus-work/$t" "corpus/$t" "regressions/$t" -- \
        -max_total_time="$secs" -rss_limit_mb=512 "${extra[@]}" -print_final_stats=1
done
