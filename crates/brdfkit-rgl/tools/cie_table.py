# Regenerates crates/brdfkit-rgl/src/cie_table.rs from Mitsuba 3 (scalar_spectral):
#   .venv/bin/python crates/brdfkit-rgl/tools/cie_table.py > crates/brdfkit-rgl/src/cie_table.rs
import mitsuba as mi

mi.set_variant('scalar_spectral')
d65 = mi.load_dict({'type': 'd65'})
si = mi.SurfaceInteraction3f()
print("//! CIE 1931 2° colour matching functions x̄, ȳ, z̄ and the CIE D65 illuminant (relative\n"
      "//! power, scaled as Mitsuba 3 scales it), at every nanometre from 360 to 830 nm.\n//!\n"
      "//! Generated from Mitsuba 3.9.1 (`mitsuba.cie1931_xyz`, the `d65` spectrum plugin in\n"
      "//! `scalar_spectral`), which tabulate the CIE's published data; regenerate with the\n"
      "//! script in docs/rgl.md.\n\n/// First wavelength of [`CIE_1931_D65`], nm (step 1 nm).\n"
      "pub const FIRST_NM: f64 = 360.0;\n\n/// Rows (x̄, ȳ, z̄, D65) at 360, 361, …, 830 nm.\n"
      "#[rustfmt::skip]\npub const CIE_1931_D65: [[f64; 4]; 471] = [")
for l in range(360, 831):
    x = mi.cie1931_xyz(float(l))
    si.wavelengths = mi.Spectrum([l, l, l, l])
    print("    [%r, %r, %r, %r]," % (float(x[0]), float(x[1]), float(x[2]), float(d65.eval(si)[0])))
print("];")
