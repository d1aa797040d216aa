//! Sets `has_brdfkit_python` when the Python package's pytest suite can run (see
//! build/external_tools.rs).

#[path = "../../build/external_tools.rs"]
mod external_tools;

fn main() {
    external_tools::emit(&[external_tools::Tool::PythonPackage]);
}
