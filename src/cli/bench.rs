use std::path::{Path, PathBuf};
use std::process::Command;

use anyhow::{bail, Context, Result};
use clap::Args;
use serde::{Deserialize, Serialize};

use meshgaze::mesh::{load_mesh, subdivide_midpoint, Mesh};
use meshgaze::progress::Silent;
use meshgaze::saliency::{
    compute_saliency, sparse_metric_saliency, Method, SmsExtras, SmsParams, PAPER_METHODS,
};

/// Time SMS at the paper's settings, as in the paper's Table 3.
///
/// Cases: the 35,947-vertex Stanford bunny, the 48k Cyberware horse, the 134k igea, and the
/// 50k armadillo subdivided twice (about 800k vertices); each is compared with the paper's
/// row nearest in size. SMS with its steps A/B/C, then MC, MS, SI, SRI, MR and GR. Each cell
/// (case × method) runs in its own process so its peak memory is its own.
/// Prints a Markdown table; --csv also writes it as CSV. `--case NAME --method NAME` times one
/// cell alone, in its own process, with its peak memory.
#[derive(Debug, Args)]
pub struct BenchArgs {
    /// Folder with the shared meshes (meshes/classic/...) [default: $MESHGAZE_DATA, else
    /// ../shared/data from the current directory, else ../shared/data beside the source tree
    /// meshgaze was built from].
    #[arg(long)]
    pub data: Option<PathBuf>,
    /// Repeat each case this many times and keep the fastest total.
    #[arg(long, default_value_t = 1)]
    pub repeat: usize,
    /// Also write the table as CSV here.
    #[arg(long)]
    pub csv: Option<PathBuf>,
    /// Only this case (bunny-35k, horse-48k, igea-134k, armadillo-subdivided).
    #[arg(long)]
    pub case: Option<String>,
    /// Only this method (sms, mc, ms, si, sri, mr, gr; the priors and the gaze model are not in the
    /// paper's table and are refused): with --case, one cell of the table, timed in its
    /// own process so the peak memory is that method's alone.
    #[arg(long, value_enum)]
    pub method: Option<Method>,
    /// Run the case (without --case: the stimulus) in this process and print its JSON (how
    /// the bench calls itself).
    #[arg(long, hide = true)]
    pub child: bool,
    /// Skip the stimulus benchmark (a 48 s 1680x1050 video of the 50k armadillo, ~30 s).
    #[arg(long)]
    pub skip_stimulus: bool,
}

#[derive(Debug, Serialize, Deserialize)]
struct CaseResult {
    name: String,
    vertices: usize,
    #[serde(deserialize_with = "nan_if_null")]
    a_s: f64,
    #[serde(deserialize_with = "nan_if_null")]
    field_s: f64,
    #[serde(deserialize_with = "nan_if_null")]
    b_s: f64,
    #[serde(deserialize_with = "nan_if_null")]
    c_s: f64,
    #[serde(deserialize_with = "nan_if_null")]
    total_s: f64,
    load_s: f64,
    peak_rss_mb: f64,
    #[serde(deserialize_with = "nan_if_null")]
    paper_total_s: f64,
    /// The paper's Table 3 row this case is compared with.
    paper_row: String,
    /// Other methods' totals: (name, seconds, paper seconds, peak RSS MB of their process).
    baselines: Vec<(String, f64, f64, f64)>,
}

/// A bench case and the row of the paper's Table 3 it is compared with (the nearest in
/// vertex count): case, paper mesh, and the paper's seconds for SMS (total) and each other
/// method in [`COMPETITORS`] order.
const CASES: [(&str, &str, f64, [f64; 6]); 4] = [
    (
        "bunny-35k",
        "Bunny 35k",
        43.5,
        [0.5, 12.2, 13.7, 56.9, 35.8, 43.4],
    ),
    (
        "horse-48k",
        "Dinosaur 56k",
        45.2,
        [1.8, 28.2, 23.6, 100.2, 67.3, 86.3],
    ),
    (
        "igea-134k",
        "Armadillo 172k",
        44.3,
        [2.3, 56.1, 36.5, 245.8, 221.3, 276.2],
    ),
    (
        "armadillo-subdivided",
        "Lucy 604k",
        48.9,
        [7.3, 448.0, 67.4, 1178.2, 912.5, 1264.0],
    ),
];

/// The competitors of the paper's Table 3, in its column order after SMS.
const COMPETITORS: &[Method] = PAPER_METHODS.split_at(1).1;

