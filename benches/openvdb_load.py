#!/usr/bin/python3
"""OpenVDB's side of the "load" benchmark: time and peak memory of pyopenvdb.readAll.

    OPENVDB_DISABLE_DELAYED_LOAD=1 /usr/bin/python3 benches/openvdb_load.py FILE.vdb

Prints one JSON line: wall and CPU seconds, the resident set before the read (interpreter plus
pyopenvdb, the baseline), the peak during the read and the resident set after it, in
bytes. The peak is measured from the baseline: /proc/self/clear_refs resets the
high-water mark first, so what the imports touched does not count.

Set OPENVDB_DISABLE_DELAYED_LOAD=1: by default OpenVDB maps the file and decodes leaf
buffers only when they are first touched, so a bare readAll would not decode them.
"""

import gc
import json
import sys
import time

import pyopenvdb as vdb


def status_kib(field):
    with open("/proc/self/status") as f:
        for line in f:
            if line.startswith(field + ":"):
                return int(line.split()[1])
    raise RuntimeError(f"{field} not in /proc/self/status")


def reset_peak():
    """Resets VmHWM to the current RSS (Linux >= 4.0). Returns False if not allowed."""
    try:
        with open("/proc/self/clear_refs", "w") as f:
            f.write("5")
        return True
    except OSError:
        return False


def main():
    path = sys.argv[1]
    gc.collect()
    baseline = status_kib("VmRSS")
    peak_reset = reset_peak()
    t0, c0 = time.perf_counter(), time.process_time()
    grids, _meta = vdb.readAll(path)
    seconds, cpu = time.perf_counter() - t0, time.process_time() - c0
    peak = status_kib("VmHWM")
    after = status_kib("VmRSS")
    voxels = sum(g.activeVoxelCount() for g in grids)
    mem = sum(g.memUsage() for g in grids)
    print(json.dumps({
        "seconds": seconds,
        "cpu_seconds": cpu,
        "baseline_bytes": baseline * 1024,
        "peak_bytes": (peak - baseline) * 1024,
        "retained_bytes": (after - baseline) * 1024,
        "peak_reset": peak_reset,
        "active_voxels": voxels,
        "structure_bytes": mem,
    }))


if __name__ == "__main__":
    main()
