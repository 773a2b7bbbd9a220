#![no_main]
use libfuzzer_sys::fuzz_target;
use meshgaze::gaze::{parse_recording, GazeFormat};

fuzz_target!(|data: &[u8]| {
    if let Ok(r) = parse_recording(data, "fuzz", Some(GazeFormat::IviewLegacy)) {
        // Every line is accounted for; one sample per sample line, one eye each.
        assert_eq!(r.rows.accounted(), r.rows.lines);
        assert_eq!(r.samples.len(), r.rows.samples);
        assert!(r.samples.iter().all(|s| s.left.is_some() && s.right.is_none()));
    }
});