fn load_case(name: &str, data: &Path) -> Result<Mesh> {
    Ok(match name {
        "bunny-35k" => load_mesh(&data.join("meshes/classic/stanford_bunny/bun_zipper.ply"))?.0,
        "horse-48k" => load_mesh(&data.join("meshes/classic/cyberware/horse.ply"))?.0,
        "igea-134k" => load_mesh(&data.join("meshes/classic/cyberware/igea.ply"))?.0,
        "armadillo-subdivided" => {
            let m =
                load_mesh(&data.join("meshes/classic/decimated_profactor_50k/armadillo.obj"))?.0;
            subdivide_midpoint(&subdivide_midpoint(&m))
        }
        other => bail!("unknown bench case {other}"),
    })
}

/// "28x", or one decimal below 10x so 1.4x is not printed as 1x.
/// JSON writes NaN (a column the case did not measure) as null; read it back as NaN.
fn nan_if_null<'de, D: serde::Deserializer<'de>>(d: D) -> Result<f64, D::Error> {
    Ok(Option::<f64>::deserialize(d)?.unwrap_or(f64::NAN))
}

fn ratio(r: f64) -> String {
    if r < 10.0 {
        format!("{r:.1}x")
    } else {
        format!("{r:.0}x")
    }
}

fn peak_rss_mb() -> f64 {
    std::fs::read_to_string("/proc/self/status")
        .ok()
        .and_then(|s| {
            s.lines()
                .find(|l| l.starts_with("VmHWM:"))
                .and_then(|l| l.split_whitespace().nth(1))
                .and_then(|kb| kb.parse::<f64>().ok())
        })
        .map_or(f64::NAN, |kb| kb / 1024.0)
}

fn run_case(name: &str, data: &Path, repeat: usize, only: Option<Method>) -> Result<CaseResult> {
    let t = std::time::Instant::now();
    let mesh = load_case(name, data)?;
    let load_s = t.elapsed().as_secs_f64();
    let params = SmsParams::default();
    let mut best: Option<CaseResult> = None;
    let sms_runs = if only.is_none_or(|m| m == Method::Sms) {
        repeat.max(1)
    } else {
        0
    };
    for _ in 0..sms_runs {
        let r = sparse_metric_saliency(&mesh, &params, SmsExtras::default(), &Silent)
            .map_err(|e| anyhow::anyhow!(e))?;
        let tm = &r.report.timings;
        let paper = CASES.iter().find(|c| c.0 == name).map_or(f64::NAN, |c| c.2);
        let cr = CaseResult {
            name: name.to_string(),
            vertices: mesh.positions.len(),
            a_s: tm.a_metric_s,
            field_s: tm.a_field_s,
            b_s: tm.b_saliency_s,
            c_s: tm.c_interpolation_s,
            total_s: tm.total_s,
            load_s,
            peak_rss_mb: 0.0,
            paper_total_s: paper,
            paper_row: CASES
                .iter()
                .find(|c| c.0 == name)
                .map_or(String::new(), |c| c.1.to_string()),
            baselines: Vec::new(),
        };
        if best.as_ref().is_none_or(|b| cr.total_s < b.total_s) {
            best = Some(cr);
        }
    }
    let case = CASES.iter().find(|c| c.0 == name);
    let sms_ran = best.is_some();
    if let Some(b) = best.as_mut() {
        // SMS's own peak, before the other methods run in this process.
        b.peak_rss_mb = peak_rss_mb();
    }
    // Without SMS (--method ms, say) its columns are left empty.
    let mut best = best.unwrap_or_else(|| CaseResult {
        name: name.to_string(),
        vertices: mesh.positions.len(),
        a_s: f64::NAN,
        field_s: f64::NAN,
        b_s: f64::NAN,
        c_s: f64::NAN,
        total_s: f64::NAN,
        load_s,
        peak_rss_mb: 0.0,
        paper_total_s: case.map_or(f64::NAN, |c| c.2),
        paper_row: case.map_or(String::new(), |c| c.1.to_string()),
        baselines: Vec::new(),
    });
    if let Some(&(_, _, _, paper_seconds)) = case {
        for (method, paper) in COMPETITORS
            .iter()
            .copied()
            .zip(paper_seconds)
            .filter(|(m, _)| only.is_none_or(|o| o == *m))
        {
            let mut fastest = f64::INFINITY;
            for _ in 0..repeat.max(1) {
                let out = compute_saliency(method, &mesh, &params, &Silent)
                    .map_err(|e| anyhow::anyhow!(e))?;
                fastest = fastest.min(out.seconds);
            }
            best.baselines
                .push((method.name().to_string(), fastest, paper, peak_rss_mb()));
        }
    }
    if !sms_ran {
        // With --method, the one method this process ran.
        best.peak_rss_mb = peak_rss_mb();
    }
    Ok(best)
}

