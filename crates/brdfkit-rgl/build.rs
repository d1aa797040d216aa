//! Sets `has_mitsuba` when the Mitsuba cross-checks can run, and `has_brdfkit_python`
//! when the brdfkit Python package is there too (the render test of
//! tests/write_mitsuba.rs); see build/external_tools.rs.

#[path = "../../build/external_tools.rs"]
mod external_tools;

fn main() {
    external_tools::emit(&[
        external_tools::Tool::Mitsuba,
        external_tools::Tool::PythonPackage,
    ]);
}
