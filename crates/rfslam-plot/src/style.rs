//! Shared look of the figures: font sizes readable when a 1200-pixel-wide figure is printed
//! at the width of a page, a colour-blind-safe palette (Okabe and Ito), and data bounds with
//! equal axis scaling for maps.

use plotters::chart::MeshStyle;
use plotters::coord::ranged1d::Ranged;
use plotters::prelude::DrawingBackend;
use plotters::style::{RGBColor, TextStyle, WHITE};

use crate::font::FAMILY;

/// A chart's mesh in the look of every figure: axis descriptions and tick labels in the
/// figure fonts, white minor and light grey major grid lines.
pub fn mesh<'m, 'a, 'b, X: Ranged, Y: Ranged, DB: DrawingBackend>(
    mesh: &'m mut MeshStyle<'a, 'b, X, Y, DB>,
) -> &'m mut MeshStyle<'a, 'b, X, Y, DB> {
    mesh.axis_desc_style(axis_desc()).label_style(tick()).light_line_style(WHITE).bold_line_style(GRID)
}

/// Figure title.
pub fn title() -> TextStyle<'static> {
    (FAMILY, 30).into()
}

/// Axis descriptions (`"x [m]"`).
pub fn axis_desc() -> TextStyle<'static> {
    (FAMILY, 28).into()
}

/// Tick labels.
pub fn tick() -> TextStyle<'static> {
    (FAMILY, 24).into()
}

/// Legend entries.
pub fn legend() -> TextStyle<'static> {
    (FAMILY, 24).into()
}

/// Okabe-Ito colours: blue, vermillion, bluish green, orange, reddish purple, sky blue,
/// yellow, black.
pub const PALETTE: [RGBColor; 8] = [
    RGBColor(0, 114, 178),
    RGBColor(213, 94, 0),
    RGBColor(0, 158, 115),
    RGBColor(230, 159, 0),
    RGBColor(204, 121, 167),
    RGBColor(86, 180, 233),
    RGBColor(240, 228, 66),
    RGBColor(0, 0, 0),
];

/// The `i`-th series colour.
pub fn color(i: usize) -> RGBColor {
    PALETTE[i % PALETTE.len()]
}

/// Major grid lines.
pub const GRID: RGBColor = RGBColor(222, 222, 222);

/// A tick label without trailing zeros ("0.5", "10", "250", "1e-3").
pub fn tick_label(v: f64) -> String {
    if v == 0.0 {
        return "0".into();
    }
    let a = v.abs();
    if !(1e-3..1e6).contains(&a) {
        return format!("{v:e}");
    }
    let s = format!("{v:.4}");
    s.trim_end_matches('0').trim_end_matches('.').to_string()
}

/// Ground truth (trajectory, landmarks).
pub const TRUTH: RGBColor = RGBColor(0, 0, 0);
/// The odometry-only trajectory.
pub const ODOMETRY: RGBColor = RGBColor(120, 120, 120);
/// The filter's estimated trajectory.
pub const ESTIMATE: RGBColor = RGBColor(0, 114, 178);
/// The filter's map estimate.
pub const MAP: RGBColor = RGBColor(213, 94, 0);

/// An axis-aligned box of data coordinates.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Bounds {
    /// Least x.
    pub x0: f64,
    /// Greatest x.
    pub x1: f64,
    /// Least y.
    pub y0: f64,
    /// Greatest y.
    pub y1: f64,
}

impl Bounds {
    /// The bounds of the finite points (`None` if there is none).
    pub fn of(points: impl IntoIterator<Item = (f64, f64)>) -> Option<Bounds> {
        let mut b: Option<Bounds> = None;
        for (x, y) in points.into_iter().filter(|(x, y)| x.is_finite() && y.is_finite()) {
            let c = b.get_or_insert(Bounds { x0: x, x1: x, y0: y, y1: y });
            c.x0 = c.x0.min(x);
            c.x1 = c.x1.max(x);
            c.y0 = c.y0.min(y);
            c.y1 = c.y1.max(y);
        }
        b
    }

