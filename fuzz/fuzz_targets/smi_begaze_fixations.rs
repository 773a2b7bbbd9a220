#![no_main]
use libfuzzer_sys::fuzz_target;
use meshgaze::gaze::{parse_recording, GazeFormat};

fuzz_target!(|data: &[u8]| {
    if let Ok(r) = parse_recording(data, "fuzz", Some(GazeFormat::BeGazeFixations)) {
        // Every line is accounted for, and every fixation has a non-negative length.
        assert_eq!(r.rows.accounted(), r.rows.lines);
        assert_eq!(r.events.len(), r.rows.events);
        assert!(r.events.iter().all(|e| e.duration_us >= 0 && e.end_us >= e.start_us));
    }
});
