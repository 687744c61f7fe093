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
while proc.poll() is None:
    try:
        with open(f"/proc/{proc.pid}/status") as f:
            for l in f:
                if l.startswith("VmRSS:"):
                    samples.append((time.time(), int(l.split()[1]) * 1024))
                elif l.startswith("VmHWM:"):
                    hwm = int(l.split()[1]) * 1024
    except (FileNotFoundError, ProcessLookupError):
        break
    time.sleep(0.05)
proc.wait()
time.sleep(0.2)
stage = re.compile(r"^\w+: (.+?) (\d+(?:\.\d+)?) s$")
print(f"{'stage':<16} {'seconds':>9} {'peak RSS MB':>12}")
for t_end, line in lines:
    m = stage.match(line)
    if not m:
        continue
    name, secs = m.group(1), float(m.group(2))
    t0 = t_end - secs
    inside = [r for t, r in samples if t0 - 0.05 <= t <= t_end + 0.05]
    peak = max(inside) / 1e6 if inside else float("nan")
    print(f"{name:<16} {secs:>9.1f} {peak:>12.1f}")
print(f"{'all':<16} {time.time() - start:>9.1f} {hwm / 1e6:>12.1f}  (VmHWM)")
sys.exit(proc.returncode)
