#![no_main]
use libfuzzer_sys::fuzz_target;
use meshgaze::gaze::{parse_recording, EventKind, GazeFormat};

fuzz_target!(|data: &[u8]| {
    if let Ok(r) = parse_recording(data, "fuzz", Some(GazeFormat::EyelinkAsc)) {
        // Every line is accounted for; one sample per sample line, one event per E… line.
        assert_eq!(r.rows.accounted(), r.rows.lines);
        assert_eq!(r.samples.len(), r.rows.samples);
        assert!(r.events.len() <= r.rows.events);
        // A valid eye sample has a position; events never end before they start.
        for s in &r.samples {
            for e in [s.left, s.right].into_iter().flatten() {
                assert!(!e.valid || (e.x.is_finite() && e.y.is_finite()));
            }
        }
        assert!(r.events.iter().all(|e| e.end_us >= e.start_us));
        assert!(r
            .events
            .iter()
            .all(|e| e.kind != EventKind::Fixation || e.duration_us >= 0));
    }
});
