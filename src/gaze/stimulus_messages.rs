//! Which messages of a recording start a stimulus. Real recordings carry whatever the
//! experiment program logged: stimulus file names (often behind a Windows path, inside a
//! sentence), status text, clock stamps, Experiment Center user events, text the exporter cut
//! off. A message starts a stimulus only when it names a stimulus file (an image or video
//! extension) or matches the user's pattern; every other message is classified and kept, and
//! does not end the running stimulus.
use std::collections::BTreeMap;

use regex::Regex;
use serde::Serialize;

use super::recording::{Message, Recording};

/// File extensions that make a message name a stimulus.
pub const STIMULUS_EXTENSIONS: [&str; 22] = [
    "png", "jpg", "jpeg", "bmp", "gif", "tif", "tiff", "webp", "tga", "avi", "mp4", "m4v", "mov",
    "mkv", "wmv", "mpg", "mpeg", "webm", "flv", "ogv", "3gp", "svg",
];

/// What a message is.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum MessageKind {
    /// Names a stimulus file (or matches the start pattern): a stimulus starts here.
    Stimulus,
    /// Matches the user's end pattern: the running stimulus ends here.
    StimulusEnd,
    /// An Experiment Center user event (`UE-mouseclick …`, `UE-keypress`).
    UserEvent,
    /// A clock stamp (`# UTC: 1489598928 791`, `12:01:33.250`).
    Clock,
    /// Text cut off by the exporter (an unclosed quote or bracket, or punctuation only).
    Truncated,
    /// Anything else the experiment program logged (`Starting wait for fixation period`).
    Status,
}

impl MessageKind {
    /// The name messages.csv writes.
    pub fn name(self) -> &'static str {
        match self {
            MessageKind::Stimulus => "stimulus",
            MessageKind::StimulusEnd => "stimulus-end",
            MessageKind::UserEvent => "user-event",
            MessageKind::Clock => "clock",
            MessageKind::Truncated => "truncated",
            MessageKind::Status => "status",
        }
    }
}

/// A user's rule for stimulus messages: `start` has one capture group, the stimulus name;
/// `end`, when given, marks where a stimulus ends.
#[derive(Debug, Clone)]
pub struct StimulusPattern {
    /// Messages that start a stimulus; the capture group is its name.
    pub start: Regex,
    /// Messages that end the running stimulus.
    pub end: Option<Regex>,
}

impl StimulusPattern {
    /// Compiles the patterns; the start pattern must have exactly one capture group.
    pub fn new(start: &str, end: Option<&str>) -> Result<StimulusPattern, super::GazeError> {
        use super::GazeError::Invalid;
        let start_re =
            Regex::new(start).map_err(|e| Invalid(format!("--stimulus-pattern `{start}`: {e}")))?;
        if start_re.captures_len() != 2 {
            return Err(Invalid(format!(
                "--stimulus-pattern `{start}` has {} capture groups; it needs exactly one, around the stimulus name, e.g. `start_trial \\d+ (.*)`",
                start_re.captures_len() - 1
            )));
        }
        let end = end
            .map(|e| {
                Regex::new(e).map_err(|err| Invalid(format!("--stimulus-end-pattern `{e}`: {err}")))
            })
            .transpose()?;
        Ok(StimulusPattern {
            start: start_re,
            end,
        })
    }
}

/// How a recording is cut into stimuli.
#[derive(Debug, Clone, Default)]
pub struct Segmentation {
    /// The user's pattern; None: messages naming an image or video file.
    pub pattern: Option<StimulusPattern>,
    /// A stimulus ends this long after its onset at the latest (the protocol's video length).
    pub max_duration_us: Option<i64>,
}

