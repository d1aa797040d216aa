//! The styles of the report page and of the interactive panels, which each page that
//! shows the panels (the report, `fit-brdf view`) includes together.

/// The report page's style.
pub(crate) const PAGE_CSS: &str = r#"
body { font-family: system-ui, sans-serif; margin: 0 auto; max-width: 1320px; padding: 0 18px 40px; color: #222; }
h1 { margin-bottom: 4px; }
h2 { border-bottom: 2px solid #ddd; padding-bottom: 4px; margin-top: 36px; }
p.meta, p.note { color: #555; font-size: 14px; }
nav a { margin-right: 14px; font-size: 14px; }
table { border-collapse: collapse; font-size: 13px; margin: 8px 0; }
th, td { border: 1px solid #ddd; padding: 4px 8px; text-align: right; vertical-align: top; }
th { background: #f4f4f4; }
td.l, th.l { text-align: left; }
td.best { font-weight: bold; background: #eef7ee; }
.swatch { display: inline-block; width: 12px; height: 12px; border-radius: 2px; margin-right: 6px; vertical-align: -1px; }
.pass { color: #1a7f37; font-weight: bold; }
.fail { color: #c62828; font-weight: bold; }
.inconclusive { color: #b26a00; font-weight: bold; }
.row { display: flex; flex-wrap: wrap; gap: 8px; align-items: flex-start; }
.row svg { max-width: 100%; height: auto; }
.card { border: 1px solid #ddd; border-radius: 4px; padding: 6px; font-size: 12px; text-align: center; }
.card img { width: 128px; height: 128px; image-rendering: pixelated; display: block; margin: 2px; }
.pair { display: flex; }
code.params { font-size: 12px; white-space: pre-wrap; text-align: left; display: block; max-width: 420px; }
details { margin: 6px 0; }
summary { cursor: pointer; font-weight: bold; }
#page-check { font-size: 12px; color: #888; }
"#;

/// The panels' style.
pub(crate) const PANELS_CSS: &str = r#"
.panel { border: 1px solid #ddd; border-radius: 4px; padding: 8px; margin: 10px 0; }
.panel h3 { margin: 2px 0 6px; }
.controls { display: flex; flex-wrap: wrap; gap: 14px; align-items: center; font-size: 13px; margin-bottom: 6px; }
.controls label { white-space: nowrap; }
.controls input[type=range] { width: 160px; vertical-align: middle; }
.panel canvas { border: 1px solid #eee; }
.readout { font-family: ui-monospace, monospace; font-size: 12px; color: #333; min-height: 1.3em; }
.legend span { margin-right: 12px; font-size: 12px; }
"#;
