//! The synthetic-material spec parser on arbitrary text: never panics, and errors name
//! the file.
#![no_main]
use brdfkit::synth::SynthSpec;
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    if let Err(e) = SynthSpec::from_toml_str(text, "fuzz.toml") {
        assert!(e.to_string().starts_with("fuzz.toml: "));
    }
});
