//! Paths of the test data: everything inside the repository (CI may not have
//! `../shared`).
#![allow(dead_code)]

use std::path::PathBuf;

/// `data-measured/` at the repository root.
pub fn data() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../data-measured")
}

/// `data-measured/<database>/<name>` (the stem of the six files).
pub fn material(database: &str, name: &str) -> PathBuf {
    data().join(database).join(name)
}

/// The seven proxies in `data-measured/`, (database, name).
pub const ALL: [(&str, &str); 7] = [
    ("merl", "chrome-steel"),
    ("merl", "gold-paint"),
    ("merl", "specular-red-phenolic"),
    ("merl", "pink-fabric"),
    ("merl", "blue-rubber"),
    ("rgl-isotropic", "acrylic_felt_green_rgb"),
    ("nielsen", "bindercover"),
];
