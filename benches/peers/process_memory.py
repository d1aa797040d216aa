#!/usr/bin/env python3
"""Whole-process wall time and peak resident memory of `fit-brdf batch`, `info` and `fit`
(docs/performance.md, "Whole-process time and peak memory"). These figures were part of
the study's scaling section until the study stopped running the binary; the commands and
the tables are the same: N tables synthesised from the study's six materials in turn
(data-synthetic/, `fit-brdf synth`), named NN-MATERIAL.binary.

Usage: process_memory.py FIT_BRDF SPECS_DIR [N_TABLES=20] [OUT.json]

Peak RSS is GNU time's %M (KiB, converted to MB = 10^6 bytes), not this script's
RUSAGE_CHILDREN: Linux carries a parent's memory high-water mark into a child across
exec, and GNU time's own child is forked from a small process. Without /usr/bin/time the
figures are reported as not measured. Prints a markdown table; with OUT.json also writes
the rows as JSON.
"""
import json
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

# The study's materials (brdfkit_study::DEFAULT_MATERIALS), in its order.
MATERIALS = ["lambert-white", "demo-plastic", "gold-ggx", "near-mirror-silver",
             "ward-duer", "lafortune-two-lobes"]
GNU_TIME = "/usr/bin/time"


def measured(cmd):
    """(exit status, wall s, peak RSS MB or None) of one whole process."""
    with tempfile.NamedTemporaryFile("r", suffix=".maxrss") as rep:
        full = [GNU_TIME, "-f", "%M", "-o", rep.name, *cmd] if Path(GNU_TIME).exists() else cmd
        t = time.perf_counter()
        st = subprocess.run(full, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL).returncode
        wall = time.perf_counter() - t
        # GNU time writes "Command exited with non-zero status N" before the figure.
        nums = [ln.strip() for ln in Path(rep.name).read_text().splitlines() if ln.strip().isdigit()]
    return st, wall, (int(nums[-1]) * 1024 / 1e6 if nums else None)


def main():
    exe, specs = sys.argv[1], Path(sys.argv[2])
    n = int(sys.argv[3]) if len(sys.argv) > 3 else 20
    out = sys.argv[4] if len(sys.argv) > 4 else None
    rows = []
    with tempfile.TemporaryDirectory() as d:
        d = Path(d)
        synth = {}
        for m in MATERIALS:
            synth[m] = d / f"{m}.binary"
            subprocess.run([exe, "synth", str(specs / f"{m}.toml"), "--out", str(synth[m]), "-q"],
                           check=True)
        tables = []
        for i in range(n):
            m = MATERIALS[i % len(MATERIALS)]
            tables.append(d / f"{i:02}-{m}.binary")
            shutil.copyfile(synth[m], tables[-1])
        table = next((t for t in tables if "demo-plastic" in t.name), tables[0])
        params = d / "p.json"
        cmds = [
            (f"batch ({n} TABLES) --models cook-torrance --starts 1 --out DIR",
             ["batch", *map(str, tables), "--models", "cook-torrance", "--starts", "1",
              "--out", str(d / "batch-out")]),
            ("info TABLE", ["info", str(table)]),
            ("fit TABLE --model cook-torrance --starts 1 --quiet --out P.json",
             ["fit", str(table), "--model", "cook-torrance", "--starts", "1", "--quiet",
              "--out", str(params)]),
            ("fit TABLE --model cook-torrance --quiet --out P.json",
             ["fit", str(table), "--model", "cook-torrance", "--quiet", "--out", str(params)]),
        ]
        for label, args in cmds:
            st, wall, mb = measured([exe, *args])
            rows.append({"command": label, "status": st, "wall_s": wall, "peak_rss_mb": mb,
                         "tables_per_s": n / wall if label.startswith("batch") and st == 0
                         else None})
    print("| `fit-brdf …` (whole process) | peak RSS | wall | tables/s | exit |")
    print("|---|---:|---:|---:|---:|")
    for r in rows:
        mb = f"{r['peak_rss_mb']:.0f} MB" if r["peak_rss_mb"] is not None else "not measured"
        tps = f"{r['tables_per_s']:.2f}" if r["tables_per_s"] is not None else ""
        print(f"| `{r['command']}` | {mb} | {r['wall_s']:.3f} s | {tps} | {r['status']} |")
    if out:
        Path(out).write_text(json.dumps({"tables": n, "rows": rows}, indent=1))
    if any(r["status"] != 0 for r in rows):
        sys.exit(1)


if __name__ == "__main__":
    main()
