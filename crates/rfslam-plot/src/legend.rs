//! Legends drawn in a strip below the plot, laid out in centred rows, so that they never
//! hide data (plotters' own legend box sits inside the plotting area).

use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};

use crate::error::PlotError;
use crate::render::draw_err;
use crate::style;

/// How an entry's symbol looks.
#[derive(Debug, Clone, Copy)]
pub enum Symbol {
    /// A line segment (dashed or solid).
    Line {
        /// Colour.
        color: RGBAColor,
        /// Width in pixels.
        width: u32,
        /// Dashed.
        dashed: bool,
    },
    /// A square marker, filled or hollow.
    Square {
        /// Colour.
        color: RGBAColor,
        /// Filled.
        filled: bool,
    },
    /// A small dot.
    Dot {
        /// Colour.
        color: RGBAColor,
    },
    /// A "+" marker.
    Cross {
        /// Colour.
        color: RGBAColor,
    },
    /// A filled bar.
    Bar {
        /// Colour.
        color: RGBAColor,
    },
}

/// One legend entry.
#[derive(Debug, Clone)]
pub struct Entry {
    /// Text.
    pub label: String,
    /// Symbol.
    pub symbol: Symbol,
}

impl Entry {
    /// A new entry.
    pub fn new(label: impl Into<String>, symbol: Symbol) -> Entry {
        Entry { label: label.into(), symbol }
    }
}

const SYMBOL_W: u32 = 48;
const GAP: u32 = 10;
const SPACING: u32 = 36;
const ROW_H: u32 = 38;
const PAD: u32 = 10;

fn text_width(label: &str) -> u32 {
    style::legend().font.box_size(label).map_or(14 * label.chars().count() as u32, |(w, _)| w)
}

/// Entries per row for an area `width` pixels wide (at least one per row).
fn rows(entries: &[Entry], width: u32) -> Vec<Vec<&Entry>> {
    let mut rows: Vec<Vec<&Entry>> = Vec::new();
    let mut used = 0;
    for e in entries {
        let w = SYMBOL_W + GAP + text_width(&e.label) + SPACING;
        match rows.last_mut() {
            Some(r) if used + w <= width => {
                r.push(e);
                used += w;
            }
            _ => {
                rows.push(vec![e]);
                used = w;
            }
        }
    }
    rows
}

/// Height of the legend strip for `entries` in `width` pixels (0 without entries).
pub fn height(entries: &[Entry], width: u32) -> u32 {
    match rows(entries, width).len() {
        0 => 0,
        n => n as u32 * ROW_H + 2 * PAD,
    }
}

/// Draws the entries in `area`.
pub fn draw<DB: DrawingBackend>(area: &DrawingArea<DB, Shift>, entries: &[Entry]) -> Result<(), PlotError> {
    let (w, _) = area.dim_in_pixel();
    for (r, row) in rows(entries, w).iter().enumerate() {
        let total: u32 = row.iter().map(|e| SYMBOL_W + GAP + text_width(&e.label) + SPACING).sum::<u32>() - SPACING;
        let mut x = (w.saturating_sub(total) / 2) as i32;
        let y = (PAD + r as u32 * ROW_H + ROW_H / 2) as i32;
        for e in row {
            draw_symbol(area, e.symbol, (x, y))?;
            let pos = Pos::new(HPos::Left, VPos::Center);
            area.draw(&Text::new(e.label.clone(), (x + (SYMBOL_W + GAP) as i32, y), style::legend().pos(pos)))
                .map_err(draw_err)?;
            x += (SYMBOL_W + GAP + text_width(&e.label) + SPACING) as i32;
        }
    }
    Ok(())
}

fn draw_symbol<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    symbol: Symbol,
    (x, y): (i32, i32),
) -> Result<(), PlotError> {
    let mid = x + SYMBOL_W as i32 / 2;
    match symbol {
        Symbol::Line { color, width, dashed: false } => {
            area.draw(&PathElement::new(vec![(x, y), (x + SYMBOL_W as i32, y)], color.stroke_width(width)))
        }
        Symbol::Line { color, width, dashed: true } => {
            let s = color.stroke_width(width);
            (0..3).try_for_each(|i| {
                let x0 = x + i * 18;
                area.draw(&PathElement::new(vec![(x0, y), (x0 + 11, y)], s))
            })
        }
        Symbol::Square { color, filled } => {
            let s = if filled { color.filled() } else { color.stroke_width(2) };
            area.draw(&Rectangle::new([(mid - 7, y - 7), (mid + 7, y + 7)], s))
        }
        Symbol::Dot { color } => area.draw(&Circle::new((mid, y), 4, color.filled())),
        Symbol::Cross { color } => {
            let s = color.stroke_width(2);
            area.draw(&PathElement::new(vec![(mid - 8, y), (mid + 8, y)], s)).map_err(draw_err)?;
            area.draw(&PathElement::new(vec![(mid, y - 8), (mid, y + 8)], s))
        }
        Symbol::Bar { color } => area.draw(&Rectangle::new([(mid - 12, y - 12), (mid + 12, y + 12)], color.filled())),
    }
    .map_err(draw_err)
}

/// Splits `root` into the title (when given), the plot and the legend strip below it;
/// draws title and legend and returns the plot's area.
pub fn frame<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    title: Option<&str>,
    entries: &[Entry],
) -> Result<DrawingArea<DB, Shift>, PlotError> {
    let area = match title {
        Some(t) => root.margin(TITLE_TOP, 0, 0, 0).titled(t, style::title()).map_err(draw_err)?,
        None => root.clone(),
    };
    let (w, h) = area.dim_in_pixel();
    let lh = height(entries, w.saturating_sub(40));
    if lh == 0 {
        return Ok(area);
    }
    let (plot, strip) = area.split_vertically(h.saturating_sub(lh));
    draw(&strip, entries)?;
    Ok(plot)
}

/// Space above a title.
const TITLE_TOP: u32 = 8;

/// Height a title takes in [`frame`] (text height plus padding), for sizing figures.
pub fn title_height(title: Option<&str>) -> u32 {
    title.map_or(0, |t| TITLE_TOP + style::title().font.box_size(t).map_or(40, |(_, h)| h + 10))
}
