use std::ffi::OsStr;
use std::path::{Path, PathBuf};

use anyhow::{bail, Context, Result};
use clap::Args;

use meshgaze::experiments::timing::{
    eyelink_parse_speed, gaze_features_cell, paper_case, run_case, run_cell_in_child, scoring_cell,
    smi_parse_speed, stimulus_cell, table_parse_speeds, CaseResult, StimulusCell, COMPETITORS,
    PAPER_CASES, PARSE_RUNS,
};
use meshgaze::saliency::Method;

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
    /// Only the recording readers' parse speed (SMI format A, EyeLink ASC, Tobii Pro Lab,
    /// Gazepoint, Pupil Core surface; each against SMI A per sample, the fastest of three
    /// parses, the first one's time beside it), about ten seconds. SMI A parses chunks of rows
    /// on every core, the table readers (Tobii, Gazepoint, Pupil) scan on a second thread,
    /// EyeLink uses one: `RAYON_NUM_THREADS=1 meshgaze bench --parse-only` times each on one.
    #[arg(long, conflicts_with_all = ["case", "method", "csv"])]
    pub parse_only: bool,
    /// Only the scoring row: the 50k armadillo's seven maps scored against an 8-subject,
    /// 120-fixation truth as a study scores them (about half a minute with the maps).
    #[arg(long, conflicts_with_all = ["case", "method", "csv", "parse_only"])]
    pub scoring_only: bool,
    /// Only the gaze model's row: the seconds of each feature group and of the trees on the
    /// 20k-vertex VR bunny (fixations-vr/meshes/bunny.obj.gz), a few seconds.
    #[arg(long, conflicts_with_all = ["case", "method", "csv", "parse_only", "scoring_only"])]
    pub gaze_only: bool,
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
    if args.child {
        return run_child(&args, &data);
    }
    if args.parse_only {
        return print_smi_parse(&data);
    }
    if args.scoring_only {
        return print_scoring(&data).map(|_| ());
    }
    if args.gaze_only {
        return print_gaze_features(&data);
    }
    check_cell(&args)?;
    let exe = std::env::current_exe().context("cannot find the meshgaze executable")?;
    let rows = measure_cases(&args, &exe, &data)?;
    print_sms_table(&rows);
    print_methods_table(&rows);
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
        print_smi_parse(&data)?;
        print_gaze_features(&data)?;
        let scoring = print_scoring(&data)?;
        if !args.skip_stimulus {
            let stimulus_s = print_stimulus(&exe, &data)?;
            print_study_estimate(scoring, stimulus_s);
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
        std::fs::write(path, cases_csv(&rows))
            .with_context(|| format!("cannot write {}", path.display()))?;
    }
    Ok(())
}

/// How the bench calls itself: one cell measured in this process, printed as JSON.
fn run_child(args: &BenchArgs, data: &Path) -> Result<()> {
    let json = match (&args.case, args.method) {
        // The stimulus cell; a method without a case is still refused below.
        (None, None) => serde_json::to_string(&stimulus_cell(data)?)?,
        (Some(case), method) => serde_json::to_string(&run_case(case, data, args.repeat, method)?)?,
        (None, Some(_)) => bail!("--child needs --case"),
    };
    println!("{json}");
    Ok(())
}

/// Refuses a --method outside the paper's table and an unknown --case, before any work.
fn check_cell(args: &BenchArgs) -> Result<()> {
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
        paper_case(case)?;
    }
    Ok(())
}

/// Every asked-for case, each (case, method) cell in its own process so each cell's peak
/// memory is its own, merged into one row per case.
fn measure_cases(args: &BenchArgs, exe: &Path, data: &Path) -> Result<Vec<CaseResult>> {
    let methods: Vec<Method> = match args.method {
        Some(m) => vec![m],
        None => std::iter::once(Method::Sms)
            .chain(COMPETITORS.iter().copied())
            .collect(),
    };
    let repeat = args.repeat.to_string();
    let mut rows = Vec::new();
    for case in PAPER_CASES
        .iter()
        .filter(|c| args.case.as_deref().is_none_or(|x| x == c.name))
    {
        let mut row: Option<CaseResult> = None;
        for &method in &methods {
            eprintln!("bench: {} / {} ...", case.name, method.name());
            let words = [
                "bench",
                "--child",
                "--case",
                case.name,
                "--repeat",
                &repeat,
                "--method",
                method.name(),
                "--data",
            ];
            let cell_args: Vec<&OsStr> = words
                .iter()
                .map(OsStr::new)
                .chain([data.as_os_str()])
                .collect();
            let what = format!("bench case {} / {}", case.name, method.name());
            let cell: CaseResult = run_cell_in_child(exe, &cell_args, &what)?;
            row = Some(match row {
                None => cell,
                Some(r) if method == Method::Sms => CaseResult {
                    baselines: r.baselines,
                    ..cell
                },
                Some(mut r) => {
                    r.baselines.extend(cell.baselines);
                    r
                }
            });
        }
        rows.extend(row);
    }
    Ok(rows)
}

/// "28x", or one decimal below 10x so 1.4x is not printed as 1x.
fn ratio(r: f64) -> String {
    if r < 10.0 {
        format!("{r:.1}x")
    } else {
        format!("{r:.0}x")
    }
}

fn print_sms_table(rows: &[CaseResult]) {
    let threads = rayon::current_num_threads();
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
}

