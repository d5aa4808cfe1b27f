//! Polylines as the figures draw them. plotters' bitmap backend draws a path wider than one
//! pixel as one polygon with mitred joins, which grows spikes and double edges where a
//! trajectory jitters below the pixel scale; so wide lines are drawn as separate two-point
//! segments (no joins), after dropping points closer than a pixel to their predecessor,
//! and lines that should not set the axes' extent are cut to the plotted box.

use plotters::element::PathElement;
use plotters::style::ShapeStyle;

use crate::style::Bounds;

/// The points of `pts` at least `min_step` from the previously kept one (the last point is
/// always kept): the same picture with far fewer segments.
pub fn decimate(pts: &[(f64, f64)], min_step: f64) -> Vec<(f64, f64)> {
    let mut out: Vec<(f64, f64)> = Vec::with_capacity(pts.len().min(4096));
    let min_sq = min_step * min_step;
    for (i, &p) in pts.iter().enumerate() {
        let keep = match out.last() {
            None => true,
            Some(&q) => i + 1 == pts.len() || (p.0 - q.0).powi(2) + (p.1 - q.1).powi(2) >= min_sq,
        };
        if keep {
            out.push(p);
        }
    }
    out
}

/// The polyline `pts` as separate segments of `style` (no joins, hence no mitre spikes).
pub fn segments(pts: &[(f64, f64)], style: ShapeStyle) -> impl Iterator<Item = PathElement<(f64, f64)>> + '_ {
    pts.windows(2).map(move |w| PathElement::new(vec![w[0], w[1]], style))
}

/// The runs of consecutive points of `pts` inside `b`.
pub fn clip_runs(pts: &[(f64, f64)], b: &Bounds) -> Vec<Vec<(f64, f64)>> {
    let inside = |p: &(f64, f64)| p.0 >= b.x0 && p.0 <= b.x1 && p.1 >= b.y0 && p.1 <= b.y1;
    let mut runs: Vec<Vec<(f64, f64)>> = Vec::new();
    let mut current: Vec<(f64, f64)> = Vec::new();
    for p in pts {
        if inside(p) {
            current.push(*p);
        } else if !current.is_empty() {
            runs.push(std::mem::take(&mut current));
        }
    }
    if !current.is_empty() {
        runs.push(current);
    }
    runs
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn decimate_keeps_ends_and_spacing() {
        let pts: Vec<(f64, f64)> = (0..=100).map(|i| (i as f64 * 0.1, 0.0)).collect();
        let d = decimate(&pts, 1.0);
        assert_eq!(d.first(), Some(&(0.0, 0.0)));
        assert_eq!(d.last(), pts.last());
        assert!(d.len() <= 12, "{}", d.len());
    }

    #[test]
    fn clip_runs_splits_at_the_box() {
        let b = Bounds { x0: 0.0, x1: 1.0, y0: 0.0, y1: 1.0 };
        let pts = [(0.5, 0.5), (0.6, 0.5), (2.0, 0.5), (0.7, 0.5), (0.8, 0.9)];
        assert_eq!(clip_runs(&pts, &b), vec![vec![(0.5, 0.5), (0.6, 0.5)], vec![(0.7, 0.5), (0.8, 0.9)]]);
    }
}
