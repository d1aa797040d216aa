//! Sets `has_mitsuba` / `has_chromium` / `has_gltf_validator` / `has_browser_driver` /
//! `has_threejs` / `has_blender` when the export's Mitsuba check, the report's browser
//! checks, the glTF validator check and the engine checks (three.js, Blender) can run (see
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
        Tool::ThreeJs,
        Tool::Blender,
    ]);
}
