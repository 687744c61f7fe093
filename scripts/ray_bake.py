#!/usr/bin/env python3
"""A bake spread over a Ray cluster: one Ray task per shard of a bake plan, then one assembly.

    scripts/ray_bake.py SCENE -o OUT.rad [BAKE FLAGS ... | --plan PLAN.json] [--reuse OLD.rad]
                        [--workers N] [--shards N] [--cpus-per-shard N] [--radiosity PATH]
                        [--storage object|shared] [--shared-dir DIR] [--rows-dir DIR] [--json]

The steps are those of `radiosity bake-plan`, `bake-shard` and `bake-assemble`
(docs/distributed.md):

1. Without `--plan`, the driver (this process) runs `radiosity bake-plan SCENE -o PLAN
   BAKE FLAGS [--shards N]` itself; every argument this script does not know is a bake flag
   (`--patches 3000 --systems 4`). SCENE comes first. With `--plan` the bake flags are the plan's.
2. One Ray task per shard (`num_cpus=1`, or N with `--cpus-per-shard N`, the bake's threads
   too; `max_retries=3`: a task whose worker dies, killed, out of memory or lost with its node,
   runs again) runs `radiosity bake-shard SCENE --plan PLAN --shard K --out-dir DIR` in a
   temporary folder on its worker. A shard's rows file is named by its inputs and written whole
   (temporary file and rename), so a retried or duplicated shard writes the same name and bytes.
   A shard that bake-shard itself refuses is not retried (the same inputs fail the same way).
3. The driver runs `radiosity bake-assemble SCENE --plan PLAN --rows DIR -o OUT.rad [--reuse
   OLD.rad]` and passes its output through. The file is the one `radiosity bake SCENE -o OUT.rad
   --plan PLAN` writes (`radiosity compare` says `same`).

Storage (`--storage`):

* `object` (the default): nothing needs to be shared between machines. The driver puts the
  scene's folder (every regular file under the scene file's directory but baked `.rad`,
  `.rad.rows` and `rows-*` files: the OBJ's mtllib and textures, a glTF's buffers; at most
  1 GiB, else use `--storage shared`), the plan, and with `--reuse` OLD.rad and OLD.rad.rows
  in Ray's object store once; each task writes them into its temporary folder, bakes its shard
  there and returns the rows file's name and bytes. The driver
  writes the rows into `--rows-dir` (default: a temporary folder, removed at the end) and
  assembles from there.
* `shared`: every worker reads SCENE, the plan and OLD.rad at the same absolute paths as the
  driver (a shared file system: an NFS export, a Kubernetes PersistentVolumeClaim mounted on
  every pod), and writes its rows file straight into `--shared-dir DIR` (required), from which
  the driver assembles. A plan made by this script is written into DIR too.

The cluster: with `RAY_ADDRESS` set (as a RayJob sets it) the script connects to that cluster
and leaves it running; otherwise it starts a local one of `--workers N` CPUs (default 2) and
stops it at the end.

The binary: `--radiosity PATH`, else `$RADIOSITY_BIN`, else `target/release/radiosity` of this
repository, else `radiosity` on PATH. A worker runs the same path where it exists on its
machine, else `radiosity` on its PATH (the Kubernetes image puts it there).

At the end the script prints the wall time, each shard's seconds, the assembly's seconds and
how many task attempts failed and were retried (counted by a small Ray actor each attempt
reports to); with `--json` one JSON object instead: {"shards", "workers", "seconds",
"shard_seconds", "assemble_seconds", "retries", "plan_hash", "assemble"}. Progress (shards done,
elapsed, ETA) goes to stderr. Any failure (a shard failed after its retries, an assembly
refusal) ends with one `error:` line and a non-zero exit.

Test hook: with `RAY_BAKE_KILL_SHARD=K`, the first attempt of shard K starts bake-shard, waits
half a second, then SIGKILLs bake-shard and its own Ray worker process; Ray retries the task and
the file comes out the same. The first attempt is told by a marker file in `RAY_BAKE_KILL_MARK`
(a folder the workers can write; default: a temporary folder on the driver's machine, which
serves a local cluster).

Needs Ray (`pip install -r scripts/ray-requirements.txt`).
"""

import argparse
import json
import os
import shutil
import signal
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

MAX_SCENE_BYTES = 1 << 30  # the object store carries scenes up to 1 GiB; above, --storage shared
REPO = Path(__file__).resolve().parent.parent


class Failure(Exception):
    """A failure reported as one `error:` line."""


