//! The MERL table reader on arbitrary bytes: never panics; whatever it accepts holds
//! only finite values and writes back bit for bit.
#![no_main]
use brdfkit::merl::MerlTable;
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    if let Ok(t) = MerlTable::from_bytes(data, "fuzz.binary") {
        assert!(t.raw().iter().all(|v| v.is_finite()));
        assert!(t.to_bytes() == data, "accepted input does not round-trip");
    }
});
