//! Sets `has_mitsuba` when the Mitsuba cross-checks can run (see build/external_tools.rs).

#[path = "../../build/external_tools.rs"]
mod external_tools;

fn main() {
    external_tools::emit(&[external_tools::Tool::Mitsuba]);
}