def fail(message, code=1):
    print(f"error: {message}", file=sys.stderr)
    sys.exit(code)


def find_binary(given):
    """The radiosity binary: --radiosity, $RADIOSITY_BIN, the repository's release build, PATH."""
    for candidate in (given, os.environ.get("RADIOSITY_BIN")):
        if candidate:
            path = shutil.which(candidate) or candidate
            if not (os.path.isfile(path) and os.access(path, os.X_OK)):
                raise Failure(f"radiosity binary {candidate!r} is not an executable file")
            return os.path.abspath(path)
    built = REPO / "target" / "release" / "radiosity"
    if built.is_file() and os.access(built, os.X_OK):
        return str(built)
    on_path = shutil.which("radiosity")
    if on_path:
        return on_path
    raise Failure(
        "no radiosity binary: give --radiosity PATH or RADIOSITY_BIN, build it with "
        "`cargo build --release`, or put `radiosity` on PATH"
    )


def last_line(text):
    lines = [line for line in text.strip().splitlines() if line.strip()]
    return lines[-1].strip() if lines else ""


def error_of(proc):
    """The `error:` line a failed radiosity command printed, else its last line of output."""
    for line in reversed(proc.stderr.splitlines()):
        if line.startswith("error:"):
            return line[len("error:"):].strip()
    return last_line(proc.stderr) or last_line(proc.stdout) or f"exit status {proc.returncode}"


def run_streamed(command, capture_stdout):
    """Runs a radiosity command on the driver, its stderr passed on as it comes except its
    `error:` lines, which are returned (the script ends with one error line of its own).
    Returns (exit status, stdout if captured, error messages)."""
    proc = subprocess.Popen(command, stdout=subprocess.PIPE if capture_stdout else None,
                            stderr=subprocess.PIPE, text=True)
    out, errors = [], []
    reader = None
    if capture_stdout:  # read stdout beside stderr, so that neither pipe fills and blocks
        reader = threading.Thread(target=lambda: out.append(proc.stdout.read()))
        reader.start()
    for line in proc.stderr:
        if line.startswith("error:"):
            errors.append(line[len("error:"):].strip())
        else:
            sys.stderr.write(line)
            sys.stderr.flush()
    if reader is not None:
        reader.join()
    return proc.wait(), "".join(out), errors


def refusal(what, code, errors):
    return Failure(f"{what}: {errors[-1]}" if errors else f"{what} failed (exit status {code})")


def scene_bundle(scene, skip):
    """Every regular file under the scene's folder as {relative path: bytes}."""
    root = scene.parent
    files, total = {}, 0
    for folder, dirs, names in os.walk(root):
        dirs[:] = sorted(d for d in dirs if not d.startswith("."))
        for name in sorted(names):
            path = Path(folder) / name
            if (not path.is_file() or path.resolve() in skip
                    or name.endswith((".rad", ".rad.rows")) or name.startswith("rows-")):
                continue  # baked files and rows: never part of a scene
            total += path.stat().st_size
            if total > MAX_SCENE_BYTES:
                raise Failure(
                    f"the scene's folder {root} holds more than 1 GiB: the object store would "
                    "carry all of it to every worker; use --storage shared --shared-dir DIR "
                    "(or move the scene into a folder of its own)"
                )
            files[str(path.relative_to(root))] = path.read_bytes()
    return files


