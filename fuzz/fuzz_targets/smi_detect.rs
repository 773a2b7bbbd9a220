#![no_main]
use libfuzzer_sys::fuzz_target;
use meshgaze::gaze::parse_smi;

fuzz_target!(|data: &[u8]| {
    if let Ok(r) = parse_smi(data, "fuzz", None) {
        assert_eq!(r.rows.accounted(), r.rows.lines);
    }
});
