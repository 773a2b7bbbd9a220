//! The score charts: AUC-Judd over blur with chance and the human ceiling, and the Lorenz
//! curves of the maps with their Gini index.
use std::path::{Path, PathBuf};

use plotters::style::RGBColor;

use super::plot::{line_chart_png, Chart, Series, PALETTE};
use super::ReportError;
use crate::scoring::{gini_index, lorenz_curve, MeshScore, CHANCE, CHANCE_HIGH, CHANCE_LOW, HUMAN};

/// AUC-Judd over blur (methods, chance dashed, human ceiling in black) and Lorenz curves of
/// the unblurred maps with their Gini index.
pub fn write_score_plots(
    prefix: &Path,
    mesh: &str,
    maps: &[(String, Vec<f64>)],
    score: &MeshScore,
) -> Result<Vec<String>, ReportError> {
    let curve = |method: &str, metric: &str| -> Vec<(f64, f64)> {
        score
            .rows
            .iter()
            .filter(|r| r.method == method && r.metric == metric && r.value.is_finite())
            .map(|r| (r.blur, r.value))
            .collect()
    };
    let methods = maps
        .iter()
        .map(|(name, _)| (name.clone(), curve(name, "auc_judd")))
        .collect();
    let chance = curve(CHANCE, "auc_judd")
        .iter()
        .zip(curve(CHANCE_LOW, "auc_judd"))
        .zip(curve(CHANCE_HIGH, "auc_judd"))
        .map(|((m, l), h)| (m.0, m.1, l.1, h.1))
        .collect();
    let series = auc_series(
        methods,
        "chance: mean and 95% of random maps",
        chance,
        curve(HUMAN, "auc_judd"),
    );
    let auc_path = PathBuf::from(format!("{}.{mesh}.auc.png", prefix.display()));
    auc_chart_png(&auc_path, &format!("{mesh}: AUC-Judd vs blur"), &series)?;
    let mut lorenz = vec![Series {
        name: "uniform (Gini 0)".into(),
        points: vec![(0.0, 0.0), (1.0, 1.0)],
        color: RGBColor(128, 128, 128),
        dashed: true,
        band: Vec::new(),
    }];
    for (k, (name, values)) in maps.iter().enumerate() {
        let clipped: Vec<f64> = values.iter().map(|v| v.max(0.0)).collect();
        if let Some(points) = lorenz_curve(&clipped) {
            // At most ~500 points: enough for the eye.
            let step = (points.len() / 500).max(1);
            let mut thin: Vec<(f64, f64)> = points.iter().step_by(step).copied().collect();
            thin.push(*points.last().expect("non-empty"));
            lorenz.push(Series {
                name: format!("{name} (Gini {:.3})", gini_index(&clipped)),
                points: thin,
                color: PALETTE[k % PALETTE.len()],
                dashed: false,
                band: Vec::new(),
            });
        }
    }
    let lorenz_path = PathBuf::from(format!("{}.{mesh}.lorenz.png", prefix.display()));
    line_chart_png(
        &lorenz_path,
        &Chart {
            title: &format!("{mesh}: Lorenz curves of the saliency maps"),
            x_label: "fraction of vertices, least salient first",
            y_label: "fraction of total saliency",
            x_range: (0.0, 1.0),
            y_range: (0.0, 1.0),
        },
        &lorenz,
    )?;
    Ok(vec![
        auc_path.display().to_string(),
        lorenz_path.display().to_string(),
    ])
}

/// The series of an AUC-over-blur chart: each method in its palette colour, chance
/// (σ_b, mean, low, high) dashed grey over its shaded band, and the human ceiling in black
/// when there is one.
pub fn auc_series(
    methods: Vec<(String, Vec<(f64, f64)>)>,
    chance_name: &str,
    chance: Vec<(f64, f64, f64, f64)>,
    human: Vec<(f64, f64)>,
) -> Vec<Series> {
    let mut series: Vec<Series> = methods
        .into_iter()
        .enumerate()
        .map(|(k, (name, points))| Series {
            name,
            points,
            color: PALETTE[k % PALETTE.len()],
            dashed: false,
            band: Vec::new(),
        })
        .collect();
    series.push(Series {
        name: chance_name.into(),
        points: chance.iter().map(|c| (c.0, c.1)).collect(),
        color: RGBColor(128, 128, 128),
        dashed: true,
        band: chance.iter().map(|c| (c.0, c.2, c.3)).collect(),
    });
    if !human.is_empty() {
        series.push(Series {
            name: "human (split-half)".into(),
            points: human,
            color: RGBColor(0, 0, 0),
            dashed: false,
            band: Vec::new(),
        });
    }
    series
}

/// Writes an AUC-over-blur chart: y from just below the lowest point or band edge to 1.
pub fn auc_chart_png(path: &Path, title: &str, series: &[Series]) -> Result<(), ReportError> {
    let lowest = series
        .iter()
        .flat_map(|s| {
            s.points
                .iter()
                .map(|p| p.1)
                .chain(s.band.iter().map(|b| b.1))
        })
        .fold(0.5f64, f64::min);
    let x_max = series
        .iter()
        .flat_map(|s| s.points.iter().map(|p| p.0))
        .fold(0.01f64, f64::max);
    line_chart_png(
        path,
        &Chart {
            title,
            x_label: "blur σ_b (normalized units)",
            y_label: "AUC-Judd",
            x_range: (0.0, x_max),
            y_range: ((lowest - 0.05).max(0.0), 1.0),
        },
        series,
    )
}
