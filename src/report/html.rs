//! Pieces shared by the HTML reports: escaping, inlined PNGs, number formatting.
use std::path::Path;

use anyhow::{Context, Result};
use base64::Engine;
use image::RgbImage;

/// Escapes text for HTML content and attribute values.
pub fn esc(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

pub fn png_data_uri(img: &RgbImage) -> Result<String> {
    let mut bytes = Vec::new();
    img.write_to(
        &mut std::io::Cursor::new(&mut bytes),
        image::ImageFormat::Png,
    )?;
    Ok(format!(
        "data:image/png;base64,{}",
        base64::engine::general_purpose::STANDARD.encode(bytes)
    ))
}

pub fn file_data_uri(path: &Path) -> Result<String> {
    let bytes = std::fs::read(path).with_context(|| format!("cannot read {}", path.display()))?;
    Ok(format!(
        "data:image/png;base64,{}",
        base64::engine::general_purpose::STANDARD.encode(bytes)
    ))
}

pub fn thumbnail(img: &RgbImage, width: u32) -> RgbImage {
    let h = (img.height() as f64 * width as f64 / img.width() as f64).round() as u32;
    image::imageops::resize(img, width, h, image::imageops::FilterType::Triangle)
}

/// Three decimals, or an en dash for NaN.
pub fn fmt3(v: f64) -> String {
    if v.is_finite() {
        format!("{v:.3}")
    } else {
        "–".into()
    }
}
