"""The table of docs/measured.md's glTF section from `fit --for gltf --json` outputs.

Usage: python3 docs/measured/gltf_table.py DIR   (DIR/NAME.json, as gltf_fits.sh writes)
"""
import csv
import json
import pathlib
import statistics
import sys

d = pathlib.Path(sys.argv[1])
cats = {r[0]: r[2] for r in csv.reader(open("data-measured/categories.csv")) if len(r) > 2}
cols = ["gltf-pbr", "gltf-sheen", "gltf-clearcoat", "gltf-specular",
        "gltf-sheen-specular", "gltf-clearcoat-specular"]
short = {"gltf-pbr": "core", "gltf-sheen": "sheen", "gltf-clearcoat": "clearcoat",
         "gltf-specular": "specular", "gltf-sheen-specular": "sheen+specular",
         "gltf-clearcoat-specular": "clearcoat+specular"}
order = {"fabric": 0, "paint": 1, "plastic": 2, "metal": 3}
rows, gains = [], {}
for f in sorted(d.glob("*.json")):
    j = json.load(open(f))
    name = f.stem
    cat = cats.get(name, "?")
    loss = {o["label"]: o["record"]["losses_full"]["cbrt"]["overall"] for o in j["outcomes"]}
    core = loss["gltf-pbr"]
    cells = [f"{core:.3e}"]
    for c in cols[1:]:
        g = 100 * (1 - loss[c] / core)
        gains.setdefault((cat, c), []).append(g)
        cells.append(f"{loss[c]:.3e} ({g:.1f} %)")
    rows.append((order.get(cat, 9), cat, name, cells, short[j["best"]]))
print("| category | material | core | " + " | ".join("+ " + short[c] for c in cols[1:]) + " | picked |")
print("|" + "---|" * (len(cols) + 3))
for _, cat, name, cells, best in sorted(rows):
    print(f"| {cat} | {name} | " + " | ".join(cells) + f" | {best} |")
print()
print("| category | n | " + " | ".join("+ " + short[c] for c in cols[1:]) + " | picked |")
print("|" + "---|" * (len(cols) + 2))
for cat in sorted({r[1] for r in rows}, key=lambda c: order.get(c, 9)):
    picks = [r[4] for r in rows if r[1] == cat]
    tally = ", ".join(f"{p} {picks.count(p)}" for p in sorted(set(picks), key=lambda p: -picks.count(p)))
    med = [f"{statistics.median(gains[(cat, c)]):.1f} %" for c in cols[1:]]
    print(f"| {cat} | {len(picks)} | " + " | ".join(med) + f" | {tally} |")
print()
for _, cat, name, _, _ in sorted(rows):
    print(f"- {name}: {json.load(open(d / (name + '.json')))['why']}")
