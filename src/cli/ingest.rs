use std::collections::BTreeMap;
use std::io::Write;
use std::path::PathBuf;

use anyhow::{Context, Result};
use clap::Args;

use meshgaze::file_bytes::create_output_dir;
use meshgaze::gaze::fixations::{Detector, EyePolicy, Fate, Fixation};
use meshgaze::gaze::ingest::{
    ingest_files, message_kind_counts, stimuli_of, write_ingest, write_samples_csv, IngestParams,
    IngestedFile,
};
use meshgaze::gaze::stimulus_messages::{classify_messages, message_census, stimulus_segments};
use meshgaze::gaze::validity::ValidityRule;
use meshgaze::gaze::{read_recording, GazeFormat};
use meshgaze::protocol::Protocol;

/// Read eye-tracker recordings (SMI, EyeLink), find fixations, apply the protocol's filter,
/// report quality.
///
/// Reads SR Research EyeLink ASC files (edf2asc text, plain or .gz: monocular or binocular,
/// any sample rate, remote mode; an EDF binary must be converted with edf2asc first), and SMI
/// exports: IDF Converter sample text (format A, `## [iView]`), BeGaze sample exports (A'),
/// iView X 2.x sample files (A2, `#FileVersion: 2`, one eye, ms times), IDF Event Detector /
/// BeGaze event text (C1, `Table Header for …`; TAB, comma or the space-damaged variant),
/// BeGaze Raw Data (C2), BeGaze Event Statistics (B; separator and decimal comma sniffed) and
/// the older BeGaze fixation table (B-fix, `Fixation Start [ms]`, several subjects a file),
/// detected from content or set with --format.
/// Every line of every file is accounted for: rows that cannot be used are counted by reason
/// with the line and column of the first one.
///
/// Fixations come from the exporter's events (--detector events, the default for files with
/// events and no samples: C1, B, and for EyeLink files, whose EFIX events are the tracker's
/// own parser) or are detected in samples (i-dt, the default for A; i-vt). EyeLink message
/// offsets (`MSG 1000 -14 text`) are applied; GAZE_COORDS gives the screen.
///
/// A message starts a stimulus when it names an image or video file (`bunny.mp4`, a Windows
/// path ending in `mtemo33.png`, `Elmos World.avi`), or matches --stimulus-pattern. Every other
/// message (status text, clock stamps, `UE-…` user events, cut-off text) is kept in
/// messages.csv with its kind and does not end the running stimulus. A stimulus ends at the
/// next onset, at a --stimulus-end-pattern message, or after the protocol's video length
/// (48 s for hu2020); fixations after that, or before the first onset, are `invalid` with
/// the reason. See what a file's messages are with --list-messages.
///
/// The eye: by default the one the file has (with both, the one with more valid samples; for
/// event files the left stream, else the eye present). A sample is lost where its validity
/// flag is 0 or its point of regard is (0, 0); a flag that is 0 in every row while the gaze
/// moves is set aside and said so (--validity). A file that yields no fixation says why.
///
/// Per subject and stimulus the protocol's filter drops the first and last fixations and
/// keeps the longest; every fixation keeps its fate. Two files giving one subject fixations
/// on the same stimulus (a sample and an event export of one recording) are refused.
///
/// Writes DIR/fixations.csv, DIR/messages.csv, DIR/quality.csv, DIR/ingest.json (provenance,
/// headers, row accounts, message kinds, parameters) and with --samples DIR/samples.csv.
#[derive(Debug, Args)]
pub struct IngestArgs {
    /// Recording files (SMI exports, EyeLink .asc), gzip allowed.
    #[arg(required = true)]
    pub files: Vec<PathBuf>,
    /// Output folder (not needed with --list-messages).
    #[arg(short, long, required_unless_present = "list_messages")]
    pub output: Option<PathBuf>,
    /// Print each file's distinct message texts with their counts and how each is
    /// classified, then stop: the minute it takes to write a --stimulus-pattern.
    #[arg(long)]
    pub list_messages: bool,
    /// A regular expression with one capture group, the stimulus name, that marks stimulus
    /// onsets (replaces the image/video file-name rule), e.g. `^start_trial \d+ (.*)$`.
    #[arg(long)]
    pub stimulus_pattern: Option<String>,
    /// A regular expression marking where a stimulus ends (with --stimulus-pattern).
    #[arg(long, requires = "stimulus_pattern")]
    pub stimulus_end_pattern: Option<String>,
    /// The protocol whose [fixations] rules apply [default: the built-in hu2020 protocol].
    #[arg(long)]
    pub protocol: Option<PathBuf>,
    /// Force the format instead of detecting it.
    #[arg(long, value_enum)]
    pub format: Option<GazeFormat>,
    /// Where fixations come from (default: events for event files and EyeLink, i-dt for
    /// sample files).
    #[arg(long, value_enum)]
    pub detector: Option<Detector>,
    /// Which eye's gaze to use (best: the eye the file has, or of two the one with more
    /// valid samples). A named eye the file lacks is an error that names the eyes it has.
    #[arg(long, value_enum, default_value_t = EyePolicy::Best)]
    pub eye: EyePolicy,
    /// Which samples are lost: auto (validity flag or POR (0, 0), but a flag that is 0 in
    /// every row while the POR moves is set aside, said in the summary), strict (flag or POR,
    /// always), por (POR (0, 0) only).
    #[arg(long, value_enum, default_value_t = ValidityRule::Auto)]
    pub validity: ValidityRule,
    /// Subject id (default: the header's Subject, else the file name).
    #[arg(long)]
    pub subject: Option<String>,
    /// I-DT: largest dispersion (x range + y range) in pixels [default: the protocol's].
    #[arg(long)]
    pub max_dispersion_px: Option<f64>,
    /// Shortest fixation in ms [default: the protocol's].
    #[arg(long)]
    pub min_duration_ms: Option<f64>,
    /// I-VT: largest fixation speed in degrees per second [default: the protocol's].
    #[arg(long)]
    pub max_velocity_deg_s: Option<f64>,
    /// The screen, WIDTHxHEIGHT pixels, for files whose positions are fractions of it
    /// (Gazepoint, Pupil Labs surfaces) and that do not give its size [default: the
    /// protocol's display]. The summary says which size a file was scaled with.
    #[arg(long, value_parser = parse_screen_px)]
    pub screen: Option<[f64; 2]>,
    /// Also write every sample to samples.csv.
    #[arg(long)]
    pub samples: bool,
    #[arg(short, long)]
    pub quiet: bool,
}

