"""The Python package's benchmark targets (docs/python.md, "Performance").

    .venv/bin/python crates/brdfkit-python/bench/bench_python.py [FIT_BRDF]

1. `table.lookup` on 1,458,000 pairs against the library call alone in the same
   process (`_brdfkit._lookup_seconds`: the same lookup timed inside Rust, without the
   argument conversion and the output array): the binding's overhead.
2. `brdfkit.fit` against `fit-brdf fit` (FIT_BRDF, default target/release/fit-brdf) on
   the same table, both reading the table and fitting cook-torrance with the defaults.
3. Mitsuba `llvm_ad_rgb`, a 256² sphere at 64 spp, `brdfkit_merl` against
   `roughconductor` in the same scene (needs DRJIT_LIBLLVM_PATH, docs/python.md).

Medians of repeated runs; the machine's load is printed with them.
"""

from __future__ import annotations

import os
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

import brdfkit
from brdfkit import _brdfkit

from timing import median_time, unit_pairs  # noqa: E402 (beside this script)

ROOT = Path(__file__).resolve().parents[3]




def main():
    fit_brdf = sys.argv[1] if len(sys.argv) > 1 else str(ROOT / "target/release/fit-brdf")
    print("load:", os.getloadavg())
    tmp = Path(tempfile.mkdtemp())
    table_path = tmp / "gold-paint.binary"
    nb = brdfkit.Nbrdf.load(ROOT / "data-measured/merl/gold-paint")
    brdfkit.resample(nb, (90, 90, 180)).write(table_path)
    table = brdfkit.MerlTable.read(table_path)

    wi, wo = unit_pairs(1_458_000)
    for interp in ("nearest", "linear"):
        py = median_time(lambda: table.lookup(wi, wo, interp), 15)
        rs = statistics.median(_brdfkit._lookup_seconds(table, wi, wo, interp) for _ in range(15))
        print(f"lookup {interp}, 1,458,000 pairs: Python {py * 1e3:.1f} ms, "
              f"Rust call {rs * 1e3:.1f} ms, ratio {py / rs:.3f}")

    if Path(fit_brdf).exists():
        def cli():
            subprocess.run([fit_brdf, "fit", str(table_path), "--model", "cook-torrance", "--quiet"],
                           check=True, stdout=subprocess.DEVNULL)

        def python():
            brdfkit.fit(brdfkit.MerlTable.read(table_path), "cook-torrance")

        cli()
        python()
        c = median_time(cli, 7)
        p = median_time(python, 7)
        print(f"fit cook-torrance (read + fit): fit-brdf {c:.3f} s, Python {p:.3f} s, ratio {p / c:.3f}")
    else:
        print(f"no {fit_brdf}: cargo build --release -p fit-brdf (fit comparison skipped)")

    if os.environ.get("DRJIT_LIBLLVM_PATH"):
        import mitsuba as mi

        mi.set_variant("llvm_ad_rgb")
        from brdfkit import mitsuba as plugin

        plugin.register()

        def scene(bsdf):
            return mi.load_dict({
                "type": "scene",
                "integrator": {"type": "path", "max_depth": 2},
                "sensor": {"type": "perspective", "fov": 35,
                           "to_world": mi.ScalarTransform4f().look_at(origin=[0, 0.6, 4.5], target=[0, 0, 0], up=[0, 1, 0]),
                           "film": {"type": "hdrfilm", "width": 256, "height": 256},
                           "sampler": {"type": "independent", "sample_count": 64}},
                "sphere": {"type": "sphere", "bsdf": bsdf},
                "light": {"type": "point", "position": [3, 3, 3], "intensity": {"type": "rgb", "value": 30}},
                "sky": {"type": "constant", "radiance": {"type": "rgb", "value": 0.2}},
            })

        for name, bsdf in [
            ("brdfkit_merl", {"type": "brdfkit_merl", "filename": str(table_path)}),
            ("roughconductor", {"type": "roughconductor", "material": "Au", "alpha": 0.2}),
        ]:
            sc = scene(bsdf)
            mi.render(sc, seed=0)  # compile the kernels (cached afterwards)
            t = median_time(lambda: np.asarray(mi.render(sc, seed=1)), 5)
            print(f"Mitsuba llvm_ad_rgb 256x256 64 spp, {name}: {t:.3f} s")
    print("load:", os.getloadavg())


if __name__ == "__main__":
    main()
