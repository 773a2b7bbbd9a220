use std::io::Write;
use std::path::PathBuf;

use anyhow::{bail, Context, Result};
use clap::Args;
use serde::Serialize;

use meshgaze::gaze::fixation_table::{write_fixations_csv, FixationRow};
use meshgaze::gaze::fixations::{
    apply_protocol_filter, fixations, Detector, DetectorParams, EyePolicy, Fixation,
};
use meshgaze::gaze::model::{Header, RowAccount};
use meshgaze::gaze::quality::{quality, QualityRow};
use meshgaze::gaze::{read_smi, SmiFormat};
use meshgaze::provenance::{InputFile, Provenance};
use meshgaze::stimulus::Protocol;

/// Read SMI eye-tracker exports, find fixations, apply the protocol's filter, report quality.
///
/// Reads IDF Converter sample text (format A, `## [iView]`), BeGaze sample exports (A'),
/// IDF Event Detector / BeGaze event text (C1, `Table Header for …`; TAB, comma or the
/// space-damaged variant), BeGaze Raw Data (C2) and BeGaze Event Statistics (B; separator and
/// decimal comma sniffed), detected from content or set with --format.
/// Every line of every file is accounted for: rows that cannot be used are counted by reason
/// with the line and column of the first one.
///
/// Fixations come from the event export (--detector events, the default for C1) or are
/// detected in samples (i-dt, the default for A; i-vt). Messages split a recording by
/// stimulus. Per subject and stimulus the protocol's filter drops the first and last
/// fixations and keeps the longest; every fixation keeps its fate.
///
/// Writes DIR/fixations.csv, DIR/quality.csv, DIR/ingest.json (provenance, headers, row
/// accounts, parameters) and with --samples DIR/samples.csv.
#[derive(Debug, Args)]
pub struct IngestArgs {
    /// SMI export files.
    #[arg(required = true)]
    pub files: Vec<PathBuf>,
    /// Output folder.
    #[arg(short, long)]
    pub output: PathBuf,
    /// The protocol whose [fixations] rules apply [default: the built-in hu2020 protocol].
    #[arg(long)]
    pub protocol: Option<PathBuf>,
    /// Force the format instead of detecting it.
    #[arg(long, value_enum)]
    pub format: Option<SmiFormat>,
    /// Where fixations come from (default: events for event files, i-dt for sample files).
    #[arg(long, value_enum)]
    pub detector: Option<Detector>,
    /// Which eye's gaze to use.
    #[arg(long, value_enum, default_value_t = EyePolicy::Best)]
    pub eye: EyePolicy,
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
    /// Also write every sample to samples.csv.
    #[arg(long)]
    pub samples: bool,
    #[arg(short, long)]
    pub quiet: bool,
}

#[derive(Serialize)]
struct FileEntry {
    file: String,
    format: SmiFormat,
    subject: String,
    detector: Detector,
    header: Header,
    rows: RowAccount,
    notes: Vec<String>,
    fixations: usize,
}

#[derive(Serialize)]
struct Sidecar<'a> {
    provenance: Provenance,
    protocol: &'a str,
    drop_first: usize,
    drop_last: usize,
    keep_longest: usize,
    eye_policy: EyePolicy,
    detector_params: &'a DetectorParams,
    files: Vec<FileEntry>,
}

fn opt(v: Option<f64>) -> String {
    v.map_or(String::new(), |x| format!("{x}"))
}

