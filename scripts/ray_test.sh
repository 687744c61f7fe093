#!/usr/bin/env bash
# The distributed bake's check (docs/distributed.md): a bake over a local Ray cluster of two
# workers gives the file the single-process bake of the same plan gives, also when a worker
# dies in the middle of a shard.
#
#     scripts/ray_test.sh [RADIOSITY_BINARY]     # default target/release/radiosity
#
# Builds nothing but a missing default binary (cargo build --release --bin radiosity); installs
# Ray from scripts/ray-requirements.txt when `import ray` fails. On a small city
# (scripts/city.py, 3 × 3 blocks) at 3000 patches, 4 systems, 4 shards:
#   1. bake-plan writes a plan of 4 shards;
#   2. `radiosity bake --plan` bakes it in one process;
#   3. scripts/ray_bake.py bakes it on 2 workers (object store): `radiosity compare` says same;
#   4. the same with shard 1's worker killed mid-shard (RAY_BAKE_KILL_SHARD=1): Ray retried it,
#      and the file is again the same;
#   5. the same with shared storage (--storage shared): the same file;
#   6. the same reusing the file of 3 (OLD.rad and OLD.rad.rows sent through the object store);
#   7. a building moved (scripts/move_object.py), rebaked reusing the file of 2: the Ray rebake
#      is the full one-process bake of the moved city;
#   8. bake-assemble refuses rows with a shard missing (one `error:` line, non-zero exit);
#   9. without Ray, ray_bake.py says how to install it and exits 2.
# About 90 s on a 2-core machine. Ends with `N passed, M failed`; exits 1 on any failure.
set -uo pipefail
cd "$(dirname "$0")/.."

