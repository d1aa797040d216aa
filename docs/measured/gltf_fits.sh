#!/bin/sh
# `fit --for gltf` on the fabric, paint, plastic and metal proxies of docs/measured.md's
# glTF section: resamples each proxy to the MERL grid, fits, keeps the --json output,
# then prints the section's table (docs/measured/gltf_table.py).
# Usage (from the repository root, after `cargo build --release -p fit-brdf`):
#   sh docs/measured/gltf_fits.sh [OUTDIR]      (default target/gltf-fits)
set -eu
B=target/release/fit-brdf
P=../shared/measured-proxies
OUT=${1:-target/gltf-fits}
mkdir -p "$OUT"
MERL="red-fabric blue-fabric pink-felt white-fabric2 dark-specular-fabric
blue-metallic-paint2 gold-metallic-paint2 red-metallic-paint dark-red-paint
red-plastic green-plastic specular-white-phenolic brass chrome-steel aluminium"
RGL="acrylic_felt_green_rgb acrylic_felt_orange_rgb acrylic_felt_pink_rgb
acrylic_felt_purple_rgb acrylic_felt_white_rgb acrylic_felt_yellow_rgb satin_blue_rgb
satin_gold_rgb satin_purple_rgb satin_rosaline_rgb satin_white_rgb cc_amber_citrine_rgb
cc_blue_agat_rgb cc_green_malachite_rgb cc_ibiza_sunset_rgb cc_iris_purple_gem_rgb
cc_nothern_aurora_rgb"
one() {
  [ -s "$OUT/$2.json" ] && return 0
  [ -s "$OUT/$2.binary" ] || $B resample --nbrdf "$P/$1/$2" --dims 90,90,180 --out "$OUT/$2.binary" -q
  s=$(date +%s.%N)
  $B fit "$OUT/$2.binary" --for gltf --json -q > "$OUT/$2.json.tmp"
  echo "$2 $(echo "$(date +%s.%N) - $s" | bc)" >> "$OUT/times.txt"
  mv "$OUT/$2.json.tmp" "$OUT/$2.json"
}
for n in $MERL; do one merl "$n"; done
for n in $RGL; do one rgl-isotropic "$n"; done
python3 docs/measured/gltf_table.py "$OUT"
