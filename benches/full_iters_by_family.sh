#!/usr/bin/env bash
# `--full-iters 0` (the warm-up optimum evaluated on all cells; what `--full-iters auto`,
# the command line's default, does for every family but Ward-Dür) against `--full-iters
# all` (LM to convergence on all cells after the warm-up), per model family and vendored
# measured table: the relative excess of the shortcut's full-table cbrt loss, and both
# whole-process wall times. docs/fitting.md, "`--full-iters 0` by family". Needs
# `cargo build --release -p fit-brdf`; writes its tables and fits into a temporary
# directory. Optional arguments: the models to run, names or model JSON files (default:
# every family below, Ward with each of its three normalisations).
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
fb="$root/target/release/fit-brdf"
tmp="$(mktemp -d)"
trap 'rm -rf "$tmp"' EXIT
for norm in duer ward; do
    echo "{\"model\":\"ward\",\"params\":{\"normalization\":\"$norm\"}}" > "$tmp/ward-$norm.json"
done
models=("$@")
[ ${#models[@]} -gt 0 ] || models=(ward "$tmp/ward-duer.json" "$tmp/ward-ward.json" plausible-phong
    blinn-phong lafortune ashikhmin-shirley cook-torrance cook-torrance-beckmann cook-torrance-2 lafortune-2)
now() { date +%s.%N; }
echo "table model loss(0) loss(all) excess time(0) time(all)"
for stem in merl/chrome-steel merl/gold-paint merl/pink-fabric merl/blue-rubber \
    merl/specular-red-phenolic nielsen/bindercover rgl-isotropic/acrylic_felt_green_rgb; do
    n="$(basename "$stem")"
    "$fb" resample --nbrdf "$root/data-measured/$stem" --dims 90,90,180 --out "$tmp/$n.binary" >/dev/null 2>&1
    for m in "${models[@]}"; do
        t0=$(now)
        "$fb" fit "$tmp/$n.binary" --model "$m" --full-iters 0 --quiet --out "$tmp/o.json" --record "$tmp/a.json" >/dev/null
        t1=$(now)
        "$fb" fit "$tmp/$n.binary" --model "$m" --full-iters all --quiet --out "$tmp/o.json" --record "$tmp/b.json" >/dev/null
        t2=$(now)
        python3 - "$n" "$(basename "$m" .json)" "$tmp/a.json" "$tmp/b.json" "$t0" "$t1" "$t2" <<'PY'
import json, sys
a, b = (json.load(open(f))["losses_full"]["cbrt"]["overall"] for f in sys.argv[3:5])
t0, t1, t2 = map(float, sys.argv[5:8])
print(f"{sys.argv[1]} {sys.argv[2]} {a:.5e} {b:.5e} {100 * (a / b - 1):+.3f} % {t1 - t0:.2f} s {t2 - t1:.2f} s")
PY
    done
done
