//! Pieces shared by the HTML reports: escaping, inlined PNGs, number formatting.
use std::path::Path;

use base64::Engine;
use image::RgbImage;

use super::ReportError;

/// Escapes text for HTML content and attribute values.
pub fn esc(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

/// An image as a `data:` URI of its PNG bytes, so a page needs no other file.
pub fn png_data_uri(img: &RgbImage) -> Result<String, ReportError> {
    let mut bytes = Vec::new();
    img.write_to(
        &mut std::io::Cursor::new(&mut bytes),
        image::ImageFormat::Png,
    )
    .map_err(ReportError::chart)?;
    Ok(format!(
        "data:image/png;base64,{}",
        base64::engine::general_purpose::STANDARD.encode(bytes)
    ))
}

/// A PNG file on disk as a `data:` URI.
pub fn file_data_uri(path: &Path) -> Result<String, ReportError> {
    let bytes = std::fs::read(path).map_err(ReportError::io("read", path))?;
    Ok(format!(
        "data:image/png;base64,{}",
        base64::engine::general_purpose::STANDARD.encode(bytes)
    ))
}

/// `img` scaled to `width` pixels wide.
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