    /// The smallest box holding both.
    pub fn union(self, o: Bounds) -> Bounds {
        Bounds { x0: self.x0.min(o.x0), x1: self.x1.max(o.x1), y0: self.y0.min(o.y0), y1: self.y1.max(o.y1) }
    }

    /// Grown by `frac` of its larger side on every side (and at least to 1 unit wide).
    pub fn padded(self, frac: f64) -> Bounds {
        let pad = (frac * (self.x1 - self.x0).max(self.y1 - self.y0)).max(0.5);
        Bounds { x0: self.x0 - pad, x1: self.x1 + pad, y0: self.y0 - pad, y1: self.y1 + pad }
    }

    /// Width over height.
    pub fn aspect(&self) -> f64 {
        (self.x1 - self.x0) / (self.y1 - self.y0)
    }

    /// Grown about its centre along one axis so that one data unit has the same length on
    /// both axes in a plotting area of `w` x `h` pixels.
    pub fn equal_scale(self, w: u32, h: u32) -> Bounds {
        let target = w.max(1) as f64 / h.max(1) as f64;
        let (cx, cy) = (0.5 * (self.x0 + self.x1), 0.5 * (self.y0 + self.y1));
        let (mut dx, mut dy) = (self.x1 - self.x0, self.y1 - self.y0);
        if dx / dy < target {
            dx = dy * target;
        } else {
            dy = dx / target;
        }
        Bounds { x0: cx - 0.5 * dx, x1: cx + 0.5 * dx, y0: cy - 0.5 * dy, y1: cy + 0.5 * dy }
    }
}

/// The range `[lo, hi]` of the finite values, padded by 5 % (a unit range around a constant;
/// `[0, 1]` without values).
pub fn value_range(values: impl IntoIterator<Item = f64>, from_zero: bool) -> (f64, f64) {
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    for v in values.into_iter().filter(|v| v.is_finite()) {
        lo = lo.min(v);
        hi = hi.max(v);
    }
    if !lo.is_finite() {
        return (0.0, 1.0);
    }
    if from_zero {
        lo = lo.min(0.0);
    }
    if hi - lo < 1e-12 {
        return (lo - 0.5, hi + 0.5);
    }
    let pad = 0.05 * (hi - lo);
    (if from_zero && lo >= 0.0 { lo } else { lo - pad }, hi + pad)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn equal_scale_keeps_the_data_and_matches_the_pixel_aspect() {
        let b = Bounds { x0: 0.0, x1: 100.0, y0: 0.0, y1: 10.0 }.equal_scale(400, 400);
        assert!((b.aspect() - 1.0).abs() < 1e-12);
        assert!(b.x0 <= 0.0 && b.x1 >= 100.0 && b.y0 <= 0.0 && b.y1 >= 10.0);
        let b = Bounds { x0: 0.0, x1: 10.0, y0: 0.0, y1: 100.0 }.equal_scale(800, 400);
        assert!((b.aspect() - 2.0).abs() < 1e-12);
    }

    #[test]
    fn tick_labels_are_short() {
        assert_eq!(tick_label(100.0), "100");
        assert_eq!(tick_label(0.5), "0.5");
        assert_eq!(tick_label(-250.0), "-250");
        assert_eq!(tick_label(0.0), "0");
        assert_eq!(tick_label(2.5e-5), "2.5e-5");
    }

    #[test]
    fn value_range_handles_constants_and_nothing() {
        assert_eq!(value_range([], false), (0.0, 1.0));
        assert_eq!(value_range([2.0, 2.0], false), (1.5, 2.5));
        let (lo, hi) = value_range([1.0, 3.0, f64::NAN], true);
        assert_eq!(lo, 0.0);
        assert!(hi > 3.0);
    }
}
