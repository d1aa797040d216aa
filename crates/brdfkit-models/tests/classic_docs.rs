//! The JSON examples of the classic models in `docs/models.md` build, round-trip, and
//! name the model of their section.

use brdfkit_models::from_json_str;

const CLASSIC: [&str; 6] = [
    "oren-nayar",
    "phong",
    "plausible-phong",
    "blinn-phong",
    "lafortune",
    "sum",
];

#[test]
fn doc_examples_build() {
    let doc = include_str!("../../../docs/models.md");
    let mut section = "";
    let mut seen = Vec::new();
    for line in doc.lines() {
        if let Some(s) = line.strip_prefix("## ") {
            section = s.trim();
        }
        let Some(rest) = line.strip_prefix("Example: `") else {
            continue;
        };
        if !CLASSIC.contains(&section) {
            continue;
        }
        let json = rest
            .strip_suffix('`')
            .expect("an example ends with a backtick");
        let m = from_json_str(json).unwrap_or_else(|e| panic!("{section}: {e}\n{json}"));
        assert_eq!(m.name(), section);
        let back = brdfkit_models::from_json(&m.to_json()).unwrap();
        assert_eq!(back.params(), m.params(), "{section}");
        seen.push(section);
    }
    assert_eq!(seen, CLASSIC, "every classic model has one example");
}
