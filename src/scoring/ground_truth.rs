//! What a map is scored against: a per-vertex human map or a set of fixated vertices with
//! their subjects. Plain data; `truth` reads and builds them.
use std::collections::BTreeMap;

use serde::Serialize;

/// A per-vertex human map.
#[derive(Debug, Clone, Serialize)]
pub struct VertexTruth {
    /// One value per vertex, in mesh order.
    pub values: Vec<f64>,
    /// Vertices counted as fixated for AUC and NSS.
    pub positive: Vec<bool>,
    /// How `positive` was decided.
    pub positive_rule: String,
}

/// One fixation on the mesh: who made it and the vertex it landed on.
#[derive(Debug, Clone, Serialize, PartialEq, Eq)]
pub struct Fixation {
    /// The subject's id.
    pub subject: String,
    /// The vertex, an index into the mesh's positions.
    pub vertex: usize,
}

/// Fixations with subject ids, already projected to vertices.
#[derive(Debug, Clone, Serialize)]
pub struct FixationTruth {
    /// The fixations on the mesh, in file order.
    pub fixations: Vec<Fixation>,
    /// Subject ids in first-seen order.
    pub subjects: Vec<String>,
    /// Rows read, on the mesh or not.
    pub rows: usize,
    /// Rows whose `fate` says the fixation did not land on the mesh, by fate.
    pub rows_not_on_mesh: BTreeMap<String, usize>,
}

/// What a map is scored against.
#[derive(Debug, Clone, Serialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum GroundTruth {
    /// A per-vertex human map.
    VertexMap(VertexTruth),
    /// Fixations with their subjects (gives the human ceiling).
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
