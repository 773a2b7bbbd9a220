use std::collections::BTreeMap;
use std::io::Write;
use std::path::{Path, PathBuf};

use anyhow::{bail, Context, Result};
use clap::Args;
use serde::Serialize;

use meshgaze::geometry::{BoundingBox, Normalization};
use meshgaze::ground_truth::{fixation_truth_from_rows, GroundTruth};
use meshgaze::mesh::write_ply_with_quality;
use meshgaze::metrics::surface_blur::{vertex_areas, BlurKernel, HeatBlur, SurfaceBlur};
use meshgaze::projection::table::{read_projected_csv, write_projected_csv, ProjectedRow};
use meshgaze::projection::{count_fates, ProjectionFate};
use meshgaze::provenance::{InputFile, Provenance};
use meshgaze::scoring::{score_mesh, ScoreParams, HUMAN};
use meshgaze::stimulus::load::load_stimulus;

use super::progress_bar::Bars;

/// Build a mesh's ground truth from projected fixations of several subjects.
///
/// Reads projected.csv files (or folders holding one) written by `meshgaze project` for the
/// stimulus, checks their project.json names the same mesh, and writes:
/// OUT/truth.csv (every fixation with its fate, vertex and surface point: the fixation-set
/// format `meshgaze score --truth` reads), OUT/density.csv (vertex, fixation count, density
/// blurred with σ_b = --blur in normalized units, and the cone density when the projections
/// used --cone-deg), OUT/truth.ply (density as quality and colour; MeshLab: Render > Color >
/// Per Vertex), OUT/human.csv (the split-half human ceiling over blur: every split of the
/// subjects into halves, both directions, when there are at most 8) and OUT/truth.json
/// (provenance, fates per subject, on-mesh fixations per subject against the protocol's
/// expected count).
#[derive(Debug, Args)]
pub struct TruthArgs {
    /// The stimulus (manifest.json or its folder).
    #[arg(long)]
    pub stimulus: PathBuf,
    /// projected.csv files, or folders holding one.
    #[arg(required = true)]
    pub projected: Vec<PathBuf>,
    /// Output folder.
    #[arg(short, long)]
    pub output: PathBuf,
    /// Blur σ_b of the density map, normalized units (half principal-axes box diagonal = 1).
    #[arg(long, default_value_t = 0.02)]
    pub blur: f64,
    /// Largest blur of the human-ceiling sweep.
    #[arg(long, default_value_t = 0.2)]
    pub blur_max: f64,
    /// Step of the human-ceiling sweep.
    #[arg(long, default_value_t = 0.01)]
    pub blur_step: f64,
    /// Blur kernel: Euclidean (fast) or heat diffusion (along the surface).
    #[arg(long, value_enum, default_value_t = BlurKernel::Euclidean)]
    pub kernel: BlurKernel,
    /// The mesh, if it moved since rendering.
    #[arg(long)]
    pub mesh: Option<PathBuf>,
    #[arg(short, long)]
    pub quiet: bool,
}

#[derive(Serialize)]
pub struct SubjectTruth {
    pub fates: BTreeMap<&'static str, usize>,
    pub on_mesh: usize,
}

#[derive(Serialize)]
pub struct TruthSidecar {
    pub provenance: Provenance,
    pub mesh_sha256: String,
    pub blur: f64,
    pub kernel: BlurKernel,
    pub subjects: BTreeMap<String, SubjectTruth>,
    /// The protocol's fixations per subject (keep_longest).
    pub expected_per_subject: usize,
    pub fixations_on_mesh: usize,
    pub fixated_vertices: usize,
    pub human_splits: usize,
    pub human_auc_judd_unblurred: f64,
    pub human_auc_judd_peak: f64,
    pub human_auc_judd_peak_blur: f64,
    pub warnings: Vec<String>,
}

/// What `truth` computed, for callers such as the demo.
pub struct TruthResult {
    pub rows: Vec<ProjectedRow>,
    pub truth: GroundTruth,
    pub density: Vec<f64>,
    pub sidecar: TruthSidecar,
}

fn projected_file(p: &Path) -> PathBuf {
    if p.is_dir() {
        p.join("projected.csv")
    } else {
        p.to_path_buf()
    }
}

