//! The report as a person sees it: opened from disk in headless Chromium, screenshot
//! taken and checked not blank, and the page's own check (every <img> decoded, the
//! summary table filled) read back from the rendered DOM.
//!
//! Needs Debian's `chromium` (`apt-get install chromium`). Without it the test is
//! ignored, with the reason (probed by build.rs, see build/external_tools.rs); with `CI`
//! set, a missing browser is a failure.

mod common;
#[path = "../../../build/external_tools.rs"]
#[macro_use]
mod external_tools;

use common::{bin, small_plastic_spec, synth_spec};
use std::path::Path;
use std::process::Output;

/// Headless Chromium with a fresh profile and no network chatter.
fn chromium(exe: &Path, profile: &Path, extra: &[&str], url: &str) -> Output {
    std::process::Command::new(exe)
        .args([
            "--headless",
            "--no-sandbox",
            "--disable-gpu",
            "--disable-quic",
            "--no-first-run",
            "--disable-background-networking",
            "--disable-component-update",
            "--disable-sync",
            "--hide-scrollbars",
            // Virtual time lets the page's load handler run before the dump.
            "--virtual-time-budget=10000",
        ])
        .arg(format!("--user-data-dir={}", profile.display()))
        .args(extra)
        .arg(url)
        .output()
        .expect("chromium starts")
}

fn attr<'a>(tag: &'a str, name: &str) -> Option<&'a str> {
    let key = format!("{name}=\"");
    let start = tag.find(&key)? + key.len();
    let end = tag[start..].find('"')? + start;
    Some(&tag[start..end])
}

chromium_test! {
    fn the_report_renders_in_a_browser_with_every_image() {
        let exe = external_tools::require_chromium();
        let d = tempfile::tempdir().unwrap();
        let spec = small_plastic_spec("browser-plastic", [0.45, 0.08, 0.05], 0.12);
        let table = synth_spec(d.path(), "t", &spec);
        let out = d.path().join("report");
        bin()
            .arg("report")
            .arg(&table)
            .args(["--models", "lambert,ward,cook-torrance", "--starts", "1"])
            .args(["--render-size", "48", "--env-spp", "4", "--quiet", "--out"])
            .arg(&out)
            .assert()
            .success();
        let url = format!("file://{}", out.join("index.html").display());

        // The DOM after the page's load handler ran.
        let o = chromium(&exe, &d.path().join("profile-dom"), &["--dump-dom"], &url);
        let dom = String::from_utf8_lossy(&o.stdout);
        assert!(
            o.status.success() && dom.contains("</html>"),
            "chromium --dump-dom failed: {}\n{}",
            o.status,
            String::from_utf8_lossy(&o.stderr)
        );
        let start = dom
            .find("<p id=\"page-check\"")
            .expect("the page check is in the DOM");
        let tag = &dom[start..start + dom[start..].find('>').unwrap()];
        assert_eq!(attr(tag, "data-status"), Some("ok"), "{tag}");
        // 2 lightings × (table + 3 × (fit, difference)).
        assert_eq!(attr(tag, "data-images"), Some("14"), "{tag}");
        assert_eq!(attr(tag, "data-broken"), Some("0"), "{tag}");
        assert_eq!(attr(tag, "data-summary-rows"), Some("3"), "{tag}");
        let svgs: usize = attr(tag, "data-svgs").unwrap().parse().unwrap();
        assert!(svgs >= 12 + 3 + 1 + 3, "{tag}");
        assert!(dom.contains("id=\"summary-table\""));

        // A screenshot: a real picture, not a blank page.
        let shot = d.path().join("shot.png");
        let o = chromium(
            &exe,
            &d.path().join("profile-shot"),
            &[
                "--window-size=1280,2000",
                &format!("--screenshot={}", shot.display()),
            ],
            &url,
        );
        assert!(
            o.status.success() && shot.is_file(),
            "chromium --screenshot failed: {}",
            String::from_utf8_lossy(&o.stderr)
        );
        let img = image::open(&shot)
            .expect("the screenshot is a PNG")
            .to_rgb8();
        assert_eq!(img.dimensions(), (1280, 2000));
        let mut colours = std::collections::HashSet::new();
        let mut non_white = 0usize;
        for p in img.pixels() {
            colours.insert(p.0);
            if p.0.iter().any(|&c| c < 240) {
                non_white += 1;
            }
        }
        let n = (img.width() * img.height()) as usize;
        // Text, tables, charts and colour: hundreds of colours and a good share of ink.
        assert!(colours.len() > 200, "{} colours", colours.len());
        assert!(
            non_white * 20 > n,
            "{non_white} of {n} pixels are not white"
        );
    }
}
