//! The JSON examples in `docs/models.md`: one per model of the registry
//! ([`MODEL_NAMES`], in its order), each in the section named after its model, builds,
//! names that model and round-trips through `to_json`.

use brdfkit_models::{MODEL_NAMES, from_json, from_json_str};

#[test]
fn every_model_has_one_doc_example_that_builds() {
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
        let json = rest
            .strip_suffix('`')
            .expect("an example ends with a backtick");
        let m = from_json_str(json).unwrap_or_else(|e| panic!("{section}: {e}\n{json}"));
        assert_eq!(m.name(), section);
        let back = from_json(&m.to_json()).unwrap();
        assert_eq!(back.params(), m.params(), "{section}");
        seen.push(section);
    }
    assert_eq!(seen, MODEL_NAMES, "every model has one example");
}