fn print_methods_table(rows: &[CaseResult]) {
    println!("\nEvery method, total seconds (in parentheses: the paper's Table 3 seconds, its seconds / ours, and the cell's peak RSS in MB, each cell in its own process):\n");
    println!("| mesh | vertices | SMS | MC | MS | SI | SRI | MR | GR |");
    println!("|---|---:|---:|---:|---:|---:|---:|---:|---:|");
    for r in rows {
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
}

fn cases_csv(rows: &[CaseResult]) -> String {
    let mut w = String::new();
    w.push_str(
        "mesh,vertices,method,a_s,field_s,b_s,c_s,total_s,paper_row,paper_total_s,peak_rss_mb\n",
    );
    for r in rows {
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
    w
}

/// The stimulus cell in a process of its own (so its peak memory is the stimulus's alone,
/// not the SMI parse's before it), printed as a table.
fn print_stimulus(exe: &Path, data: &Path) -> Result<f64> {
    eprintln!("bench: stimulus ...");
    let cell_args = [
        OsStr::new("bench"),
        OsStr::new("--child"),
        OsStr::new("--data"),
        data.as_os_str(),
    ];
    let m: StimulusCell = run_cell_in_child(exe, &cell_args, "the stimulus bench")?;
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
    Ok(m.total_s)
}

/// The scoring row; returns the seconds of the seven maps and of scoring them.
fn print_scoring(data: &Path) -> Result<(f64, f64)> {
    eprintln!("bench: scoring ...");
    let c = scoring_cell(data)?;
    println!(
        "\nScoring the 50k armadillo ({} vertices) as a study does: {} maps (computed in {:.1} s, not counted), {} fixations of {} subjects, {} blur scales, {} chance draws, split-half human ceiling: {:.1} s",
        c.vertices, c.maps, c.maps_s, c.fixations, c.subjects, c.blur_scales, c.chance_draws, c.score_s
    );
    Ok((c.maps_s, c.score_s))
}

/// The gaze model's cost by feature group, so a lab can weigh what each group buys.
fn print_gaze_features(data: &Path) -> Result<()> {
    eprintln!("bench: gaze model features ...");
    let c = gaze_features_cell(data)?;
    let total: f64 = c.groups.iter().map(|g| g.1).sum::<f64>() + c.predict_s;
    println!(
        "\nGaze model on the VR bunny ({} vertices), by feature group: {}, trees {:.3} s; {:.2} s in all (loading not counted)",
        c.vertices,
        c.groups
            .iter()
            .map(|(g, s)| format!("{g} {s:.3} s"))
            .collect::<Vec<_>>()
            .join(", "),
        c.predict_s,
        total
    );
    Ok(())
}

/// A 50-mesh study of 50k-vertex meshes on this machine, from the rows above: per mesh its
/// stimulus, seven maps and scoring (projection and truth take well under a second each),
/// each step already spreads over every core, so the per-mesh sum is the study's wall time
/// whatever --jobs splits it into.
fn print_study_estimate((maps_s, score_s): (f64, f64), stimulus_s: f64) {
    let per_mesh = stimulus_s + maps_s + score_s;
    println!(
        "\nA 50-mesh study of 50k-vertex meshes, estimated from these rows: 50 x ({stimulus_s:.1} s stimulus + {maps_s:.1} s seven maps + {score_s:.1} s scoring) = {:.0} s ({:.1} min) of wall time here (each step already uses every core)",
        50.0 * per_mesh,
        50.0 * per_mesh / 60.0
    );
}

/// The readers' parse speed, per sample, at the same scale (about 1.1 million samples each).
fn print_smi_parse(data: &Path) -> Result<()> {
    let s = smi_parse_speed(data)?;
    println!(
        "\nEach parse is the fastest of {PARSE_RUNS} runs on the same bytes; the first run, which takes its memory fresh from the system, is in brackets. Threads: {} ({}).\nSMI format A parse (HBN samples repeated, {:.0} MB in memory): {} samples in {:.2} s [{:.2} s] = {:.2} million samples/s (target 1)",
        rayon::current_num_threads(),
        if rayon::current_num_threads() > 1 {
            "SMI A parses chunks of rows on all of them, the table readers scan on a second thread, EyeLink uses one; RAYON_NUM_THREADS=1 times each on one"
        } else {
            "every reader on one"
        },
        s.bytes as f64 / 1e6,
        s.samples,
        s.seconds,
        s.first_seconds,
        s.samples as f64 / s.seconds / 1e6
    );
    let e = eyelink_parse_speed(data)?;
    println!(
        "EyeLink ASC parse (syelink samples repeated, {:.0} MB in memory): {} samples in {:.2} s [{:.2} s] = {:.2} million samples/s ({:.2}x SMI format A per sample)",
        e.bytes as f64 / 1e6,
        e.samples,
        e.seconds,
        e.first_seconds,
        e.samples as f64 / e.seconds / 1e6,
        (e.samples as f64 / e.seconds) / (s.samples as f64 / s.seconds)
    );
    for (what, t) in table_parse_speeds(data)? {
        println!(
            "{what} parse (its real export's rows repeated, {:.0} MB in memory): {} rows in {:.2} s [{:.2} s] = {:.2} million rows/s ({:.2}x SMI format A per sample)",
            t.bytes as f64 / 1e6,
            t.samples,
            t.seconds,
            t.first_seconds,
            t.samples as f64 / t.seconds / 1e6,
            (t.samples as f64 / t.seconds) / (s.samples as f64 / s.seconds)
        );
    }
    Ok(())
}