/// The kind of a message and, for a stimulus onset, the stimulus name (a file's base name).
pub fn classify_message(
    text: &str,
    pattern: Option<&StimulusPattern>,
) -> (MessageKind, Option<String>) {
    let t = text.trim();
    if let Some(p) = pattern {
        if let Some(c) = p.start.captures(t) {
            let name = c.get(1).map_or("", |m| m.as_str());
            let name = base_name(name.trim());
            if !name.is_empty() {
                return (MessageKind::Stimulus, Some(name.to_string()));
            }
        }
        if p.end.as_ref().is_some_and(|e| e.is_match(t)) {
            return (MessageKind::StimulusEnd, None);
        }
    }
    if t.starts_with("UE-") {
        return (MessageKind::UserEvent, None);
    }
    if is_clock(t) {
        return (MessageKind::Clock, None);
    }
    if pattern.is_none() {
        if let Some(name) = stimulus_file_name(t) {
            return (MessageKind::Stimulus, Some(name));
        }
    }
    if is_truncated(t) {
        return (MessageKind::Truncated, None);
    }
    (MessageKind::Status, None)
}

/// The text after the last `/` or `\`.
fn base_name(path: &str) -> &str {
    path.rsplit(['/', '\\']).next().unwrap_or(path)
}

fn has_stimulus_extension(word: &str) -> bool {
    let Some((stem, ext)) = word.rsplit_once('.') else {
        return false;
    };
    !stem.is_empty()
        && STIMULUS_EXTENSIONS
            .iter()
            .any(|e| ext.eq_ignore_ascii_case(e))
}

/// The stimulus file a message names: when the whole message (quotes stripped) is a file name
/// with a stimulus extension, that name, spaces and all, behind any path; otherwise the last
/// word that ends in such an extension, behind any path.
fn stimulus_file_name(text: &str) -> Option<String> {
    let unquoted = text.trim_matches(|c| c == '"' || c == '\'').trim();
    let whole = base_name(unquoted).trim();
    if has_stimulus_extension(whole) {
        let in_sentence = !unquoted.contains(['/', '\\'])
            && unquoted.split_whitespace().rev().skip(1).any(|w| {
                w.chars().all(|c| c.is_ascii_digit()) || w.contains('=') || w.contains(':')
            });
        if !in_sentence {
            return Some(whole.to_string());
        }
    }
    text.split_whitespace()
        .rev()
        .map(|w| w.trim_matches(|c: char| "\"'()[]{},;".contains(c)))
        .map(base_name)
        .find(|w| has_stimulus_extension(w))
        .map(str::to_string)
}

/// `# UTC: …`, `UTC: …`, or a bare time of day / number pair like `12:01:33.250`.
fn is_clock(t: &str) -> bool {
    let s = t.trim_start_matches('#').trim();
    let lower = s.to_ascii_lowercase();
    if ["utc:", "utc ", "time:", "clock:", "timestamp"]
        .iter()
        .any(|p| lower.starts_with(p))
    {
        return true;
    }
    // A time of day: digits with at least two colons and nothing else but . and spaces.
    s.matches(':').count() >= 2
        && s.chars()
            .all(|c| c.is_ascii_digit() || c == ':' || c == '.' || c == ' ')
}

/// Text the exporter cut off: an unclosed quote or bracket, or punctuation only.
fn is_truncated(t: &str) -> bool {
    if t.is_empty() || !t.chars().any(|c| c.is_alphanumeric()) {
        return true;
    }
    let count = |c: char| t.chars().filter(|&x| x == c).count();
    count('"') % 2 == 1
        || count('[') != count(']')
        || count('(') != count(')')
        || count('{') != count('}')
}

/// One stimulus presentation within a recording.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct StimulusSegment {
    /// The trial it is in.
    pub trial: u32,
    /// The stimulus's name, from its onset message.
    pub name: String,
    /// Onset, tracker clock in µs.
    pub onset_us: i64,
    /// Exclusive end: the next onset, an end message or onset + the longest duration;
    /// None: open to the end of the trial.
    pub end_us: Option<i64>,
    /// Why it ended: `next-onset`, `end-message`, `duration`, or `trial-end`.
    pub ended_by: &'static str,
}

/// A message with its kind, as the messages table lists it.
#[derive(Debug, Clone, Serialize)]
pub struct ClassifiedMessage {
    /// Tracker clock in µs.
    pub time_us: i64,
    /// The trial it is in.
    pub trial: u32,
    /// What the message is.
    pub kind: MessageKind,
    /// The stimulus name, for onsets.
    pub stimulus: Option<String>,
    /// The message as logged.
    pub text: String,
}