pub fn run(args: IngestArgs) -> Result<()> {
    let (protocol, _, _) = Protocol::load_or_builtin(args.protocol.as_deref())?;
    let rules = &protocol.fixations;
    let params = DetectorParams {
        max_dispersion_px: args
            .max_dispersion_px
            .unwrap_or(rules.idt_max_dispersion_px),
        min_duration_ms: args.min_duration_ms.unwrap_or(rules.min_duration_ms),
        max_velocity_px_s: args
            .max_velocity_deg_s
            .unwrap_or(rules.ivt_max_velocity_deg_s)
            * protocol.display.pixels_per_degree(),
        ..DetectorParams::default()
    };
    std::fs::create_dir_all(&args.output)
        .with_context(|| format!("cannot create {}", args.output.display()))?;
    let mut all_fix: Vec<Fixation> = Vec::new();
    let mut all_quality: Vec<QualityRow> = Vec::new();
    let mut entries = Vec::new();
    let mut inputs = Vec::new();
    let mut samples_out = if args.samples {
        let p = args.output.join("samples.csv");
        let mut w = std::io::BufWriter::new(
            std::fs::File::create(&p).with_context(|| format!("cannot create {}", p.display()))?,
        );
        writeln!(w, "subject,time_us,trial,left_x,left_y,left_pupil,left_valid,right_x,right_y,right_pupil,right_valid")?;
        Some(w)
    } else {
        None
    };
    for file in &args.files {
        let rec = read_smi(file, args.format)?;
        inputs.push(InputFile::hash(file)?);
        let subject = args
            .subject
            .clone()
            .or_else(|| rec.header.subject.clone())
            .unwrap_or_else(|| {
                file.file_stem()
                    .unwrap_or_default()
                    .to_string_lossy()
                    .to_string()
            });
        let detector = args
            .detector
            .unwrap_or(if rec.format == SmiFormat::EventTables {
                Detector::Events
            } else {
                Detector::IDt
            });
        if let (Some(rate), Detector::IVt) = (rec.header.sample_rate_hz, detector) {
            if rate < 200.0 && !args.quiet {
                eprintln!(
                    "warning: {}: I-VT at {rate} Hz: velocity detection needs 200 Hz or more",
                    file.display()
                );
            }
        }
        let interval_ms = meshgaze::gaze::fixations::sample_interval_us(&rec) as f64 / 1000.0;
        if !rec.samples.is_empty() && params.min_duration_ms < interval_ms && !args.quiet {
            eprintln!(
                "warning: {}: the minimum fixation duration {} ms is shorter than one sample ({interval_ms:.1} ms)",
                file.display(),
                params.min_duration_ms
            );
        }
        let mut fx =
            fixations(&rec, &subject, detector, args.eye, &params).map_err(anyhow::Error::msg)?;
        apply_protocol_filter(
            &mut fx,
            rules.drop_first,
            rules.drop_last,
            rules.keep_longest,
        );
        all_quality.extend(quality(&rec, &subject, &fx, args.eye));
        if let Some(w) = samples_out.as_mut() {
            for s in &rec.samples {
                let e = |e: Option<meshgaze::gaze::EyeSample>| {
                    e.map_or(",,,".to_string(), |e| {
                        format!("{},{},{},{}", e.x, e.y, opt(e.pupil), e.valid as u8)
                    })
                };
                writeln!(
                    w,
                    "{subject},{},{},{},{}",
                    s.time_us,
                    s.trial,
                    e(s.left),
                    e(s.right)
                )?;
            }
        }
        if !args.quiet {
            eprintln!(
                "{}: {:?}, {} samples, {} messages, {} events, {} unusable lines; {} fixations ({} kept)",
                file.display(),
                rec.format,
                rec.rows.samples,
                rec.rows.messages,
                rec.rows.events,
                rec.rows.unusable_total(),
                fx.len(),
                fx.iter().filter(|f| f.fate == meshgaze::gaze::fixations::Fate::Kept).count()
            );
            for (reason, first) in &rec.rows.unusable {
                eprintln!(
                    "  {} lines: {reason} (first at {}:{}:{})",
                    first.count,
                    file.display(),
                    first.line,
                    first.column
                );
            }
            for n in &rec.notes {
                eprintln!("  note: {n}");
            }
        }
        entries.push(FileEntry {
            file: file.display().to_string(),
            format: rec.format,
            subject: subject.clone(),
            detector,
            header: rec.header.clone(),
            rows: rec.rows.clone(),
            notes: rec.notes.clone(),
            fixations: fx.len(),
        });
        all_fix.extend(fx);
    }
    if let Some(mut w) = samples_out {
        w.flush()?;
    }
    if all_fix.is_empty() && !args.quiet {
        eprintln!("warning: no fixations found");
    }
    let p = args.output.join("fixations.csv");
    let file =
        std::fs::File::create(&p).with_context(|| format!("cannot create {}", p.display()))?;
    let rows: Vec<FixationRow> = all_fix.iter().map(FixationRow::from).collect();
    write_fixations_csv(std::io::BufWriter::new(file), &rows)
        .map_err(|e| anyhow::anyhow!("{}: {e}", p.display()))?;
    let q = args.output.join("quality.csv");
    let mut w = std::io::BufWriter::new(std::fs::File::create(&q)?);
    writeln!(w, "subject,stimulus,samples,lost_samples,lost_ms,loss_ratio,declared_rate_hz,measured_rate_hz,precision_rms_px,kept,dropped_first,dropped_last,not_longest,invalid")?;
    for r in &all_quality {
        let n = |k: &str| r.fixations_by_fate.get(k).copied().unwrap_or(0);
        writeln!(
            w,
            "{},{},{},{},{},{},{},{},{},{},{},{},{},{}",
            r.subject,
            r.stimulus.replace(',', ";"),
            r.samples,
            r.lost_samples,
            r.lost_ms,
            r.loss_ratio,
            opt(r.declared_rate_hz),
            opt(r.measured_rate_hz),
            opt(r.precision_rms_px),
            n("kept"),
            n("dropped-first"),
            n("dropped-last"),
            n("not-longest"),
            n("invalid")
        )?;
    }
    w.flush()?;
    if entries.is_empty() {
        bail!("no input file");
    }
    let sidecar = Sidecar {
        provenance: Provenance::new(inputs),
        protocol: &protocol.name,
        drop_first: rules.drop_first,
        drop_last: rules.drop_last,
        keep_longest: rules.keep_longest,
        eye_policy: args.eye,
        detector_params: &params,
        files: entries,
    };
    let j = args.output.join("ingest.json");
    std::fs::write(&j, serde_json::to_string_pretty(&sidecar)? + "\n")?;
    if !args.quiet {
        eprintln!("wrote {}, {}, {}", p.display(), q.display(), j.display());
    }
    Ok(())
}
