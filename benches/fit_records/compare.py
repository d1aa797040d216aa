#!/usr/bin/env python3
"""Fit records before/after a change: equal apart from timings.

Usage: benches/fit_records/compare.py BEFORE_DIR AFTER_DIR [REL]

Each directory holds, per table, the output directory of
`fit-brdf fit T.binary --model a,b,c --out DIR/<table>` (files <family>.json and
<family>.fit.json). Every pair of files must be equal as JSON once the timing
fields (`wall_time_s`) are removed; prints the differing paths and exits 1 otherwise.
With REL, numbers within REL of each other (relative) count as equal, and the largest
relative difference of each kind of field (the last key of its path) is printed.
`benches/fit_records/run` makes both directories from two binaries.
"""
import json
import pathlib
import sys

TIMINGS = {"wall_time_s"}


def strip(v):
    if isinstance(v, dict):
        return {k: strip(x) for k, x in v.items() if k not in TIMINGS}
    if isinstance(v, list):
        return [strip(x) for x in v]
    return v


REL = None
WORST = {}


def close(a, b, path):
    """Whether two numbers are within REL, noting the largest relative difference."""
    if REL is None or not all(isinstance(x, (int, float)) for x in (a, b)):
        return False
    d = abs(a - b) / max(abs(a), abs(b), 1e-300)
    key = path.rsplit("/", 1)[-1].split("[")[0]
    WORST[key] = max(WORST.get(key, 0.0), d)
    return d <= REL


def diff(a, b, path=""):
    """The first paths where a and b differ."""
    if isinstance(a, dict) and isinstance(b, dict):
        out = []
        for k in sorted(set(a) | set(b)):
            if k not in a or k not in b:
                out.append(f"{path}/{k}: only in {'after' if k in b else 'before'}")
            else:
                out += diff(a[k], b[k], f"{path}/{k}")
        return out
    if isinstance(a, list) and isinstance(b, list) and len(a) == len(b):
        return [d for x, y, i in zip(a, b, range(len(a))) for d in diff(x, y, f"{path}[{i}]")]
    return [] if a == b or close(a, b, path) else [f"{path}: {a!r} -> {b!r}"]


def main():
    global REL
    before, after = map(pathlib.Path, sys.argv[1:3])
    if len(sys.argv) > 3:
        REL = float(sys.argv[3])
    files = sorted(p.relative_to(before) for p in before.rglob("*.json"))
    if not files:
        sys.exit(f"{before}: no JSON file")
    bad = fits = 0
    for f in files:
        if not (after / f).exists():
            print(f"{f}: missing after")
            bad += 1
            continue
        a = strip(json.loads((before / f).read_text()))
        fits += len(a) if isinstance(a, list) else 1
        b = strip(json.loads((after / f).read_text()))
        d = diff(a, b)
        if d:
            bad += 1
            print(f"{f}: {len(d)} differences, first: " + "; ".join(d[:3]))
    for k, d in sorted(WORST.items()):
        if d > 0:
            print(f"largest relative difference of `{k}`: {d:.3g}")
    within = f" and within {REL:g} relative" if REL is not None else ""
    print(f"{len(files) - bad} of {len(files)} files ({fits} fits) equal apart from timings{within}")
    sys.exit(1 if bad else 0)


if __name__ == "__main__":
    main()
