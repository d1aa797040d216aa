//! Sets `has_mitsuba` / `has_chromium` / `has_gltf_validator` / `has_browser_driver`
//! when the export's Mitsuba check, the report's browser checks and the glTF validator
//! check can run (see
//! build/external_tools.rs).

#[path = "../../build/external_tools.rs"]
mod external_tools;

fn main() {
    use external_tools::Tool;
    external_tools::emit(&[
        Tool::Mitsuba,
        Tool::Chromium,
        Tool::GltfValidator,
        Tool::BrowserDriver,
    ]);
}
