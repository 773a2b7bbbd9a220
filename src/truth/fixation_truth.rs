//! The fixation set of projected rows.
use std::collections::BTreeMap;

use super::{Fixation, FixationTruth};

/// The fixation set of projected rows (hit and snapped fixations; the rest counted by fate).
pub fn fixation_truth_from_rows(rows: &[crate::projection::table::ProjectedRow]) -> FixationTruth {
    let mut subjects: Vec<String> = Vec::new();
    let mut fixations = Vec::new();
    let mut rows_not_on_mesh: BTreeMap<String, usize> = BTreeMap::new();
    for r in rows {
        match (r.fate().is_some_and(|f| f.on_mesh()), r.vertex) {
            (true, Some(v)) => {
                if !subjects.contains(&r.subject) {
                    subjects.push(r.subject.clone());
                }
                fixations.push(Fixation {
                    subject: r.subject.clone(),
                    vertex: v,
                });
            }
            _ => *rows_not_on_mesh.entry(r.fate.clone()).or_insert(0) += 1,
        }
    }
    FixationTruth {
        fixations,
        subjects,
        rows: rows.len(),
        rows_not_on_mesh,
    }
}