/// The data folder: --data, else the first default place holding meshes/classic; the error
/// lists every place looked in.
fn data_folder(given: Option<&std::path::Path>) -> Result<PathBuf> {
    let candidates: Vec<PathBuf> = match given {
        Some(d) => vec![d.to_path_buf()],
        None => std::env::var_os("MESHGAZE_DATA")
            .map(PathBuf::from)
            .into_iter()
            // Beside the source tree the binary was built from; never the working directory.
            .chain([PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../shared/data")])
            .collect(),
    };
    if let Some(d) = candidates
        .iter()
        .find(|d| d.join("meshes/classic").is_dir())
    {
        return Ok(d.clone());
    }
    let looked: Vec<String> = candidates
        .iter()
        .map(|d| {
            let p = d.join("meshes/classic");
            std::path::absolute(&p).unwrap_or(p).display().to_string()
        })
        .collect();
    bail!(
        "the benchmark meshes were not found; looked for {}: pass --data with the shared data folder (or set MESHGAZE_DATA)",
        looked.join(", ")
    )
}

pub fn run(args: BenchArgs) -> Result<()> {
    let data = data_folder(args.data.as_deref())?;
    if args.child && args.case.is_none() && args.method.is_none() {
        // The stimulus cell (how `bench_stimulus` calls itself); a method without a case
        // is still refused below.
        println!("{}", serde_json::to_string(&stimulus_cell(&data)?)?);
        return Ok(());
    }
    if args.child {
        let case = args.case.as_deref().context("--child needs --case")?;
        let r = run_case(case, &data, args.repeat, args.method)?;
        println!("{}", serde_json::to_string(&r)?);
        return Ok(());
    }
    if let Some(m) = args.method {
        if m != Method::Sms && !COMPETITORS.contains(&m) {
            bail!(
                "bench times the methods of the paper's Table 3 (sms, mc, ms, si, sri, mr, gr), not `{}`; time it with `meshgaze saliency MESH --method {}` (the JSON sidecar records its seconds)",
                m.name(),
                m.name()
            );
        }
    }
    if let Some(case) = &args.case {
        if !CASES.iter().any(|c| c.0 == case) {
            bail!(
                "no bench case `{case}`: the cases are {}",
                CASES.iter().map(|c| c.0).collect::<Vec<_>>().join(", ")
            );
        }
    }
    let exe = std::env::current_exe().context("cannot find the meshgaze executable")?;
    let threads = rayon::current_num_threads();
    let mut rows = Vec::new();
    for (name, ..) in CASES
        .iter()
        .filter(|c| args.case.as_deref().is_none_or(|x| x == c.0))
    {
        // One process per cell, so each cell's peak memory is its own.
        let methods: Vec<Method> = match args.method {
            Some(m) => vec![m],
            None => std::iter::once(Method::Sms)
                .chain(COMPETITORS.iter().copied())
                .collect(),
        };
        let mut row: Option<CaseResult> = None;
        for method in methods {
            eprintln!("bench: {name} / {} ...", method.name());
            let mut cmd = Command::new(&exe);
            cmd.args([
                "bench",
                "--child",
                "--case",
                name,
                "--repeat",
                &args.repeat.to_string(),
                "--method",
                method.name(),
                "--data",
            ])
            .arg(&data);
            let out = cmd.output().context("cannot run the bench case")?;
            if !out.status.success() {
                bail!(
                    "bench case {name} / {} failed: {}",
                    method.name(),
                    String::from_utf8_lossy(&out.stderr)
                );
            }
            let line = String::from_utf8_lossy(&out.stdout);
            let cell = serde_json::from_str::<CaseResult>(line.trim())?;
            row = Some(match row {
                None => cell,
                Some(mut r) => {
                    if method == Method::Sms {
                        let baselines = std::mem::take(&mut r.baselines);
                        r = CaseResult { baselines, ..cell };
                    } else {
                        r.baselines.extend(cell.baselines);
                    }
                    r
                }
            });
        }
        rows.extend(row);
    }
    println!("SMS at the paper's settings (n = 5000, 5 scales, 256³ grid, μ = 0.2, σ = 0.02), {threads} threads:\n");
    println!("| mesh | vertices | A metric (s) | of which field (s) | B saliency (s) | C interpolation (s) | total (s) | paper row | paper total (s) | speed-up | peak RSS (MB) |");
    println!("|---|---:|---:|---:|---:|---:|---:|---|---:|---:|---:|");
    for r in rows.iter().filter(|r| r.total_s.is_finite()) {
        println!(
            "| {} | {} | {:.2} | {:.2} | {:.2} | {:.2} | {:.2} | {} | {:.1} | {:.0}x | {:.0} |",
            r.name,
            r.vertices,
            r.a_s,
            r.field_s,
            r.b_s,
            r.c_s,
            r.total_s,
            r.paper_row,
            r.paper_total_s,
            r.paper_total_s / r.total_s,
            r.peak_rss_mb
        );
    }
    println!("\nEvery method, total seconds (in parentheses: the paper's Table 3 seconds, its seconds / ours, and the cell's peak RSS in MB, each cell in its own process):\n");
    println!("| mesh | vertices | SMS | MC | MS | SI | SRI | MR | GR |");
    println!("|---|---:|---:|---:|---:|---:|---:|---:|---:|");
    for r in &rows {
        let mut line = if r.total_s.is_finite() {
            format!(
                "| {} | {} | {:.2} ({}, {}) |",
                r.name,
                r.vertices,
                r.total_s,
                r.paper_total_s,
                ratio(r.paper_total_s / r.total_s)
            )
        } else {
            format!("| {} | {} | – |", r.name, r.vertices)
        };
        for &m in COMPETITORS {
            match r.baselines.iter().find(|b| b.0 == m.name()) {
                Some((_, secs, paper, peak)) => {
                    line += &format!(
                        " {secs:.3} ({paper}, {}, {peak:.0} MB) |",
                        ratio(paper / secs)
                    )
                }
                None => line += " – |",
            }
        }
        println!("{line}");
    }
    if let Some(m) = args.method {
        for r in &rows {
            println!(
                "\nPeak memory of the cell {} / {}: {:.0} MB (its own process)",
                r.name,
                m.name(),
                r.peak_rss_mb
            );
        }
    }
    // One cell asked for: nothing else.
    if args.case.is_none() && args.method.is_none() {
        bench_smi_parse(&data)?;
        if !args.skip_stimulus {
            bench_stimulus(&exe, &data)?;
        }
    }
    println!(
        "\nLoading (not counted above): {}",
        rows.iter()
            .map(|r| format!("{} {:.2} s", r.name, r.load_s))
            .collect::<Vec<_>>()
            .join(", ")
    );
    if let Some(path) = &args.csv {
        let mut w = String::new();
        w.push_str("mesh,vertices,method,a_s,field_s,b_s,c_s,total_s,paper_row,paper_total_s,peak_rss_mb\n");
        for r in &rows {
            w.push_str(&format!(
                "{},{},sms,{},{},{},{},{},{},{},{}\n",
                r.name,
                r.vertices,
                r.a_s,
                r.field_s,
                r.b_s,
                r.c_s,
                r.total_s,
                r.paper_row,
                r.paper_total_s,
                r.peak_rss_mb
            ));
            for (m, secs, paper, peak) in &r.baselines {
                w.push_str(&format!(
                    "{},{},{m},,,,,{secs},{},{paper},{peak}\n",
                    r.name, r.vertices, r.paper_row
                ));
            }
        }
        std::fs::write(path, w).with_context(|| format!("cannot write {}", path.display()))?;
    }
    Ok(())
}

/// What the stimulus cell measured.
#[derive(Debug, Serialize, Deserialize)]
struct StimulusCell {
    triangles: usize,
    frames: usize,
    width: u32,
    height: u32,
    fps: u32,
    rendered: usize,
    reused: usize,
    render_s: f64,
    encode_s: f64,
    total_s: f64,
    peak_rss_mb: f64,
}

/// The protocol's full 48 s stimulus of the 50k armadillo (~100k triangles), rendered and
/// encoded into a temporary folder, in this process.
fn stimulus_cell(data: &Path) -> Result<StimulusCell> {
    use meshgaze::protocol::Protocol;
    use meshgaze::stimulus::{render_stimulus, FrameImages, StimulusOptions};
    let mesh_path = data.join("meshes/classic/decimated_profactor_50k/armadillo.obj");
    let (protocol, text) = Protocol::builtin();
    let (mesh, _) = load_mesh(&mesh_path)?;
    let out = std::env::temp_dir().join(format!("meshgaze-bench-stimulus-{}", std::process::id()));
    let options = StimulusOptions {
        frames: FrameImages::None,
        id_buffer: false,
        verify: false,
    };
    let m = render_stimulus(
        &mesh_path,
        &mesh,
        &protocol,
        &text,
        meshgaze::protocol::BUILTIN_NAME,
        &out,
        &options,
        &Silent,
    )
    .map_err(anyhow::Error::msg);
    let _ = std::fs::remove_dir_all(&out);
    let m = m?;
    Ok(StimulusCell {
        triangles: mesh.triangles.len(),
        frames: m.video.frames,
        width: m.video.width,
        height: m.video.height,
        fps: m.video.fps,
        rendered: m.timings.frames_rendered,
        reused: m.timings.frames_reused,
        render_s: m.timings.render_s,
        encode_s: m.timings.encode_s,
        total_s: m.timings.total_s,
        peak_rss_mb: peak_rss_mb(),
    })
}

/// The stimulus cell in a process of its own (so its peak memory is the stimulus's alone,
/// not the SMI parse's before it), printed as a table.
fn bench_stimulus(exe: &Path, data: &Path) -> Result<()> {
    eprintln!("bench: stimulus ...");
    let out = Command::new(exe)
        .args(["bench", "--child", "--data"])
        .arg(data)
        .output()
        .context("cannot run the stimulus bench")?;
    if !out.status.success() {
        bail!(
            "the stimulus bench failed: {}",
            String::from_utf8_lossy(&out.stderr)
        );
    }
    let m: StimulusCell = serde_json::from_str(String::from_utf8_lossy(&out.stdout).trim())?;
    println!(
        "\nStimulus (protocols/hu2020.toml) of the 50k armadillo, {} triangles:\n",
        m.triangles
    );
    println!("| frames | size | rendered / reused frames | render (s, thread time summed over the 2 segments) | encode (s, likewise) | total (s) | target (s) | peak RSS (MB) |");
    println!("|---:|---|---|---:|---:|---:|---:|---:|");
    println!(
        "| {} | {}x{} @ {} fps | {} / {} | {:.1} | {:.1} | {:.1} | 16 | {:.0} |",
        m.frames,
        m.width,
        m.height,
        m.fps,
        m.rendered,
        m.reused,
        m.render_s,
        m.encode_s,
        m.total_s,
        m.peak_rss_mb
    );
    Ok(())
}

/// Parse speed of SMI format A: HBN's 7,343-sample export repeated to about 1.1 million
/// samples (times shifted so they keep increasing), read from memory.
fn bench_smi_parse(data: &Path) -> Result<()> {
    let path = data.join("smi/hbn-sccn__NDARAA075AMK_Video1_Samples.txt");
    let text = std::fs::read_to_string(&path)
        .with_context(|| format!("cannot read {}", path.display()))?;
    let split_at = text
        .find("\nTime\t")
        .map(|i| i + 1)
        .context("no column header")?;
    let body_start = split_at + text[split_at..].find('\n').context("no data")? + 1;
    let (head, body) = text.split_at(body_start);
    let rows: Vec<&str> = body.lines().filter(|l| l.contains("\tSMP\t")).collect();
    let mut big = String::with_capacity(text.len() * 160);
    big.push_str(head);
    let mut t: i64 = 1_000_000;
    for _ in 0..150 {
        for r in &rows {
            let (_, rest) = r.split_once('\t').context("row")?;
            t += 16_667;
            big.push_str(&t.to_string());
            big.push('\t');
            big.push_str(rest);
            big.push('\n');
        }
    }
    let start = std::time::Instant::now();
    let rec =
        meshgaze::gaze::parse_smi(big.as_bytes(), "bench", None).map_err(anyhow::Error::msg)?;
    let secs = start.elapsed().as_secs_f64();
    println!(
        "\nSMI format A parse (HBN samples repeated, {:.0} MB in memory): {} samples in {:.2} s = {:.2} million samples/s (target 1)",
        big.len() as f64 / 1e6,
        rec.samples.len(),
        secs,
        rec.samples.len() as f64 / secs / 1e6
    );
    Ok(())
}
