//! The model JSON contract on arbitrary text: never panics; a model it accepts evaluates
//! to finite, non-negative values on a fixed set of direction pairs and round-trips
//! through its own JSON.
#![no_main]
use brdfkit::core::direction::spherical;
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    let Ok(m) = brdfkit::models::from_json_str(text) else {
        return;
    };
    for (ti, to, p) in [(0.0, 0.0, 0.0), (0.5, 0.5, 3.14159), (1.2, 0.3, 1.0), (1.5707, 1.5707, 0.0)] {
        let f = m.eval(&spherical(ti, 0.0), &spherical(to, p));
        assert!(f.is_finite() && f.min_channel() >= 0.0, "{text}: f = {f:?}");
    }
    let back = brdfkit::models::from_json(&m.to_json()).expect("a model's own JSON parses");
    assert_eq!(back.params(), m.params());
});
