#![no_main]
use libfuzzer_sys::fuzz_target;
use meshgaze::gaze::parse_recording;

fuzz_target!(|data: &[u8]| {
    if let Ok(r) = parse_recording(data, "fuzz", None) {
        assert_eq!(r.rows.accounted(), r.rows.lines);
    }
});
