//! What became of each fixation, and the counts by fate.
use serde::{Deserialize, Serialize};

use super::table;

/// What became of a fixation.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize)]
#[cfg_attr(feature = "cli", derive(clap::ValueEnum))]
#[serde(rename_all = "kebab-case")]
pub enum ProjectionFate {
    /// The ray hit the mesh.
    Hit,
    /// The ray missed, and the nearest visible surface within the tracker's accuracy was used.
    Snapped,
    /// The ray missed the mesh (the fixation was on the background).
    Background,
    /// Outside the screen, or on a letterbox bar outside the video picture.
    OffScreen,
    /// Overlapped a camera move while the protocol rejects those.
    InTransition,
    /// No usable position, or a time outside the video.
    Invalid,
    /// Removed by the protocol's fixation filter before projection.
    Filtered,
}

impl ProjectionFate {
    /// Every fate, in the order tables list them.
    pub const ALL: [ProjectionFate; 7] = [
        ProjectionFate::Hit,
        ProjectionFate::Snapped,
        ProjectionFate::Background,
        ProjectionFate::OffScreen,
        ProjectionFate::InTransition,
        ProjectionFate::Invalid,
        ProjectionFate::Filtered,
    ];

    /// The name projected.csv writes.
    pub fn name(self) -> &'static str {
        match self {
            ProjectionFate::Hit => "hit",
            ProjectionFate::Snapped => "snapped",
            ProjectionFate::Background => "background",
            ProjectionFate::OffScreen => "off-screen",
            ProjectionFate::InTransition => "in-transition",
            ProjectionFate::Invalid => "invalid",
            ProjectionFate::Filtered => "filtered",
        }
    }

    /// The fate of a name, as [`ProjectionFate::name`] writes it.
    pub fn parse(s: &str) -> Option<ProjectionFate> {
        ProjectionFate::ALL.into_iter().find(|f| f.name() == s)
    }

    /// Whether the fixation has a vertex on the mesh.
    pub fn on_mesh(self) -> bool {
        matches!(self, ProjectionFate::Hit | ProjectionFate::Snapped)
    }
}

/// Counts by fate, every fate present (zeros included), in [`ProjectionFate::ALL`] order.
pub fn count_fates<'a>(
    fates: impl IntoIterator<Item = &'a ProjectionFate>,
) -> Vec<(ProjectionFate, usize)> {
    let mut counts: Vec<(ProjectionFate, usize)> =
        ProjectionFate::ALL.iter().map(|&f| (f, 0)).collect();
    for f in fates {
        if let Some(c) = counts.iter_mut().find(|c| c.0 == *f) {
            c.1 += 1;
        }
    }
    counts
}

/// Fates of projected rows counted by fate name (every fate present, zero or not); rows without
/// a readable fate are not counted.
pub fn fate_counts_by_name<'a>(
    rows: impl IntoIterator<Item = &'a table::ProjectedRow>,
) -> std::collections::BTreeMap<&'static str, usize> {
    let fates: Vec<ProjectionFate> = rows.into_iter().filter_map(|r| r.fate()).collect();
    count_fates(fates.iter())
        .into_iter()
        .map(|(f, c)| (f.name(), c))
        .collect()
}

/// Fates per subject as a plain-text table (one line per subject, then the totals).
pub fn fate_table_text(
    fates: &std::collections::BTreeMap<String, std::collections::BTreeMap<&'static str, usize>>,
    totals: &std::collections::BTreeMap<&'static str, usize>,
) -> String {
    let names: Vec<&str> = ProjectionFate::ALL.iter().map(|f| f.name()).collect();
    let mut text = format!("{:<10}", "subject");
    for n in &names {
        text += &format!(" {n:>13}");
    }
    text.push('\n');
    let mut row = |label: &str, c: &std::collections::BTreeMap<&'static str, usize>| {
        text += &format!("{label:<10}");
        for n in &names {
            text += &format!(" {:>13}", c.get(n).copied().unwrap_or(0));
        }
        text.push('\n');
    };
    for (s, c) in fates {
        row(s, c);
    }
    row("total", totals);
    text
}