bin=${1:-target/release/radiosity}
if [ ! -x "$bin" ]; then
    if [ $# -ge 1 ]; then
        echo "error: $bin is not an executable file" >&2
        exit 2
    fi
    cargo build --release --bin radiosity || exit 2
fi
bin=$(realpath "$bin")

if ! python3 -c "import ray" 2>/dev/null; then
    echo "installing Ray (scripts/ray-requirements.txt)"
    python3 -m pip install -q -r scripts/ray-requirements.txt \
        || python3 -m pip install -q --break-system-packages -r scripts/ray-requirements.txt \
        || { echo "error: could not install Ray" >&2; exit 2; }
fi

work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
unset RAY_ADDRESS RAY_BAKE_KILL_SHARD RAY_BAKE_KILL_MARK  # a local cluster, no kill unless asked
export RADIOSITY_BIN=$bin
start=$(date +%s)
passed=0
failed=0

check() {  # check NAME COMMAND...: runs the command, counts and reports it
    local name=$1
    shift
    local t0=$SECONDS
    if "$@"; then
        passed=$((passed + 1))
        echo "ok      $name ($((SECONDS - t0)) s)"
    else
        failed=$((failed + 1))
        echo "FAILED  $name ($((SECONDS - t0)) s)"
    fi
}

show() {  # the tail of a log, indented
    sed 's/^/    | /' "$1" | tail -n "${2:-15}"
}

python3 scripts/city.py "$work/city" 3 >/dev/null
scene=$work/city/city.obj
plan=$work/plan.json

make_plan() {
    "$bin" bake-plan "$scene" -o "$plan" --patches 3000 --systems 4 --shards 4 \
        >"$work/plan.log" 2>&1 || { show "$work/plan.log"; return 1; }
    python3 -c '
import json, sys
plan = json.load(open(sys.argv[1]))
shards = len(plan["shards"])
assert shards == 4, f"{shards} shards"
assert plan["plan_hash"], "no plan_hash"
' "$plan"
}

one_process() {
    "$bin" bake "$scene" -o "$work/one.rad" --plan "$plan" >"$work/one.log" 2>&1 \
        || { show "$work/one.log"; return 1; }
}

same_as_one() {  # same_as_one FILE: radiosity compare says same
    local out
    out=$("$bin" compare "$work/one.rad" "$1" 2>&1) || { echo "    | $out"; return 1; }
    [ "$(echo "$out" | tail -n 1)" = same ] || { echo "    | $out"; return 1; }
}

ray_object() {
    python3 scripts/ray_bake.py "$scene" --plan "$plan" --workers 2 -o "$work/ray.rad" \
        --rows-dir "$work/rows" --json >"$work/ray.json" 2>"$work/ray.log" \
        || { show "$work/ray.log"; return 1; }
    tail -n 1 "$work/ray.json" | cut -c 1-200 | sed 's/^/    | /'
    same_as_one "$work/ray.rad"
}

ray_killed() {
    mkdir -p "$work/mark"
    RAY_BAKE_KILL_SHARD=1 RAY_BAKE_KILL_MARK=$work/mark \
        python3 scripts/ray_bake.py "$scene" --plan "$plan" --workers 2 -o "$work/killed.rad" \
        --json >"$work/killed.json" 2>"$work/killed.log" \
        || { show "$work/killed.log"; return 1; }
    tail -n 1 "$work/killed.json" | cut -c 1-200 | sed 's/^/    | /'
    [ -e "$work/mark/killed-shard-1" ] || { echo "    | shard 1 was never killed"; return 1; }
    python3 -c '
import json, sys
report = json.loads(open(sys.argv[1]).read().strip().splitlines()[-1])
retries = report["retries"]
assert retries >= 1, f"retries {retries}: Ray did not retry the killed shard"
' "$work/killed.json" || return 1
    same_as_one "$work/killed.rad"
}

ray_shared() {
    python3 scripts/ray_bake.py "$scene" --plan "$plan" --workers 2 -o "$work/shared.rad" \
        --storage shared --shared-dir "$work/shared-rows" >"$work/shared.log" 2>&1 \
        || { show "$work/shared.log"; return 1; }
    [ "$(find "$work/shared-rows" -name 'rows-*' | wc -l)" -eq 4 ] \
        || { echo "    | not 4 rows files in the shared folder"; return 1; }
    same_as_one "$work/shared.rad"
}

ray_reuse() {
    python3 scripts/ray_bake.py "$scene" --plan "$plan" --workers 2 -o "$work/reused.rad" \
        --reuse "$work/ray.rad" --json >"$work/reused.json" 2>"$work/reused.log" \
        || { show "$work/reused.log"; return 1; }
    tail -n 1 "$work/reused.json" | cut -c 1-200 | sed 's/^/    | /'
    same_as_one "$work/reused.rad"
}

ray_moved() {  # a box moved: the Ray rebake is the full bake of the moved city
    mkdir -p "$work/moved"
    python3 scripts/move_object.py "$scene" "$work/moved/city.obj" 'b_1_1_0*' 2 0 1 >/dev/null \
        || return 1
    "$bin" bake "$work/moved/city.obj" -o "$work/moved-one.rad" --plan "$plan" \
        >"$work/moved-one.log" 2>&1 || { show "$work/moved-one.log"; return 1; }
    python3 scripts/ray_bake.py "$work/moved/city.obj" --plan "$plan" --workers 2 \
        -o "$work/moved-ray.rad" --reuse "$work/one.rad" >"$work/moved-ray.log" 2>&1 \
        || { show "$work/moved-ray.log"; return 1; }
    local out
    out=$("$bin" compare "$work/moved-one.rad" "$work/moved-ray.rad" 2>&1) \
        || { echo "    | $out"; return 1; }
}

missing_shard() {
    mkdir -p "$work/three"
    find "$work/rows" -name 'rows-*' ! -name 'rows-2-*' -exec cp {} "$work/three/" \;
    if "$bin" bake-assemble "$scene" --plan "$plan" --rows "$work/three" -o "$work/three.rad" \
        >"$work/three.log" 2>&1; then
        echo "    | bake-assemble accepted rows without shard 2"
        return 1
    fi
    grep -q '^error:' "$work/three.log" || { show "$work/three.log"; return 1; }
    grep '^error:' "$work/three.log" | sed 's/^/    | /'
    [ ! -e "$work/three.rad" ] || { echo "    | a file was written anyway"; return 1; }
}

without_ray() {
    mkdir -p "$work/noray"
    echo 'raise ImportError("no Ray here")' >"$work/noray/ray.py"
    local out code=0
    out=$(PYTHONPATH=$work/noray python3 scripts/ray_bake.py "$scene" -o "$work/x.rad" 2>&1) \
        || code=$?
    [ "$code" -eq 2 ] && [ "$out" = "error: Ray is not installed: pip install -r scripts/ray-requirements.txt" ] \
        || { echo "    | exit $code: $out"; return 1; }
}

check "bake-plan: 4 shards" make_plan
check "radiosity bake --plan: one process" one_process
check "ray_bake.py, 2 workers, object store: same file" ray_object
check "ray_bake.py, shard 1's worker killed: retried, same file" ray_killed
check "ray_bake.py, shared storage: same file" ray_shared
check "ray_bake.py --reuse (object store): same file" ray_reuse
check "ray_bake.py --reuse after a box moved: the full bake's file" ray_moved
check "bake-assemble refuses a missing shard" missing_shard
check "ray_bake.py without Ray: exit 2, how to install" without_ray

echo "ray_test took $(($(date +%s) - start)) s"
echo "ray_test: $passed passed, $failed failed"
[ "$failed" -eq 0 ]