pub fn run(args: TruthArgs) -> Result<()> {
    let bars = Bars::new(args.quiet);
    let stim = load_stimulus(&args.stimulus, args.mesh.as_deref()).map_err(anyhow::Error::msg)?;
    let files: Vec<PathBuf> = args.projected.iter().map(|p| projected_file(p)).collect();
    let r = build_truth(&stim, &files, &args, &bars)?;
    if !args.quiet {
        let mut fates: BTreeMap<String, BTreeMap<&'static str, usize>> = BTreeMap::new();
        for (s, t) in &r.sidecar.subjects {
            fates.insert(s.clone(), t.fates.clone());
        }
        let totals = count_fates(
            r.rows
                .iter()
                .filter_map(|x| x.fate())
                .collect::<Vec<_>>()
                .iter(),
        )
        .into_iter()
        .map(|(f, n)| (f.name(), n))
        .collect();
        super::project::print_fate_table(&fates, &totals);
        for w in &r.sidecar.warnings {
            eprintln!("warning: {w}");
        }
        eprintln!(
            "{} fixations on the mesh from {} subjects ({} vertices fixated); human ceiling AUC-Judd {:.3} unblurred, {:.3} at σ_b = {} ({} splits)",
            r.sidecar.fixations_on_mesh,
            r.sidecar.subjects.len(),
            r.sidecar.fixated_vertices,
            r.sidecar.human_auc_judd_unblurred,
            r.sidecar.human_auc_judd_peak,
            r.sidecar.human_auc_judd_peak_blur,
            r.sidecar.human_splits
        );
        eprintln!(
            "wrote truth.csv, density.csv, truth.ply, human.csv, truth.json to {}",
            args.output.display()
        );
    }
    Ok(())
}