fn parse_screen_px(s: &str) -> Result<[f64; 2], String> {
    meshgaze::projection::project_file::parse_screen(s)
        .map(|(w, h)| [w, h])
        .map_err(|e| format!("{e:#}"))
}

fn params(args: &IngestArgs, protocol: &Protocol) -> Result<IngestParams> {
    let rules = &protocol.fixations;
    let pattern = args
        .stimulus_pattern
        .as_deref()
        .map(|p| (p, args.stimulus_end_pattern.as_deref()));
    let mut params = IngestParams::from_protocol(protocol, pattern).map_err(anyhow::Error::msg)?;
    params.format = args.format;
    params.detector = args.detector;
    params.eye = args.eye;
    params.validity = args.validity;
    params.subject = args.subject.clone();
    if args.screen.is_some() {
        params.screen_px = args.screen;
    }
    let d = &mut params.detector_params;
    d.max_dispersion_px = args
        .max_dispersion_px
        .unwrap_or(rules.idt_max_dispersion_px);
    d.min_duration_ms = args.min_duration_ms.unwrap_or(rules.min_duration_ms);
    if let Some(v) = args.max_velocity_deg_s {
        d.max_velocity_px_s = v * protocol.display.pixels_per_degree();
    }
    Ok(params)
}

/// --list-messages: each file's distinct messages, counted and classified.
fn list_messages(args: &IngestArgs, params: &IngestParams) -> Result<()> {
    for file in &args.files {
        let rec = read_recording(file, args.format)?;
        let messages = classify_messages(&rec, &params.segmentation);
        println!("{}: {} messages", file.display(), messages.len());
        let census = message_census(&messages);
        let width = census
            .iter()
            .map(|c| c.3.as_deref().map_or(0, |s| s.chars().count()))
            .max()
            .unwrap_or(0)
            .max("stimulus".len());
        println!(
            "{:>7}  {:<12}  {:<width$}  text",
            "count", "kind", "stimulus"
        );
        for (text, n, kind, stimulus) in census {
            println!(
                "{n:>7}  {:<12}  {:<width$}  {text}",
                kind.name(),
                stimulus.unwrap_or_default()
            );
        }
        let segments = stimulus_segments(&messages, &params.segmentation);
        println!("  {} stimulus presentations:", segments.len());
        for s in &segments {
            println!(
                "    trial {} at {} µs: {} (ends {}, by {})",
                s.trial,
                s.onset_us,
                s.name,
                s.end_us
                    .map_or("open".to_string(), |e| format!("at {e} µs")),
                s.ended_by
            );
        }
        // Formats B and B-fix name each event's stimulus in a column instead of a message.
        let mut named: BTreeMap<&str, usize> = BTreeMap::new();
        for e in &rec.events {
            if let Some(s) = e.stimulus.as_deref() {
                *named.entry(s).or_insert(0) += 1;
            }
        }
        if !named.is_empty() {
            println!(
                "  {} stimuli named by the file's `Stimulus` column (events per stimulus):",
                named.len()
            );
            for (s, n) in named {
                println!("    {n:>7}  {s}");
            }
        }
    }
    Ok(())
}

