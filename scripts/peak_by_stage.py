#!/usr/bin/env python3
"""Runs a command (a `radiosity bake`, stderr not a terminal) and prints the peak resident
memory of each stage, sampling /proc every 50 ms; the stages come from its stage lines
(`bake: NAME 12.3 s`, printed when a stage ends). Other stderr lines pass through.

    scripts/peak_by_stage.py target/release/radiosity bake SCENE.obj -o OUT.rad --patches 2048 --json
"""
import re
import subprocess
import sys
import threading
import time

proc = subprocess.Popen(sys.argv[1:], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
samples = []  # (time, rss bytes)
lines = []  # (time, line)


def read_err():
    for line in proc.stderr:
        lines.append((time.time(), line.rstrip("\n")))
        sys.stderr.write(line)


def read_out():
    for _ in proc.stdout:
        pass


threading.Thread(target=read_err, daemon=True).start()
threading.Thread(target=read_out, daemon=True).start()
start = time.time()
hwm = 0


def status(pid):
    """VmRSS and VmHWM of `pid` in bytes (0 where it is gone)."""
    rss = peak = 0
    try:
        with open(f"/proc/{pid}/status") as f:
            for l in f:
                if l.startswith("VmRSS:"):
                    rss = int(l.split()[1]) * 1024
                elif l.startswith("VmHWM:"):
                    peak = int(l.split()[1]) * 1024
    except (FileNotFoundError, ProcessLookupError):
        pass
    return rss, peak


while proc.poll() is None:
    # The command and its children (the bake under `/usr/bin/time -v`).
    pids = [proc.pid]
    try:
        with open(f"/proc/{proc.pid}/task/{proc.pid}/children") as f:
            pids += [int(p) for p in f.read().split()]
    except (FileNotFoundError, ProcessLookupError):
        pass
    now = [status(p) for p in pids]
    samples.append((time.time(), sum(r for r, _ in now)))
    hwm = max([hwm] + [h for _, h in now])
    time.sleep(0.05)
proc.wait()
time.sleep(0.2)
stage = re.compile(r"^\w+: (.+?) (\d+(?:\.\d+)?) s$")
# Lines of the stages that end within the first second are held and printed together later:
# a stage ends where the next one starts, going back from the last line.
stages = [(t, m.group(1), float(m.group(2))) for t, l in lines if (m := stage.match(l))]
rows, next_start = [], float("inf")
for t_line, name, secs in reversed(stages):
    t_end = min(t_line, next_start)
    next_start = t_end - secs
    inside = [r for t, r in samples if next_start - 0.05 <= t <= t_end + 0.05]
    rows.append((name, secs, max(inside) / 1e6 if inside else float("nan")))
print(f"{'stage':<16} {'seconds':>9} {'peak RSS MB':>12}")
for name, secs, peak in reversed(rows):
    print(f"{name:<16} {secs:>9.1f} {peak:>12.1f}")
print(f"{'all':<16} {time.time() - start:>9.1f} {hwm / 1e6:>12.1f}  (VmHWM)")
sys.exit(proc.returncode)
