//! What a map is scored against: a per-vertex human map or a set of fixated vertices with
//! their subjects. Plain data; `truth` reads and builds them.
use std::collections::BTreeMap;

use serde::Serialize;

/// A per-vertex human map.
#[derive(Debug, Clone, Serialize)]
pub struct VertexTruth {
    pub values: Vec<f64>,
    /// Vertices counted as fixated for AUC and NSS.
    pub positive: Vec<bool>,
    /// How `positive` was decided.
    pub positive_rule: String,
}

#[derive(Debug, Clone, Serialize, PartialEq, Eq)]
pub struct Fixation {
    pub subject: String,
    pub vertex: usize,
}

/// Fixations with subject ids, already projected to vertices.
#[derive(Debug, Clone, Serialize)]
pub struct FixationTruth {
    pub fixations: Vec<Fixation>,
    /// Subject ids in first-seen order.
    pub subjects: Vec<String>,
    pub rows: usize,
    /// Rows whose `fate` says the fixation did not land on the mesh, by fate.
    pub rows_not_on_mesh: BTreeMap<String, usize>,
}

#[derive(Debug, Clone, Serialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum GroundTruth {
    VertexMap(VertexTruth),
    Fixations(FixationTruth),
}

impl GroundTruth {
    /// Vertices counted as fixated (each once).
    pub fn positive(&self, n: usize) -> Vec<bool> {
        match self {
            GroundTruth::VertexMap(m) => m.positive.clone(),
            GroundTruth::Fixations(f) => {
                let mut p = vec![false; n];
                for x in &f.fixations {
                    p[x.vertex] = true;
                }
                p
            }
        }
    }

    /// Fixated vertices with multiplicity (for NSS and AUC-Borji).
    pub fn fixated(&self) -> Vec<usize> {
        match self {
            GroundTruth::VertexMap(m) => (0..m.positive.len()).filter(|&i| m.positive[i]).collect(),
            GroundTruth::Fixations(f) => f.fixations.iter().map(|x| x.vertex).collect(),
        }
    }
}
