//! Sets `has_mitsuba` / `has_chromium` when the export's Mitsuba check and the report's
//! browser check can run (see build/external_tools.rs).

#[path = "../../build/external_tools.rs"]
mod external_tools;

fn main() {
    use external_tools::Tool;
    external_tools::emit(&[Tool::Mitsuba, Tool::Chromium]);
}
