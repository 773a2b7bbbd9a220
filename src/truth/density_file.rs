use std::path::Path;

use super::TruthError;

/// The `density` column of a truth folder's density.csv (as `meshgaze truth` and a study
/// write it), one value per vertex of a mesh of `n` vertices.
pub fn read_density(path: &Path, n: usize) -> Result<Vec<f64>, TruthError> {
    let file_error = |message: String| TruthError::File {
        path: path.to_path_buf(),
        message,
    };
    let mut r = csv::Reader::from_path(path).map_err(|e| file_error(e.to_string()))?;
    let col = r
        .headers()
        .map_err(|e| file_error(e.to_string()))?
        .iter()
        .position(|h| h == "density")
        .ok_or_else(|| file_error("no `density` column".to_string()))?;
    let mut values = Vec::with_capacity(n);
    for (i, rec) in r.records().enumerate() {
        let rec = rec.map_err(|e| file_error(e.to_string()))?;
        let field = rec.get(col).unwrap_or("");
        let value = field.parse::<f64>().map_err(|_| TruthError::At {
            path: path.to_path_buf(),
            line: i + 2,
            column: col + 1,
            message: format!("`{field}` is not a number"),
        })?;
        values.push(value);
    }
    if values.len() != n {
        return Err(file_error(format!(
            "{} rows for a mesh of {n} vertices",
            values.len()
        )));
    }
    Ok(values)
}