def bake_shard_task(binary, shard, scene, plan, reuse, out_dir, kill, counter):
    """One attempt at one shard, on a worker. Returns (name, bytes or None, seconds).

    `scene`, `plan`, `reuse` are paths (shared storage) or, with the object store, `scene` is
    (scene file's relative path, {relative path: bytes}), `plan` is (name, bytes) and `reuse`
    None or {name: bytes} (OLD.rad and OLD.rad.rows); `out_dir` is None with the object store.
    """
    import ray  # on the worker

    attempt = ray.get(counter.attempt.remote(shard))
    if not (os.path.isfile(binary) and os.access(binary, os.X_OK)):
        binary = shutil.which("radiosity")
        if binary is None:
            raise RuntimeError(f"shard {shard}: no radiosity binary on the worker at "
                               f"{os.uname().nodename}: put it on the worker's PATH")
    work = tempfile.mkdtemp(prefix=f"ray-bake-{shard}-")
    try:
        if out_dir is None:  # the object store: write the inputs into the temporary folder
            relative, files = scene
            for name, data in files.items():
                path = Path(work, "scene", name)
                path.parent.mkdir(parents=True, exist_ok=True)
                path.write_bytes(data)
            scene = str(Path(work, "scene", relative))
            plan_name, plan_data = plan
            plan = str(Path(work, plan_name))
            Path(plan).write_bytes(plan_data)
            if reuse is not None:
                for name, data in reuse.items():
                    Path(work, "reuse").mkdir(exist_ok=True)
                    Path(work, "reuse", name).write_bytes(data)
                reuse = str(Path(work, "reuse", min(reuse, key=len)))  # OLD.rad before OLD.rad.rows
            rows = str(Path(work, "rows"))
            os.makedirs(rows, exist_ok=True)
        else:
            rows = out_dir
        command = [binary, "bake-shard", scene, "--plan", plan, "--shard", str(shard),
                   "--out-dir", rows, "--json"]
        if reuse is not None:
            command += ["--reuse", reuse]
        env = dict(os.environ)
        if "RAYON_NUM_THREADS" not in env:  # the bake's threads: the CPUs Ray gave this task
            cpus = ray.get_runtime_context().get_assigned_resources().get("CPU", 1)
            env["RAYON_NUM_THREADS"] = str(max(1, int(cpus)))
        start = time.monotonic()
        if kill is not None and kill[0] == shard:
            marker = Path(kill[1], f"killed-shard-{shard}")
            try:
                fd = os.open(marker, os.O_CREAT | os.O_EXCL | os.O_WRONLY)
            except FileExistsError:
                pass  # a later attempt: bake as usual
            else:
                os.write(fd, f"attempt {attempt}\n".encode())
                os.close(fd)
                child = subprocess.Popen(command, stdout=subprocess.DEVNULL,
                                         stderr=subprocess.DEVNULL, env=env)
                try:
                    child.wait(timeout=0.5)
                except subprocess.TimeoutExpired:
                    pass
                child.kill()
                child.wait()
                shutil.rmtree(work, ignore_errors=True)
                os.kill(os.getpid(), signal.SIGKILL)  # the worker dies mid-task: Ray retries
        proc = subprocess.run(command, capture_output=True, text=True, env=env)
        seconds = time.monotonic() - start
        if proc.returncode != 0:
            raise RuntimeError(f"shard {shard}: {error_of(proc)}")
        out = last_line(proc.stdout)
        try:
            report = json.loads(out)
            path, seconds = report["path"], float(report.get("seconds", seconds))
        except (ValueError, KeyError, TypeError):
            path = out  # the path on the last line
        if not os.path.isabs(path):
            path = os.path.join(rows, path) if not os.path.exists(path) else os.path.abspath(path)
        name = os.path.basename(path)
        data = Path(path).read_bytes() if out_dir is None else None
        return name, data, seconds
    finally:
        shutil.rmtree(work, ignore_errors=True)


class AttemptCounter:
    """Counts each shard's task attempts (a Ray actor): attempts beyond one were retries."""

    def __init__(self):
        self.attempts = {}

    def attempt(self, shard):
        self.attempts[shard] = self.attempts.get(shard, 0) + 1
        return self.attempts[shard]

    def counts(self):
        return dict(self.attempts)


def write_whole(path, data):
    """Writes a file by a temporary file and a rename, as bake-shard does."""
    tmp = path.with_name(f".{path.name}.tmp-{os.getpid()}")
    tmp.write_bytes(data)
    os.replace(tmp, path)


def fmt_seconds(s):
    return f"{s:.0f} s" if s >= 10 else f"{s:.1f} s"


class Parser(argparse.ArgumentParser):
    def error(self, message):  # one `error:` line, as the binary's
        fail(f"{message} (see --help)", 2)


