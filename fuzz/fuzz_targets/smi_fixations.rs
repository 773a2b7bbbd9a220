#![no_main]
//! Any bytes through detection, the default detector and stimulus segmentation: no panic,
//! and messages change a fixation's stimulus and fate, never which fixations there are.
use libfuzzer_sys::fuzz_target;
use meshgaze::gaze::fixations::{fixations, DetectorParams, EyePolicy};
use meshgaze::gaze::ingest::default_detector;
use meshgaze::gaze::parse_recording;
use meshgaze::gaze::stimulus_messages::{classify_message, Segmentation};

fuzz_target!(|data: &[u8]| {
    for line in String::from_utf8_lossy(data).lines().take(50) {
        if let (_, Some(name)) = classify_message(line, None) {
            assert!(!name.is_empty() && line.contains(name.as_str()));
        }
    }
    let Ok(rec) = parse_recording(data, "fuzz", None) else {
        return;
    };
    let detector = default_detector(&rec);
    let p = DetectorParams::default();
    let segmented = Segmentation {
        pattern: None,
        max_duration_us: Some(48_000_000),
    };
    let a = fixations(&rec, "s", detector, EyePolicy::Best, &p, &segmented);
    let mut bare = rec.clone();
    bare.messages.clear();
    let b = fixations(&bare, "s", detector, EyePolicy::Best, &p, &Segmentation::default());
    if let (Ok(a), Ok(b)) = (a, b) {
        assert_eq!(a.len(), b.len());
        for (x, y) in a.iter().zip(&b) {
            assert_eq!((x.start_us, x.end_us), (y.start_us, y.end_us));
        }
    }
});
