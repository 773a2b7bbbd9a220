//! The score charts: AUC-Judd over blur with chance and the human ceiling, and the Lorenz
//! curves of the maps with their Gini index.
use std::path::{Path, PathBuf};

use anyhow::Result;
use plotters::style::RGBColor;

use super::plot::{line_chart_png, Chart, Series, PALETTE};
use crate::scoring::{gini_index, lorenz_curve, MeshScore, CHANCE, CHANCE_HIGH, CHANCE_LOW, HUMAN};

/// AUC-Judd over blur (methods, chance dashed, human ceiling in black) and Lorenz curves of
/// the unblurred maps with their Gini index.
pub fn write_score_plots(
    prefix: &Path,
    mesh: &str,
    maps: &[(String, Vec<f64>)],
    score: &MeshScore,
) -> Result<Vec<String>> {
    let curve = |method: &str, metric: &str| -> Vec<(f64, f64)> {
        score
            .rows
            .iter()
            .filter(|r| r.method == method && r.metric == metric && r.value.is_finite())
            .map(|r| (r.blur, r.value))
            .collect()
    };
    let mut series: Vec<Series> = maps
        .iter()
        .enumerate()
        .map(|(k, (name, _))| Series {
            name: name.clone(),
            points: curve(name, "auc_judd"),
            color: PALETTE[k % PALETTE.len()],
            dashed: false,
            band: Vec::new(),
        })
        .collect();
    let (low, high) = (
        curve(CHANCE_LOW, "auc_judd"),
        curve(CHANCE_HIGH, "auc_judd"),
    );
    series.push(Series {
        name: "chance: mean and 95% of random maps".into(),
        points: curve(CHANCE, "auc_judd"),
        color: RGBColor(128, 128, 128),
        dashed: true,
        band: low
            .iter()
            .zip(&high)
            .map(|(l, h)| (l.0, l.1, h.1))
            .collect(),
    });
    let human = curve(HUMAN, "auc_judd");
    if !human.is_empty() {
        series.push(Series {
            name: "human (split-half)".into(),
            points: human,
            color: RGBColor(0, 0, 0),
            dashed: false,
            band: Vec::new(),
        });
    }
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
    let auc_path = PathBuf::from(format!("{}.{mesh}.auc.png", prefix.display()));
    line_chart_png(
        &auc_path,
        &Chart {
            title: &format!("{mesh}: AUC-Judd vs blur"),
            x_label: "blur σ_b (normalized units)",
            y_label: "AUC-Judd",
            x_range: (0.0, x_max),
            y_range: ((lowest - 0.05).max(0.0), 1.0),
        },
        &series,
    )
    .map_err(anyhow::Error::msg)?;
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
    )
    .map_err(anyhow::Error::msg)?;
    Ok(vec![
        auc_path.display().to_string(),
        lorenz_path.display().to_string(),
    ])
}
