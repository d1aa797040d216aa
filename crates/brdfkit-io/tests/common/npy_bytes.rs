//! A NumPy `.npy` file built by hand (format version 1.0), for tests of readers that
//! must not trust a library to write what they read; shared by the unit tests of
//! `brdfkit-io/src/npy.rs` and fit-brdf's `tests/measured_io.rs`.

/// The bytes of a version 1.0 `.npy` file: magic, header length, the header dict with
/// `descr` and `shape` given as Python text, padded with spaces and a newline to a
/// multiple of 64 bytes, then `body` as is.
pub fn npy_bytes(descr: &str, shape: &str, body: &[u8]) -> Vec<u8> {
    let mut h = format!("{{'descr': '{descr}', 'fortran_order': False, 'shape': {shape}, }}");
    while (10 + h.len() + 1) % 64 != 0 {
        h.push(' ');
    }
    h.push('\n');
    let mut v = b"\x93NUMPY\x01\x00".to_vec();
    v.extend_from_slice(&(h.len() as u16).to_le_bytes());
    v.extend_from_slice(h.as_bytes());
    v.extend_from_slice(body);
    v
}
