#![no_main]
//! Gazepoint Analysis exports: never a panic, every line accounted for, events that never end before they start.
use libfuzzer_sys::fuzz_target;
#[allow(unused_imports)]
use meshgaze::gaze::{parse_recording, GazeFormat};

fuzz_target!(|data: &[u8]| {
    if let Ok(r) = parse_recording(data, "fuzz", Some(GazeFormat::Gazepoint)) {
        assert_eq!(r.rows.accounted(), r.rows.lines);
        assert_eq!(r.samples.len(), r.rows.samples);
        assert!(r.events.iter().all(|e| e.end_us >= e.start_us));
        for s in &r.samples {
            for e in [s.left, s.right, s.binocular].into_iter().flatten() {
                assert!(!e.valid || (e.x.is_finite() && e.y.is_finite()));
            }
        }
    }
});
