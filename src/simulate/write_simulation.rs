//! Writing virtual observers to disk: each subject's recording in a tracker's format, the true
//! fixations (targets.csv) and simulate.json.
use serde::Serialize;

use super::observers::{ObserverParams, VirtualSubject};
use super::SimulateError;
use crate::gaze::recording::{Event, Header, Message, Sample};

#[derive(Serialize)]
struct SimulationSidecar<'a> {
    provenance: crate::provenance::Provenance,
    stimulus_name: &'a str,
    model: &'a str,
    parameters: &'a ObserverParams,
    recording_format: RecordingFormat,
    subjects: Vec<SubjectFacts>,
}

#[derive(Serialize)]
struct SubjectFacts {
    id: String,
    head_distance_mm: f64,
    samples: usize,
    lost_samples: usize,
    fixations: usize,
    fixations_with_target: usize,
    files: Vec<String>,
}

/// The tracker whose files the virtual observers write.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize)]
#[cfg_attr(feature = "cli", derive(clap::ValueEnum))]
#[serde(rename_all = "lowercase")]
pub enum RecordingFormat {
    /// SMI RED250: format A samples (`sNN_samples.txt`) and C1 events (`sNN_events.txt`).
    #[default]
    Smi,
    /// SR Research EyeLink: one ASC file per subject (`sNN.asc`), samples, events and
    /// messages as edf2asc writes them.
    Eyelink,
    /// Tobii Pro Lab: one data export per subject (`sNN.tsv`), samples with the I-VT
    /// filter's fixation labels and stimulus start events.
    Tobii,
}

impl RecordingFormat {
    /// The files subject `id`'s recording is written to, with their text.
    pub fn files(
        self,
        id: &str,
        header: &Header,
        samples: &[Sample],
        events: &[Event],
        messages: &[Message],
    ) -> Vec<(String, String)> {
        use crate::gaze::writers::{
            write_events_c1, write_eyelink_asc, write_samples_a, write_tobii_pro_lab_tsv,
        };
        match self {
            RecordingFormat::Smi => vec![
                (
                    format!("{id}_samples.txt"),
                    write_samples_a(header, samples, messages),
                ),
                (
                    format!("{id}_events.txt"),
                    write_events_c1(header, events, messages),
                ),
            ],
            RecordingFormat::Eyelink => vec![(
                format!("{id}.asc"),
                write_eyelink_asc(header, samples, events, messages),
            )],
            RecordingFormat::Tobii => vec![(
                format!("{id}.tsv"),
                write_tobii_pro_lab_tsv(header, samples, events, messages),
            )],
        }
    }
}

/// Writes each subject's recording in `format` (SMI: format A `sNN_samples.txt` and C1
/// `sNN_events.txt`; EyeLink: `sNN.asc`), the true fixations (`targets.csv`) and
/// `simulate.json` (provenance from `inputs`, the target model and parameters, per-subject
/// facts) into `dir`.
#[allow(clippy::too_many_arguments)]
pub fn write_simulation(
    dir: &std::path::Path,
    subjects: &[VirtualSubject],
    inputs: Vec<crate::provenance::InputFile>,
    stimulus_name: &str,
    model_name: &str,
    params: &ObserverParams,
    format: RecordingFormat,
) -> Result<(), SimulateError> {
    crate::file_bytes::create_output_dir(dir)
        .map_err(|e| SimulateError::OutputFolder(format!("{e:#}")))?;
    let write = |name: &str, text: &str| {
        let path = dir.join(name);
        std::fs::write(&path, text).map_err(|error| SimulateError::Io {
            action: "write",
            path,
            error,
        })
    };
    let mut facts = Vec::new();
    for s in subjects {
        let files = format.files(&s.id, &s.header, &s.samples, &s.events, &s.messages);
        for (name, text) in &files {
            write(name, text)?;
        }
        facts.push(SubjectFacts {
            id: s.id.clone(),
            head_distance_mm: s.head_distance_mm,
            samples: s.samples.len(),
            lost_samples: s
                .samples
                .iter()
                .filter(|x| !x.left.is_some_and(|e| e.valid))
                .count(),
            fixations: s.fixations.len(),
            fixations_with_target: s.fixations.iter().filter(|f| f.vertex.is_some()).count(),
            files: files.into_iter().map(|(name, _)| name).collect(),
        });
    }
    let tp = dir.join("targets.csv");
    let file = std::fs::File::create(&tp).map_err(|error| SimulateError::Io {
        action: "create",
        path: tp.clone(),
        error,
    })?;
    write_targets_csv(std::io::BufWriter::new(file), subjects)?;
    let sidecar = SimulationSidecar {
        provenance: crate::provenance::Provenance::new(inputs),
        stimulus_name,
        model: model_name,
        parameters: params,
        recording_format: format,
        subjects: facts,
    };
    let json = serde_json::to_string_pretty(&sidecar)? + "\n";
    write("simulate.json", &json)
}

/// `targets.csv`: the true target of every simulated fixation.
pub fn write_targets_csv<W: std::io::Write>(
    out: W,
    subjects: &[VirtualSubject],
) -> Result<(), SimulateError> {
    let mut w = csv::Writer::from_writer(out);
    for s in subjects {
        for f in &s.fixations {
            w.serialize(f)?;
        }
    }
    w.flush().map_err(|e| SimulateError::Csv(e.into()))
}