def parse(argv):
    parser = Parser(
        prog="ray_bake.py", allow_abbrev=False,
        description="Bake a scene over a Ray cluster, one task per shard of a plan; "
                    "arguments it does not know are bake flags for bake-plan.",
        epilog="See the module docstring and docs/distributed.md.")
    parser.add_argument("scene", metavar="SCENE")
    parser.add_argument("-o", "--output", required=True, metavar="OUT.rad")
    parser.add_argument("--plan", metavar="PLAN.json", help="a plan from `radiosity bake-plan`")
    parser.add_argument("--reuse", metavar="OLD.rad", help="reuse rows of an earlier bake")
    parser.add_argument("--workers", type=int, default=2,
                        help="CPUs of the local cluster (ignored with RAY_ADDRESS); default 2")
    parser.add_argument("--cpus-per-shard", type=int, default=1, metavar="N",
                        help="CPUs (Ray's num_cpus, the bake's threads) of each shard's task; "
                             "default 1")
    parser.add_argument("--shards", type=int, help="shards of the plan made here (bake-plan)")
    parser.add_argument("--radiosity", metavar="PATH", help="the radiosity binary")
    parser.add_argument("--storage", choices=("object", "shared"), default="object")
    parser.add_argument("--shared-dir", metavar="DIR",
                        help="with --storage shared: where workers write the rows files")
    parser.add_argument("--rows-dir", metavar="DIR",
                        help="with --storage object: keep the rows files here")
    parser.add_argument("--json", action="store_true", help="one JSON object on stdout")
    args, bake_flags = parser.parse_known_args(argv)
    if bake_flags and bake_flags[0] == "--":
        bake_flags = bake_flags[1:]
    if args.plan and bake_flags:
        parser.error(f"bake flags {' '.join(bake_flags)} come from the plan with --plan")
    if args.plan and args.shards is not None:
        parser.error("--shards comes from the plan with --plan")
    if args.cpus_per_shard < 1:
        parser.error("--cpus-per-shard must be at least 1")
    if args.workers < 1:
        parser.error("--workers must be at least 1")
    if args.storage == "shared" and not args.shared_dir:
        parser.error("--storage shared needs --shared-dir DIR")
    return args, bake_flags


