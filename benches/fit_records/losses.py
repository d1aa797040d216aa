#!/usr/bin/env python3
"""Fit by fit, the optimised loss over all cells before and after a change that may
move results but must not lose accuracy.

Usage: benches/fit_records/losses.py BEFORE AFTER [REL [PARAM_REL]]

BEFORE and AFTER are JSON files or directories of them (the same relative paths):
`fit-brdf fit T --model a,b,c --json` outputs (as `benches/fit_records/run` writes) or
`fit-brdf batch --out DIR` directories. Every fit record found (a JSON object with
`losses_full`) is paired with the one at the same place in the other file.

A fit passes when, after the change, it is still `converged` and its full-table value
of the loss it optimised (`losses_full[loss].overall`) is at most REL (default 1e-4)
relative above the one before (lower is fine). Prints, per fit, the relative change of
that loss, of the largest free parameter (relative to max(|before|, 1e-3), so an
albedo near 0 compares absolutely) and the iterations by stage (`iterations_run`,
explore / warm-up / finish), then the totals; exits 1 when a fit fails or, with
PARAM_REL, when a parameter moved by more than PARAM_REL.
"""
import json
import pathlib
import sys


def records(v, path=""):
    """(place, record) of every fit record in a JSON value, in document order."""
    if isinstance(v, dict):
        if "losses_full" in v and "loss" in v:
            yield path, v
            return
        for k in v:
            yield from records(v[k], f"{path}/{k}")
    elif isinstance(v, list):
        for i, x in enumerate(v):
            yield from records(x, f"{path}[{i}]")


def files(root):
    root = pathlib.Path(root)
    if root.is_file():
        return {pathlib.Path(root.name): root}
    return {p.relative_to(root): p for p in sorted(root.rglob("*.json"))}


def loss_of(r):
    return r["losses_full"][r["loss"]]["overall"]


def param_change(a, b):
    pa = {p["name"]: p["value"] for p in a["params"] if p.get("free")}
    pb = {p["name"]: p["value"] for p in b["params"] if p.get("free")}
    worst, name = 0.0, ""
    for k in pa:
        d = abs(pb.get(k, float("nan")) - pa[k]) / max(abs(pa[k]), 1e-3)
        if not d <= worst:
            worst, name = d, k
    return worst, name


def iters(r):
    it = r.get("iterations_run", {})
    return [it.get(s, 0) for s in ("explore", "warm_up", "finish")]


def main():
    before, after = sys.argv[1:3]
    rel = float(sys.argv[3]) if len(sys.argv) > 3 else 1e-4
    prel = float(sys.argv[4]) if len(sys.argv) > 4 else None
    fb, fa = files(before), files(after)
    bad, n, lower, tot_b, tot_a = 0, 0, 0, [0, 0, 0], [0, 0, 0]
    worst_up, worst_p = 0.0, (0.0, "")
    for f, pb in fb.items():
        if f not in fa:
            print(f"{f}: missing after")
            bad += 1
            continue
        rb = list(records(json.loads(pb.read_text())))
        ra = dict(records(json.loads(fa[f].read_text())))
        for place, b in rb:
            a = ra.get(place)
            n += 1
            name = f"{f}{place} {b.get('family', '')}"
            if a is None:
                print(f"{name}: missing after")
                bad += 1
                continue
            lb, la = loss_of(b), loss_of(a)
            d = (la - lb) / lb if lb > 0 else la - lb
            p, pn = param_change(b, a)
            ib, ia = iters(b), iters(a)
            tot_b = [x + y for x, y in zip(tot_b, ib)]
            tot_a = [x + y for x, y in zip(tot_a, ia)]
            ok = a.get("converged") and d <= rel
            lower += d < 0
            worst_up = max(worst_up, d)
            if p > worst_p[0]:
                worst_p = (p, f"{name} {pn}")
            bad += not ok or (prel is not None and p > prel)
            flag = "" if ok else "  FAIL"
            print(f"{name:60s} loss {d:+.2e} param {p:.1e} ({pn}) "
                  f"iters {'/'.join(map(str, ib))} -> {'/'.join(map(str, ia))}"
                  f" converged {a.get('converged')}{flag}")
    print(f"{n} fits, {bad} failing; {lower} lower; largest loss increase {worst_up:+.2e} "
          f"(bound {rel:g}); largest parameter change {worst_p[0]:.2e} ({worst_p[1]})")
    print(f"iterations explore/warm-up/finish: before {'/'.join(map(str, tot_b))}, "
          f"after {'/'.join(map(str, tot_a))}")
    sys.exit(1 if bad else 0)


if __name__ == "__main__":
    main()