/// Every message of a recording with its kind, in time order within each trial.
pub fn classify_messages(rec: &Recording, seg: &Segmentation) -> Vec<ClassifiedMessage> {
    let mut msgs: Vec<&Message> = rec.messages.iter().collect();
    msgs.sort_by_key(|m| (m.trial, m.time_us));
    msgs.into_iter()
        .map(|m| {
            let (kind, stimulus) = classify_message(&m.text, seg.pattern.as_ref());
            ClassifiedMessage {
                time_us: m.time_us,
                trial: m.trial,
                kind,
                stimulus,
                text: m.text.clone(),
            }
        })
        .collect()
}

/// The stimulus segments the classified messages define.
pub fn stimulus_segments(
    messages: &[ClassifiedMessage],
    seg: &Segmentation,
) -> Vec<StimulusSegment> {
    let mut out: Vec<StimulusSegment> = Vec::new();
    let mut open: Option<usize> = None;
    let close = |out: &mut Vec<StimulusSegment>, open: &mut Option<usize>, t: i64, by| {
        if let Some(i) = open.take() {
            let s = &mut out[i];
            let cap = seg.max_duration_us.map(|d| s.onset_us + d);
            match cap {
                Some(c) if c <= t => {
                    s.end_us = Some(c);
                    s.ended_by = "duration";
                }
                _ => {
                    s.end_us = Some(t);
                    s.ended_by = by;
                }
            }
        }
    };
    let mut trial = None;
    for m in messages {
        if trial != Some(m.trial) {
            if let Some(i) = open.take() {
                finish_open(&mut out[i], seg);
            }
            trial = Some(m.trial);
        }
        match m.kind {
            MessageKind::Stimulus => {
                close(&mut out, &mut open, m.time_us, "next-onset");
                out.push(StimulusSegment {
                    trial: m.trial,
                    name: m.stimulus.clone().unwrap_or_default(),
                    onset_us: m.time_us,
                    end_us: None,
                    ended_by: "trial-end",
                });
                open = Some(out.len() - 1);
            }
            MessageKind::StimulusEnd => close(&mut out, &mut open, m.time_us, "end-message"),
            _ => {}
        }
    }
    if let Some(i) = open {
        finish_open(&mut out[i], seg);
    }
    out
}

fn finish_open(s: &mut StimulusSegment, seg: &Segmentation) {
    if let Some(d) = seg.max_duration_us {
        s.end_us = Some(s.onset_us + d);
        s.ended_by = "duration";
    }
}

/// Where a time falls: inside a segment, after a segment ended (before the next onset), or
/// before any onset of its trial.
#[derive(Debug, Clone, PartialEq)]
pub enum Placement<'a> {
    /// Inside this segment.
    Inside(&'a StimulusSegment),
    /// After this segment ended, before the next onset.
    AfterEnd(&'a StimulusSegment),
    /// Before the first onset of its trial.
    BeforeFirstOnset,
}

/// Places time `t` of `trial` among `segments` (sorted by trial, then onset).
pub fn place<'a>(segments: &'a [StimulusSegment], trial: u32, t: i64) -> Placement<'a> {
    let latest = segments
        .iter()
        .filter(|s| s.trial == trial && s.onset_us <= t)
        .max_by_key(|s| s.onset_us);
    match latest {
        None => Placement::BeforeFirstOnset,
        Some(s) if s.end_us.is_some_and(|e| t >= e) => Placement::AfterEnd(s),
        Some(s) => Placement::Inside(s),
    }
}

/// Distinct message texts with their count and classification, most frequent first.
pub fn message_census(
    messages: &[ClassifiedMessage],
) -> Vec<(String, usize, MessageKind, Option<String>)> {
    let mut by_text: BTreeMap<&str, (usize, MessageKind, Option<String>)> = BTreeMap::new();
    for m in messages {
        let e = by_text
            .entry(m.text.as_str())
            .or_insert((0, m.kind, m.stimulus.clone()));
        e.0 += 1;
    }
    let mut v: Vec<(String, usize, MessageKind, Option<String>)> = by_text
        .into_iter()
        .map(|(t, (n, k, s))| (t.to_string(), n, k, s))
        .collect();
    v.sort_by(|a, b| b.1.cmp(&a.1).then(a.0.cmp(&b.0)));
    v
}

#[cfg(test)]
mod tests {
    use super::*;