def run(args, bake_flags, ray):
    started = time.monotonic()
    binary = find_binary(args.radiosity)
    scene = Path(args.scene).resolve()
    if not scene.is_file():
        raise Failure(f"no scene file {args.scene}")
    output = Path(args.output).resolve()
    reuse = Path(args.reuse).resolve() if args.reuse else None
    if reuse is not None and not reuse.is_file():
        raise Failure(f"no file {args.reuse} to reuse")
    shared = Path(args.shared_dir).resolve() if args.storage == "shared" else None
    scratch = Path(tempfile.mkdtemp(prefix="ray-bake-driver-"))
    try:
        if shared is not None:
            shared.mkdir(parents=True, exist_ok=True)
        # 1. The plan.
        if args.plan:
            plan = Path(args.plan).resolve()
            if not plan.is_file():
                raise Failure(f"no plan {args.plan}")
        else:
            plan = (shared or scratch) / "plan.json"
            command = [binary, "bake-plan", str(scene), "-o", str(plan), *bake_flags]
            if args.shards is not None:
                command += ["--shards", str(args.shards)]
            code, out, errors = run_streamed(command, capture_stdout=True)
            sys.stderr.write(out)  # its summary: stdout is this script's report
            if code != 0:
                raise refusal("bake-plan", code, errors)
        try:
            plan_json = json.loads(plan.read_text())
            shards = len(plan_json["shards"])
        except (ValueError, KeyError, TypeError) as e:
            raise Failure(f"{plan} is not a bake plan ({e})")
        plan_hash = plan_json.get("plan_hash")
        if shards < 1:
            raise Failure(f"{plan} has no shards")

        # 2. The cluster.
        if os.environ.get("RAY_ADDRESS"):
            ray.init(logging_level="WARNING")
        else:
            ray.init(address="local", num_cpus=args.workers, include_dashboard=False,
                     logging_level="WARNING")  # a new cluster, even beside a running one
        workers = int(ray.cluster_resources().get("CPU", 0)) or args.workers
        if args.cpus_per_shard > workers:
            raise Failure(f"--cpus-per-shard {args.cpus_per_shard} is more than the cluster's "
                          f"{workers} CPUs: no shard could start")

        kill = None
        if os.environ.get("RAY_BAKE_KILL_SHARD", "").strip():
            mark = os.environ.get("RAY_BAKE_KILL_MARK") or str(scratch / "kill-mark")
            os.makedirs(mark, exist_ok=True)
            kill = (int(os.environ["RAY_BAKE_KILL_SHARD"]), mark)

        counter = ray.remote(num_cpus=0)(AttemptCounter).remote()
        task = ray.remote(max_retries=3, num_cpus=args.cpus_per_shard)(bake_shard_task)
        if shared is None:
            skip = {p for p in (output, plan, reuse) if p is not None}
            scene_ref = ray.put((str(scene.relative_to(scene.parent)), scene_bundle(scene, skip)))
            plan_ref = ray.put((plan.name, plan.read_bytes()))
            reuse_ref = None
            if reuse is not None:
                bundle = {reuse.name: reuse.read_bytes()}
                rows_cache = reuse.with_name(reuse.name + ".rows")
                if rows_cache.is_file():
                    bundle[rows_cache.name] = rows_cache.read_bytes()
                reuse_ref = ray.put(bundle)
            rows_dir = Path(args.rows_dir).resolve() if args.rows_dir else scratch / "rows"
            rows_dir.mkdir(parents=True, exist_ok=True)
            pending = {task.remote(binary, k, scene_ref, plan_ref, reuse_ref, None, kill,
                                   counter): k for k in range(shards)}
        else:
            rows_dir = shared
            pending = {task.remote(binary, k, str(scene), str(plan),
                                   str(reuse) if reuse else None, str(shared), kill,
                                   counter): k for k in range(shards)}

        # 3. The shards, as they finish.
        shard_seconds = [None] * shards
        done = 0
        bake_start = last_report = time.monotonic()
        print(f"ray_bake: {shards} shards on {workers} workers ({args.storage} storage)",
              file=sys.stderr)
        while pending:
            ready, _ = ray.wait(list(pending), num_returns=1, timeout=1.0)
            for ref in ready:
                k = pending.pop(ref)
                try:
                    name, data, seconds = ray.get(ref)
                except Exception as e:  # the task's own error, or its retries spent
                    for other in pending:
                        ray.cancel(other, force=True)
                    if isinstance(e, ray.exceptions.RayTaskError):  # raised in the task
                        cause = e.cause if e.cause is not None else e
                        text = str(cause).strip().splitlines()
                        message = text[-1] if text else type(cause).__name__
                        if not message.startswith(f"shard {k}:"):
                            message = f"shard {k}: {type(cause).__name__}: {message}"
                        raise Failure(message)
                    text = str(e).strip().splitlines()  # the worker or its node died each time
                    message = text[0] if text else type(e).__name__
                    raise Failure(f"shard {k} failed after its retries: {message}")
                if data is not None:
                    write_whole(rows_dir / name, data)
                shard_seconds[k] = round(seconds, 3)
                done += 1
            now = time.monotonic()
            if ready or now - last_report >= 10:
                elapsed = now - bake_start
                eta = elapsed / done * (shards - done) if done else None
                print(f"ray_bake: {done}/{shards} shards done, {fmt_seconds(elapsed)} elapsed"
                      + (f", ETA {fmt_seconds(eta)}" if eta is not None and pending else ""),
                      file=sys.stderr)
                last_report = now
        attempts = ray.get(counter.counts.remote())
        retries = sum(n - 1 for n in attempts.values() if n > 1)

        # 4. The assembly.
        command = [binary, "bake-assemble", str(scene), "--plan", str(plan), "--rows",
                   str(rows_dir), "-o", str(output)]
        if reuse is not None:
            command += ["--reuse", str(reuse)]
        assemble_start = time.monotonic()
        if args.json:
            command.append("--json")
        code, out, errors = run_streamed(command, capture_stdout=args.json)
        assemble_seconds = time.monotonic() - assemble_start
        if code != 0:
            raise refusal("bake-assemble", code, errors)
        seconds = time.monotonic() - started
        if args.json:
            assembled = None
            for text in (out, last_line(out)):
                try:
                    assembled = json.loads(text)
                    break
                except ValueError:
                    pass
            print(json.dumps({
                "shards": shards, "workers": workers, "seconds": round(seconds, 3),
                "shard_seconds": shard_seconds, "assemble_seconds": round(assemble_seconds, 3),
                "retries": retries, "plan_hash": plan_hash, "assemble": assembled,
            }))
        else:
            print(f"ray_bake: {output}: {shards} shards on {workers} workers in "
                  f"{seconds:.1f} s (assembly {assemble_seconds:.1f} s); shard seconds "
                  + ", ".join(f"{s:.1f}" for s in shard_seconds))
            print(f"ray_bake: {retries} task attempt(s) failed and were retried")
    finally:
        shutil.rmtree(scratch, ignore_errors=True)


def main(argv=None):
    args, bake_flags = parse(sys.argv[1:] if argv is None else argv)
    try:
        import ray
    except ImportError:
        fail("Ray is not installed: pip install -r scripts/ray-requirements.txt", 2)
    try:
        run(args, bake_flags, ray)
    except Failure as e:
        fail(str(e))
    except KeyboardInterrupt:
        fail("interrupted", 130)
    except Exception as e:  # anything unforeseen: still one error line
        fail(f"{type(e).__name__}: {e}")
    finally:
        if ray.is_initialized():
            ray.shutdown()


if __name__ == "__main__":
    main()