fn print_file_summary(f: &IngestedFile) {
    let rec = &f.recording;
    eprintln!(
        "{}: {:?}, {} samples, {} messages, {} events, {} unusable lines; {} fixations ({} kept) over {} stimuli",
        f.path.display(),
        rec.format,
        rec.rows.samples,
        rec.rows.messages,
        rec.rows.events,
        rec.rows.unusable_total(),
        f.fixations.len(),
        f.fixations.iter().filter(|x| x.fate == Fate::Kept).count(),
        stimuli_of(f).len()
    );
    for (reason, first) in &rec.rows.unusable {
        eprintln!(
            "  {} lines: {reason} (first at {}:{}:{})",
            first.count,
            f.path.display(),
            first.line,
            first.column
        );
    }
    let mut reasons: BTreeMap<&str, usize> = BTreeMap::new();
    for x in &f.fixations {
        if let Some(r) = x.invalid_reason {
            *reasons.entry(r).or_insert(0) += 1;
        }
    }
    for (r, n) in reasons {
        eprintln!("  {n} fixations invalid: {r}");
    }
    let kinds = message_kind_counts(&f.messages);
    if !kinds.is_empty() {
        let list: Vec<String> = kinds.iter().map(|(k, n)| format!("{n} {k}")).collect();
        eprintln!("  messages: {}", list.join(", "));
    }
    for n in &rec.notes {
        eprintln!("  note: {n}");
    }
    for w in &f.warnings {
        eprintln!("warning: {w}");
    }
}

fn create(path: &std::path::Path) -> Result<std::io::BufWriter<std::fs::File>> {
    Ok(std::io::BufWriter::new(
        std::fs::File::create(path).with_context(|| format!("cannot create {}", path.display()))?,
    ))
}

pub fn run(args: IngestArgs) -> Result<()> {
    let (protocol, _, _) = Protocol::load_or_builtin(args.protocol.as_deref())?;
    let params = params(&args, &protocol)?;
    if args.list_messages {
        return list_messages(&args, &params);
    }
    let out = args.output.clone().expect("clap requires --output");
    let (files, inputs) = ingest_files(&args.files, &params).map_err(anyhow::Error::msg)?;
    if !args.quiet {
        files.iter().for_each(print_file_summary);
    }
    create_output_dir(&out)?;
    if args.samples {
        let p = out.join("samples.csv");
        let mut w = create(&p)?;
        write_samples_csv(&mut w, &files)?;
        w.flush()?;
    }
    let all_fix: Vec<&Fixation> = files.iter().flat_map(|f| f.fixations.iter()).collect();
    if all_fix.is_empty() && !args.quiet {
        eprintln!("warning: no fixations found in any file (each file's reason is above)");
    }
    let (_, j) =
        write_ingest(&out, &files, inputs, &protocol, &params).map_err(anyhow::Error::msg)?;
    let (p, m, q) = (
        out.join("fixations.csv"),
        out.join("messages.csv"),
        out.join("quality.csv"),
    );
    if !args.quiet {
        eprintln!(
            "wrote {}, {}, {}, {}",
            p.display(),
            m.display(),
            q.display(),
            j.display()
        );
    }
    Ok(())
}
