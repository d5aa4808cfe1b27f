//! Writing a figure as PNG or SVG, chosen by the output file's extension. A figure draws on
//! a plotters drawing area of any backend ([`Figure::draw`]), so the same code makes both.

use std::path::Path;

use plotters::coord::Shift;
use plotters::prelude::*;

use crate::error::PlotError;

/// The image formats.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Format {
    /// Raster (`.png`).
    Png,
    /// Vector (`.svg`).
    Svg,
}

impl Format {
    /// The format of `path` from its extension (case-insensitive).
    pub fn of(path: &Path) -> Result<Format, PlotError> {
        match path.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase).as_deref() {
            Some("png") => Ok(Format::Png),
            Some("svg") => Ok(Format::Svg),
            _ => Err(PlotError::Usage(format!(
                "--out {}: the file name must end in .png or .svg (the format follows the extension)",
                path.display()
            ))),
        }
    }
}

/// Something that can be drawn: its size in pixels and its drawing on an area.
pub trait Figure {
    /// Width and height in pixels (SVG user units).
    fn size(&self) -> (u32, u32);

    /// Draws the figure on `root` (already filled white).
    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> Result<(), PlotError>;
}

/// The error of a drawing operation, as a message.
pub fn draw_err<E: std::error::Error + Send + Sync>(e: DrawingAreaErrorKind<E>) -> PlotError {
    PlotError::Draw(e.to_string())
}

/// Draws `fig` into `path` (PNG or SVG by the extension); creates the parent directory.
pub fn render<F: Figure>(fig: &F, path: &Path) -> Result<(), PlotError> {
    let format = Format::of(path)?;
    crate::font::ensure_registered()?;
    if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir)
            .map_err(|e| PlotError::Output { path: path.to_path_buf(), message: e.to_string() })?;
    }
    // The file must be writable: say so with the operating system's reason before drawing
    // (the image encoder's own error is a debug dump of nested types).
    std::fs::OpenOptions::new()
        .write(true)
        .create(true)
        .truncate(true)
        .open(path)
        .map_err(|e| PlotError::Output { path: path.to_path_buf(), message: e.to_string() })?;
    let out_err = |e: PlotError| PlotError::Output { path: path.to_path_buf(), message: readable(&e.to_string()) };
    let size = fig.size();
    match format {
        Format::Png => {
            let root = BitMapBackend::new(path, size).into_drawing_area();
            root.fill(&WHITE).map_err(draw_err).map_err(out_err)?;
            fig.draw(&root)?;
            root.present().map_err(draw_err).map_err(out_err)
        }
        Format::Svg => {
            let root = SVGBackend::new(path, size).into_drawing_area();
            root.fill(&WHITE).map_err(draw_err).map_err(out_err)?;
            fig.draw(&root)?;
            root.present().map_err(draw_err).map_err(out_err)
        }
    }
}

/// A backend error's text without the debug dump some backends give (`ImageError(IoError(Os
/// { code: 28, kind: StorageFull, message: "No space left on device" }))` becomes `No space
/// left on device`).
fn readable(text: &str) -> String {
    match text.split_once("message: \"").and_then(|(_, rest)| rest.split_once('"')) {
        Some((message, _)) => message.to_string(),
        None => text.to_string(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn backend_errors_read_as_the_reason() {
        let dump = r#"Drawing backend error: ImageError(IoError(Os { code: 28, kind: StorageFull, message: "No space left on device" }))"#;
        assert_eq!(readable(dump), "No space left on device");
        assert_eq!(readable("drawing failed: bad range"), "drawing failed: bad range");
    }
}
