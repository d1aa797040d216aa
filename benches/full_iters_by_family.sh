#!/usr/bin/env bash
# `--full-iters 0` (the command line's default) against `--full-iters all` (LM to
# convergence on all cells after the warm-up), per model family and vendored measured
# table: the relative excess of the default's full-table cbrt loss. docs/fitting.md,
# "`--full-iters 0` by family". Needs `cargo build --release -p fit-brdf`; writes its
# tables and fits into a temporary directory.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
fb="$root/target/release/fit-brdf"
tmp="$(mktemp -d)"
trap 'rm -rf "$tmp"' EXIT
echo '{"model":"ward","params":{"normalization":"duer"}}' > "$tmp/ward-duer.json"
for stem in merl/chrome-steel merl/gold-paint merl/pink-fabric merl/blue-rubber \
    merl/specular-red-phenolic nielsen/bindercover rgl-isotropic/acrylic_felt_green_rgb; do
    n="$(basename "$stem")"
    "$fb" resample --nbrdf "$root/data-measured/$stem" --dims 90,90,180 --out "$tmp/$n.binary" >/dev/null
    for m in ward "$tmp/ward-duer.json" plausible-phong blinn-phong lafortune ashikhmin-shirley \
        cook-torrance cook-torrance-beckmann cook-torrance-2 lafortune-2; do
        "$fb" fit "$tmp/$n.binary" --model "$m" --quiet --out "$tmp/o.json" --record "$tmp/a.json" >/dev/null
        "$fb" fit "$tmp/$n.binary" --model "$m" --full-iters all --quiet --out "$tmp/o.json" --record "$tmp/b.json" >/dev/null
        python3 - "$n" "$(basename "$m" .json)" "$tmp/a.json" "$tmp/b.json" <<'PY'
import json, sys
a, b = (json.load(open(f))["losses_full"]["cbrt"]["overall"] for f in sys.argv[3:5])
print(f"{sys.argv[1]} {sys.argv[2]} {a:.5e} {b:.5e} {100 * (a / b - 1):+.3f} %")
PY
    done
done