/// Builds and writes the ground truth (see `meshgaze truth --help`).
pub fn build_truth(
    stim: &meshgaze::stimulus::load::LoadedStimulus,
    files: &[PathBuf],
    args: &TruthArgs,
    bars: &Bars,
) -> Result<TruthResult> {
    let mesh = &stim.mesh;
    let n = mesh.positions.len();
    let mut inputs = vec![InputFile::hash(&stim.manifest_path)?];
    let mut rows: Vec<ProjectedRow> = Vec::new();
    let mut cone = vec![0.0; n];
    let mut have_cone = false;
    let mut warnings = Vec::new();
    for f in files {
        let dir = f.parent().unwrap_or(Path::new("."));
        let sidecar = dir.join("project.json");
        match std::fs::read(&sidecar) {
            Ok(b) => {
                let v: serde_json::Value = serde_json::from_slice(&b)
                    .with_context(|| format!("{}: not JSON", sidecar.display()))?;
                if v.get("mesh_sha256").and_then(|x| x.as_str()) != Some(stim.mesh_sha256.as_str())
                {
                    bail!(
                        "{} was projected onto another mesh than {} (SHA-256 differs)",
                        f.display(),
                        stim.mesh_path.display()
                    );
                }
            }
            Err(_) => warnings.push(format!(
                "{}: no project.json beside it; cannot confirm it was projected onto this mesh",
                f.display()
            )),
        }
        let part = read_projected_csv(f).map_err(anyhow::Error::msg)?;
        if let Some(bad) = part.iter().filter_map(|r| r.vertex).find(|&v| v >= n) {
            bail!(
                "{}: vertex {bad} is out of range: the mesh has {n} vertices",
                f.display()
            );
        }
        rows.extend(part);
        inputs.push(InputFile::hash(f)?);
        let cone_file = dir.join("cone.csv");
        if cone_file.exists() {
            have_cone = true;
            let mut r = csv::Reader::from_path(&cone_file)
                .with_context(|| format!("cannot read {}", cone_file.display()))?;
            for (i, rec) in r.records().enumerate() {
                let rec = rec.with_context(|| format!("{}:{}", cone_file.display(), i + 2))?;
                let v: usize = rec.get(2).unwrap_or("").parse().with_context(|| {
                    format!("{}:{}: column `vertex`", cone_file.display(), i + 2)
                })?;
                let w: f64 = rec.get(3).unwrap_or("").parse().with_context(|| {
                    format!("{}:{}: column `weight`", cone_file.display(), i + 2)
                })?;
                if v >= n {
                    bail!("{}:{}: vertex {v} out of range", cone_file.display(), i + 2);
                }
                cone[v] += w;
            }
            inputs.push(InputFile::hash(&cone_file)?);
        }
    }
    rows.sort_by(|a, b| a.subject.cmp(&b.subject).then(a.fixation.cmp(&b.fixation)));
    let dup = rows
        .windows(2)
        .find(|w| w[0].subject == w[1].subject && w[0].fixation == w[1].fixation);
    if let Some(w) = dup {
        bail!(
            "subject {} fixation {} appears twice: the same subject was given twice",
            w[0].subject,
            w[0].fixation
        );
    }
    let fixation_truth = fixation_truth_from_rows(&rows);
    let mut counts = vec![0.0; n];
    for f in &fixation_truth.fixations {
        counts[f.vertex] += 1.0;
    }
    let normalized = Normalization::of_mesh(mesh, BoundingBox::Oriented).normalized_mesh(mesh);
    let density = match args.kernel {
        BlurKernel::Euclidean => {
            SurfaceBlur::new(normalized.positions.clone(), vertex_areas(&normalized))
                .blur(&[&counts], args.blur)
                .remove(0)
        }
        BlurKernel::Heat => HeatBlur::new(&normalized)
            .blur(&[&counts], args.blur)
            .map_err(anyhow::Error::msg)?
            .remove(0),
    };
    let expected = stim.protocol.fixations.keep_longest;
    let mut subjects: BTreeMap<String, SubjectTruth> = BTreeMap::new();
    let names: Vec<String> = {
        let mut v: Vec<String> = rows.iter().map(|r| r.subject.clone()).collect();
        v.dedup();
        v
    };
    for s in &names {
        let fates: BTreeMap<&'static str, usize> = count_fates(
            rows.iter()
                .filter(|r| &r.subject == s)
                .filter_map(|r| r.fate())
                .collect::<Vec<_>>()
                .iter(),
        )
        .into_iter()
        .map(|(f, c)| (f.name(), c))
        .collect();
        let on_mesh = fates[ProjectionFate::Hit.name()] + fates[ProjectionFate::Snapped.name()];
        if on_mesh < expected {
            warnings.push(format!(
                "subject {s}: {on_mesh} fixations on the mesh, the protocol keeps {expected}"
            ));
        }
        subjects.insert(s.clone(), SubjectTruth { fates, on_mesh });
    }
    let truth = GroundTruth::Fixations(fixation_truth.clone());
    let params = ScoreParams {
        blur_sigmas: super::score::blur_grid(args.blur_max, args.blur_step)?,
        kernel: args.kernel,
        borji_splits: 10,
        ..ScoreParams::default()
    };
    let score = score_mesh(mesh, &truth, &[], &params, bars).map_err(anyhow::Error::msg)?;
    let human: Vec<(f64, &'static str, f64)> = score
        .rows
        .iter()
        .filter(|r| r.method == HUMAN)
        .map(|r| (r.blur, r.metric, r.value))
        .collect();
    let auc: Vec<(f64, f64)> = human
        .iter()
        .filter(|h| h.1 == "auc_judd")
        .map(|h| (h.0, h.2))
        .collect();
    let (peak_blur, peak) =
        auc.iter()
            .copied()
            .filter(|x| x.1.is_finite())
            .fold((f64::NAN, f64::NAN), |b, x| {
                if b.1.is_nan() || x.1 > b.1 {
                    x
                } else {
                    b
                }
            });
    let out = &args.output;
    std::fs::create_dir_all(out).with_context(|| format!("cannot create {}", out.display()))?;
    let tp = out.join("truth.csv");
    write_projected_csv(
        std::io::BufWriter::new(
            std::fs::File::create(&tp)
                .with_context(|| format!("cannot create {}", tp.display()))?,
        ),
        &rows,
    )
    .map_err(anyhow::Error::msg)?;
    let dp = out.join("density.csv");
    let mut w = std::io::BufWriter::new(
        std::fs::File::create(&dp).with_context(|| format!("cannot create {}", dp.display()))?,
    );
    writeln!(
        w,
        "vertex,fixations,density{}",
        if have_cone { ",cone" } else { "" }
    )?;
    for v in 0..n {
        if have_cone {
            writeln!(w, "{v},{},{},{}", counts[v], density[v], cone[v])?;
        } else {
            writeln!(w, "{v},{},{}", counts[v], density[v])?;
        }
    }
    w.flush()?;
    let max = density.iter().cloned().fold(0.0f64, f64::max);
    let quality: Vec<f64> = density
        .iter()
        .map(|d| if max > 0.0 { d / max } else { 0.0 })
        .collect();
    write_ply_with_quality(
        &out.join("truth.ply"),
        mesh,
        &quality,
        &[
            format!(
                "meshgaze {} truth: fixation density, blur {}",
                env!("CARGO_PKG_VERSION"),
                args.blur
            ),
            format!(
                "{} fixations from {} subjects",
                fixation_truth.fixations.len(),
                fixation_truth.subjects.len()
            ),
        ],
    )
    .with_context(|| format!("cannot write {}", out.join("truth.ply").display()))?;
    let hp = out.join("human.csv");
    let mut w = std::io::BufWriter::new(std::fs::File::create(&hp)?);
    writeln!(w, "blur,metric,value")?;
    for (b, m, v) in &human {
        writeln!(w, "{b},{m},{v}")?;
    }
    w.flush()?;
    let sidecar = TruthSidecar {
        provenance: Provenance::new(inputs),
        mesh_sha256: stim.mesh_sha256.clone(),
        blur: args.blur,
        kernel: args.kernel,
        subjects,
        expected_per_subject: expected,
        fixations_on_mesh: fixation_truth.fixations.len(),
        fixated_vertices: counts.iter().filter(|c| **c > 0.0).count(),
        human_splits: score.human_splits,
        human_auc_judd_unblurred: auc.first().map_or(f64::NAN, |x| x.1),
        human_auc_judd_peak: peak,
        human_auc_judd_peak_blur: peak_blur,
        warnings,
    };
    let jp = out.join("truth.json");
    std::fs::write(&jp, serde_json::to_string_pretty(&sidecar)? + "\n")
        .with_context(|| format!("cannot write {}", jp.display()))?;
    Ok(TruthResult {
        rows,
        truth,
        density,
        sidecar,
    })
}