    fn kind(t: &str) -> (MessageKind, Option<String>) {
        classify_message(t, None)
    }

    #[test]
    fn the_messages_seen_in_real_exports() {
        let stim = |n: &str| (MessageKind::Stimulus, Some(n.to_string()));
        assert_eq!(
            kind(r"start_trial 36 C:\Users\someone\Desktop\Manip SMI\Images_finales\mtemo33.png"),
            stim("mtemo33.png")
        );
        assert_eq!(
            kind("Starting wait for fixation period").0,
            MessageKind::Status
        );
        assert_eq!(kind("# UTC: 1489598928 791").0, MessageKind::Clock);
        assert_eq!(kind("[").0, MessageKind::Truncated);
        assert_eq!(kind("car_banana.jpg"), stim("car_banana.jpg"));
        assert_eq!(
            kind("Elmos World The Sky Active.avi"),
            stim("Elmos World The Sky Active.avi")
        );
        assert_eq!(kind("ball-calibration.avi"), stim("ball-calibration.avi"));
        assert_eq!(kind("\"Spoon").0, MessageKind::Truncated);
        assert_eq!(
            kind("UE-mouseclick left x=407 y=378").0,
            MessageKind::UserEvent
        );
        assert_eq!(kind("UE-keypress").0, MessageKind::UserEvent);
        assert_eq!(kind("start_trial 36 mtemo33.png"), stim("mtemo33.png"));
        assert_eq!(kind("/home/lab/videos/bunny.MP4"), stim("bunny.MP4"));
        assert_eq!(kind("81").0, MessageKind::Status);
        assert_eq!(kind("12:01:33.250").0, MessageKind::Clock);
    }

    #[test]
    fn a_user_pattern_replaces_the_file_name_rule() {
        let p = StimulusPattern::new(r"^TRIALID (\w+)$", Some("^TRIAL_END")).unwrap();
        assert_eq!(
            classify_message("TRIALID cow", Some(&p)),
            (MessageKind::Stimulus, Some("cow".into()))
        );
        assert_eq!(
            classify_message("TRIAL_END", Some(&p)).0,
            MessageKind::StimulusEnd
        );
        assert_eq!(classify_message("cow.png", Some(&p)).0, MessageKind::Status);
        assert!(StimulusPattern::new("no group", None).is_err());
        assert!(StimulusPattern::new("(a)(b)", None).is_err());
        assert!(StimulusPattern::new("(", None).is_err());
    }

    fn msg(t: i64, text: &str) -> ClassifiedMessage {
        let (kind, stimulus) = classify_message(text, None);
        ClassifiedMessage {
            time_us: t,
            trial: 1,
            kind,
            stimulus,
            text: text.into(),
        }
    }

    #[test]
    fn segments_end_at_the_next_onset_or_the_longest_duration() {
        let seg = Segmentation {
            pattern: None,
            max_duration_us: Some(48_000_000),
        };
        let m = vec![
            msg(0, "Starting wait for fixation period"),
            msg(1_000_000, "a.avi"),
            msg(2_000_000, "UE-keypress"),
            msg(30_000_000, "b.avi"),
            msg(31_000_000, "["),
            msg(200_000_000, "c.avi"),
        ];
        let s = stimulus_segments(&m, &seg);
        assert_eq!(s.len(), 3);
        assert_eq!(
            (s[0].name.as_str(), s[0].end_us, s[0].ended_by),
            ("a.avi", Some(30_000_000), "next-onset")
        );
        assert_eq!(
            (s[1].name.as_str(), s[1].end_us, s[1].ended_by),
            ("b.avi", Some(78_000_000), "duration")
        );
        assert_eq!(
            (s[2].name.as_str(), s[2].end_us, s[2].ended_by),
            ("c.avi", Some(248_000_000), "duration")
        );
        assert_eq!(place(&s, 1, 500_000), Placement::BeforeFirstOnset);
        assert_eq!(place(&s, 1, 2_500_000), Placement::Inside(&s[0]));
        assert_eq!(place(&s, 1, 80_000_000), Placement::AfterEnd(&s[1]));
        assert_eq!(place(&s, 2, 80_000_000), Placement::BeforeFirstOnset);
    }
}
