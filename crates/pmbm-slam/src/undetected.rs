//! The intensity `lambda_u` of the undetected landmarks, the Poisson part of a PMBM map
//! (\[Kim2022\] Section III-B), and its update, step i of \[Kim2022\] Appendix A:
//! `lambda_u,k(m) = (1 - p_D(m | x_k)) lambda_u,k-1(m)`, from `lambda_u,0 = kappa_u`.
//!
//! Two models, the key `undetected` of every PMBM filter ([`UndetectedModel`]):
//! - **`thinned`** (default): step i as Appendix A writes it, which is also the standard PMBM
//!   update (Garcia-Fernandez, Williams, Granstrom, Svensson 2018). Along a particle's
//!   trajectory `lambda_u(m) = kappa_u prod_k (1 - p_D(m | x_k))`, so ground scanned many
//!   times holds almost no undetected landmark, and a measurement there starts a track of
//!   almost zero existence. The intensity then depends on the trajectory, and the particle
//!   weight keeps the factor `exp(-int p_D lambda_u,k-1)` of the PMBM likelihood (it is the
//!   same for every particle only while `lambda_u` is constant).
//! - **`constant`**: \[Kim2022\] Section V's shortcut, `p_D ~ 0` in step i: `lambda_u = kappa_u`
//!   for ever, and the factor is dropped (common to all particles).
//!
//! **Representation** ([`ThinnedGrid`]): `kappa_u` times a multiplier per square cell of a
//! planar grid (over the first two landmark coordinates), stored as `f32` in tiles of
//! [`TILE`] x [`TILE`] cells. The cell side is the key `undetected_cell`, by default the
//! sensor's maximum range over [`crate::params::CELLS_PER_RANGE`] (3.75 m on the PHD-SLAM
//! 3.0 world), so that a scan thins about 2500 cells of a half disc whatever the sensor's
//! scale. A cell never thinned holds no memory and the multiplier 1; a tile is created when
//! a scan first thins one of its cells. Tiles are shared (`Arc`) between the copies of one
//! parent after resampling and copied only when one of them writes it, which a scan does
//! only inside its field of view, and only where the multiplier is not zero already: a
//! particle owns the tiles its own scans have changed since it parted from its siblings.
//!
//! **Step i on the grid.** A scan multiplies each cell by `1 - p_D f`, with `f` the fraction
//! of the cell inside the field of view: the cell average of `1 - p_D(m | x)`, exact when
//! `f` is. `f` is 1 for a cell wholly inside, and for a cell an edge cuts it is the mean of
//! the cell's covered lengths on the two lines `y0 + c/4` and `y0 + 3c/4` (the two-point
//! rule across a row, exact along it; within 0.25 of the true fraction, an edge nearly
//! parallel to the rows being the worst case). Where `p_D` varies inside the field of view
//! (the range-linear model, a taper) a cell takes its centre's `p_D` (the largest of its
//! centre's and corners' when cut). Multipliers below `1e-30` are set to zero.
//!
//! **Resolution error.** Inside a cell the grid keeps one value where the exact intensity
//! may vary: a cell the field-of-view edge has cut in several scans holds the product of
//! `1 - p_D f` over them, which is the exact cell average after one scan only. The exact
//! intensity there is higher in the part never seen and lower in the part seen, so a
//! landmark just outside the edge reads a lower intensity than the exact one (its first
//! detection starts a track of lower existence, and it is confirmed by the second) and
//! clutter just inside reads a higher one. Elsewhere the grid is exact up to `f32`
//! rounding: a cell wholly inside or outside every scan so far holds the exact product.
//! Measured on the PHD-SLAM 3.0 world (`results/pmbm/report.md`, "The grid's resolution
//! error"): with the default cell, 1.8 % of the detections start a track whose existence is
//! off by more than 0.05 and 0.3 % fall on the other side of `T_EP = 0.4`; 1, 2 and 7.5 m
//! cells gave the maps of the default within the run-to-run spread of 10 runs, the 1 m cell
//! at 54 % more time per recursion.
//!
//! **New tracks** (step ii). `e_j = int p_D lambda_u,k-1(m) N(z_j; h(m, x), R) dm` takes
//! the constant-intensity closed form (`p_D kappa_u int N(z_j; h(m, x), R) dm`) with
//! `kappa_u` replaced by the mean of the grid's intensity at the four cubature points
//! `m_j +- sqrt(2) L e_i` of the new landmark's Gaussian `N(m_j, L L^T)`: the intensity is
//! averaged over the likelihood's footprint instead of integrated cell by cell.
//!
//! **Weight factor.** Its integral is taken on the grid, `int p_D lambda_u,k-1 =
//! kappa_u A_cell sum_c p_D(c) f_c mult_c`, which is exactly the intensity the scan removes
//! from the grid: the represented Poisson process stays consistent.

use std::sync::Arc;

use nalgebra::{Matrix2, SMatrix, SVector};
use rfslam_core::detection::{PD_MAX, PlacedFov};
use rfslam_core::model::DetectionRegion;
use rfslam_core::{DetectionModel, Fov, FovEdge, Point2, Pose};
use serde::{Deserialize, Serialize};

use crate::model::SensorModel;

/// Which intensity of undetected landmarks a PMBM filter keeps (the key `undetected`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum UndetectedModel {
    /// Thinned by `1 - p_D` at every scan (\[Kim2022\] Appendix A step i; the standard PMBM
    /// update), on a grid; the particle weight keeps `exp(-int p_D lambda_u)`.
    #[default]
    Thinned,
    /// `kappa_u` for ever (\[Kim2022\] Section V: `p_D ~ 0` in step i).
    Constant,
}

/// Cells per side of a tile of [`ThinnedGrid`].
pub const TILE: usize = 32;

/// Multipliers of one tile, row-major (`TILE` rows of `TILE` cells).
type Tile = [f32; TILE * TILE];

/// The tiles of one row of tiles, from tile column `first`.
#[derive(Debug, Clone, Default, PartialEq)]
struct TileRow {
    first: i64,
    tiles: Vec<Option<Arc<Tile>>>,
}

impl TileRow {
    /// The tile at column `ti`, created (all ones) if absent, and writable: copied if another
    /// grid shares it.
    fn tile_mut(&mut self, ti: i64) -> &mut Tile {
        if self.tiles.is_empty() {
            self.first = ti;
        }
        if ti < self.first {
            let grow = (self.first - ti) as usize;
            self.tiles.splice(0..0, std::iter::repeat_n(None, grow));
            self.first = ti;
        }
        let k = (ti - self.first) as usize;
        if k >= self.tiles.len() {
            self.tiles.resize(k + 1, None);
        }
        Arc::make_mut(self.tiles[k].get_or_insert_with(|| Arc::new([1.0; TILE * TILE])))
    }

    fn tile(&self, ti: i64) -> Option<&Tile> {
        let k = usize::try_from(ti - self.first).ok()?;
        self.tiles.get(k)?.as_deref()
    }
}

/// The multiplier `lambda_u / kappa_u` of the undetected intensity on a planar grid of square
/// cells (see the module docs): 1 in a cell no scan has thinned.
#[derive(Debug, Default, PartialEq)]
pub struct ThinnedGrid {
    cell: f64,
    first_row: i64,
    rows: Vec<TileRow>,
}

impl Clone for ThinnedGrid {
    fn clone(&self) -> Self {
        let mut g = ThinnedGrid::default();
        g.clone_from(self);
        g
    }

    /// Shares the tiles (reference counts) and reuses the row allocations.
    fn clone_from(&mut self, src: &Self) {
        self.cell = src.cell;
        self.first_row = src.first_row;
        self.rows.truncate(src.rows.len());
        let n = self.rows.len();
        for (dst, s) in self.rows.iter_mut().zip(&src.rows) {
            dst.first = s.first;
            dst.tiles.clone_from(&s.tiles);
        }
        self.rows.extend_from_slice(&src.rows[n..]);
    }
}

/// Largest cell index magnitude: coordinates beyond `1e15` cells are clamped (no landmark
/// or pose of a valid scenario is there).
const MAX_INDEX: f64 = 1e15;

/// A set of at most four disjoint closed intervals of the real line (`lo <= hi`).
#[derive(Debug, Clone, Copy)]
struct Spans {
    lo: [f64; 4],
    hi: [f64; 4],
    n: usize,
}

impl Spans {
    fn one(lo: f64, hi: f64) -> Self {
        let mut s = Spans { lo: [0.0; 4], hi: [0.0; 4], n: 0 };
        s.push(lo, hi);
        s
    }

    fn push(&mut self, lo: f64, hi: f64) {
        if lo <= hi && self.n < 4 {
            self.lo[self.n] = lo;
            self.hi[self.n] = hi;
            self.n += 1;
        }
    }

    /// The intersection with the union of the disjoint intervals `other`.
    fn intersect(&self, other: &[(f64, f64)]) -> Self {
        let mut out = Spans { lo: [0.0; 4], hi: [0.0; 4], n: 0 };
        for k in 0..self.n {
            for &(lo, hi) in other {
                out.push(self.lo[k].max(lo), self.hi[k].min(hi));
            }
        }
        out
    }
}

/// Multipliers below this are set to zero: `kappa_u` times it is no intensity at all, and
/// `f32` arithmetic on subnormal numbers is slow.
const FLUSH: f32 = 1e-30;

/// `v`, or zero below [`FLUSH`].
#[inline]
fn flush(v: f32) -> f32 {
    if v < FLUSH { 0.0 } else { v }
}

/// Multiplies a run of cells by `q` (the constant `1 - p_D`) and returns the sum of their
/// values before, summed in eight `f32` lanes (so that the loop vectorises) and the lanes
/// in `f64`.
#[inline]
fn thin_run(cells: &mut [f32], q: f32) -> f64 {
    const LANES: usize = 8;
    let mut acc = [0.0f32; LANES];
    let mut chunks = cells.chunks_exact_mut(LANES);
    for chunk in &mut chunks {
        for (a, v) in acc.iter_mut().zip(chunk.iter_mut()) {
            *a += *v;
            *v = flush(*v * q);
        }
    }
    let mut sum: f64 = acc.iter().map(|&a| f64::from(a)).sum();
    for v in chunks.into_remainder() {
        sum += f64::from(*v);
        *v = flush(*v * q);
    }
    sum
}

impl ThinnedGrid {
    /// An unthinned grid of `cell`-metre cells.
    pub fn new(cell: f64) -> Self {
        ThinnedGrid { cell, first_row: 0, rows: Vec::new() }
    }

    /// Cell side (m).
    pub fn cell(&self) -> f64 {
        self.cell
    }

    /// Tiles held (each [`TILE`]^2 `f32`), shared or not.
    pub fn tiles(&self) -> usize {
        self.rows.iter().map(|r| r.tiles.iter().filter(|t| t.is_some()).count()).sum()
    }

    /// Drops every tile (the grid becomes unthinned).
    pub fn clear(&mut self) {
        self.rows.clear();
    }

    fn index(&self, v: f64) -> i64 {
        (v / self.cell).floor().clamp(-MAX_INDEX, MAX_INDEX) as i64
    }

    /// `lambda_u / kappa_u` at the point `(x, y)`: the product of `1 - p_D` over the scans
    /// that thinned its cell (1 if none; a non-finite point reads 1).
    pub fn multiplier(&self, x: f64, y: f64) -> f64 {
        if !(x.is_finite() && y.is_finite()) {
            return 1.0;
        }
        let (i, j) = (self.index(x), self.index(y));
        let (ti, tj) = (i.div_euclid(TILE as i64), j.div_euclid(TILE as i64));
        let Some(row) = usize::try_from(tj - self.first_row).ok().and_then(|k| self.rows.get(k)) else {
            return 1.0;
        };
        match row.tile(ti) {
            Some(t) => {
                let (li, lj) = (i.rem_euclid(TILE as i64) as usize, j.rem_euclid(TILE as i64) as usize);
                f64::from(t[lj * TILE + li])
            }
            None => 1.0,
        }
    }

    /// The mean multiplier at the four cubature points `mean +- sqrt(2) L e_i` of
    /// `N(mean, L L^T)` (at the mean alone when `cov` is not positive definite).
    pub fn mean_multiplier(&self, mean: &Point2, cov: &Matrix2<f64>) -> f64 {
        let Some(ch) = cov.cholesky() else {
            return self.multiplier(mean.x, mean.y);
        };
        let l = ch.l() * std::f64::consts::SQRT_2;
        let mut sum = 0.0;
        for k in 0..2 {
            let d = l.column(k);
            sum += self.multiplier(mean.x + d[0], mean.y + d[1]);
            sum += self.multiplier(mean.x - d[0], mean.y - d[1]);
        }
        0.25 * sum
    }

    /// The tile row `tj`, created if absent.
    fn row_mut(&mut self, tj: i64) -> &mut TileRow {
        if self.rows.is_empty() {
            self.first_row = tj;
        }
        if tj < self.first_row {
            let grow = (self.first_row - tj) as usize;
            self.rows.splice(0..0, std::iter::repeat_n(TileRow::default(), grow));
            self.first_row = tj;
        }
        let k = (tj - self.first_row) as usize;
        if k >= self.rows.len() {
            self.rows.resize(k + 1, TileRow::default());
        }
        &mut self.rows[k]
    }

    /// Step i for one scan from `x` with the field of view `fov` and the detection model
    /// `detection`: every cell the field of view reaches has its multiplier `mult` multiplied
    /// by `1 - p_D f` (`f` its covered fraction, `p_D` its centre's; see the module docs).
    /// Returns `A_cell sum p_D f mult` over those cells, before the thinning: the intensity
    /// removed, `int p_D lambda_u,k-1 / kappa_u` as the grid represents it.
    ///
    /// The field of view is the range sector of [`Fov::contains`] around the pose's heading
    /// (hard edge; a taper scales `p_D` inside it). Row by row, its cover is a few pieces of
    /// cells of one fraction (the two-point rule of the module docs); the work goes tile by
    /// tile, and a tile whose cells in view are all zero already is neither written nor
    /// copied.
    pub fn thin_sector(&mut self, x: &Pose, fov: &Fov, detection: &DetectionModel) -> f64 {
        self.thin_sector_in(x, fov, detection, &mut ThinScratch::default())
    }

    /// [`ThinnedGrid::thin_sector`] with the caller's scratch (a filter keeps one, so that a
    /// scan neither allocates nor clears it).
    pub fn thin_sector_in(
        &mut self,
        x: &Pose,
        fov: &Fov,
        detection: &DetectionModel,
        scratch: &mut ThinScratch,
    ) -> f64 {
        let Some(sector) = SectorRows::new(x, fov, self.cell) else {
            return 0.0;
        };
        let pd_constant = match (*detection, fov.edge) {
            (DetectionModel::Constant { pd }, FovEdge::Hard | FovEdge::Expected | FovEdge::Hold { .. }) => {
                Some(pd.clamp(0.0, PD_MAX))
            }
            _ => None,
        };
        if pd_constant == Some(0.0) {
            return 0.0;
        }
        let placed = fov.at(x);
        let c = self.cell;
        let t = TILE as i64;
        let mut mass = 0.0;
        // The runs of the TILE rows of one row of tiles: (first, last) cell column, empty
        // when first > last (each row's count is reset before it is read).
        let rows = &mut *scratch.rows;
        let (j_lo, j_hi) = sector.rows();
        for tj in j_lo.div_euclid(t)..=j_hi.div_euclid(t) {
            let (mut i_min, mut i_max) = (i64::MAX, i64::MIN);
            for (lj, cover) in rows.iter_mut().enumerate() {
                let j = tj * t + lj as i64;
                cover.n = 0;
                if (j_lo..=j_hi).contains(&j) {
                    sector.cover(j, cover);
                }
                for piece in cover.pieces() {
                    i_min = i_min.min(piece.first);
                    i_max = i_max.max(piece.last);
                }
            }
            if i_min > i_max {
                continue;
            }
            let row = self.row_mut(tj);
            // Pieces are in ascending order in each row: one cursor per row walks them
            // tile by tile.
            let mut cursor = [0usize; TILE];
            // The pieces of one tile: (row, first and last local cell, fraction).
            let mut segs = [(0u8, 0u8, 0u8, 0.0f64); 4 * TILE];
            for ti in i_min.div_euclid(t)..=i_max.div_euclid(t) {
                let (c0, c1) = (ti * t, ti * t + t - 1);
                let mut n_segs = 0;
                for (lj, cover) in rows.iter().enumerate() {
                    let pieces = cover.pieces();
                    let mut k = cursor[lj];
                    while k < pieces.len() && pieces[k].last < c0 {
                        k += 1;
                    }
                    cursor[lj] = k;
                    while k < pieces.len() && pieces[k].first <= c1 && n_segs < segs.len() {
                        let p = pieces[k];
                        let (a, b) = (p.first.max(c0) - c0, p.last.min(c1) - c0);
                        segs[n_segs] = (lj as u8, a as u8, b as u8, p.f);
                        n_segs += 1;
                        if p.last > c1 {
                            break;
                        }
                        k += 1;
                    }
                }
                let segs = &segs[..n_segs];
                if segs.is_empty() {
                    continue;
                }
                let range = |&(lj, a, b, _): &(u8, u8, u8, f64)| {
                    let base = lj as usize * TILE;
                    base + a as usize..base + b as usize + 1
                };
                // (Multipliers are never negative: a zero run has no bit set.)
                let live = row.tile(ti).is_none_or(|tile| {
                    segs.iter().any(|sg| tile[range(sg)].iter().fold(0, |acc, v| acc | v.to_bits()) != 0)
                });
                if !live {
                    continue;
                }
                let tile = row.tile_mut(ti);
                for sg in segs {
                    let (lj, a, _, f) = *sg;
                    let cells = &mut tile[range(sg)];
                    mass += match pd_constant {
                        Some(pd) => pd * f * thin_run(cells, (1.0 - pd * f) as f32),
                        None => {
                            let mut sum = 0.0;
                            let y0 = (tj * t + lj as i64) as f64 * c;
                            for (o, v) in cells.iter_mut().enumerate() {
                                let x0 = (c0 + a as i64 + o as i64) as f64 * c;
                                let pd = cell_pd(detection, &placed, x0, y0, c, f);
                                sum += pd * f * f64::from(*v);
                                *v = flush(*v * (1.0 - pd * f) as f32);
                            }
                            sum
                        }
                    };
                }
            }
        }
        mass * c * c
    }
}

/// `p_D` of a cell of side `c` at `(x0, y0)` that the field of view covers by the fraction
/// `f`: at its centre when it is wholly covered, else the largest `p_D` of its centre and
/// corners (a part-covered cell's centre may lie outside).
fn cell_pd(detection: &DetectionModel, placed: &PlacedFov, x0: f64, y0: f64, c: f64, f: f64) -> f64 {
    let centre = detection.pd_at(placed, &Point2::new(x0 + 0.5 * c, y0 + 0.5 * c));
    if f >= 1.0 {
        return centre;
    }
    [(0.0, 0.0), (c, 0.0), (0.0, c), (c, c)]
        .iter()
        .map(|(a, b)| detection.pd_at(placed, &Point2::new(x0 + a, y0 + b)))
        .fold(centre, f64::max)
}

/// Cells `first..=last` of a row, each covered by the fraction `f` of its area.
#[derive(Debug, Clone, Copy, Default)]
struct Piece {
    first: i64,
    last: i64,
    f: f64,
}

/// Most pieces of one row: at most 16 interval ends on the two lines, one piece of whole
/// cells between consecutive ends and one cut cell at each end.
const MAX_PIECES: usize = 40;

/// The cells of one row the field of view covers, as pieces.
#[derive(Debug, Clone, Copy)]
struct RowCover {
    pieces: [Piece; MAX_PIECES],
    n: usize,
}

/// Scratch of step i's sector thinning: the covers of one row of tiles (about 31 KB, which
/// a scan would otherwise clear once per call). A filter keeps one and passes it to
/// [`Undetected::thin`].
#[derive(Debug, Clone)]
pub struct ThinScratch {
    rows: Box<[RowCover; TILE]>,
}

impl Default for ThinScratch {
    fn default() -> Self {
        ThinScratch { rows: Box::new([RowCover::default(); TILE]) }
    }
}

impl Default for RowCover {
    fn default() -> Self {
        RowCover { pieces: [Piece::default(); MAX_PIECES], n: 0 }
    }
}

impl RowCover {
    fn pieces(&self) -> &[Piece] {
        &self.pieces[..self.n]
    }

    fn push(&mut self, first: i64, last: i64, f: f64) {
        if first <= last && f > 0.0 && self.n < MAX_PIECES {
            self.pieces[self.n] = Piece { first, last, f: f.min(1.0) };
            self.n += 1;
        }
    }
}

/// `floor(v)` as an integer, `v` clamped to `+-MAX_INDEX` (without a call to `floor`).
#[inline]
fn floor_index(v: f64) -> i64 {
    let v = v.clamp(-MAX_INDEX, MAX_INDEX);
    let t = v as i64;
    if (t as f64) > v { t - 1 } else { t }
}

/// Length of `[a, b]` inside the union of the disjoint intervals `s`.
fn overlap(s: &Spans, a: f64, b: f64) -> f64 {
    (0..s.n).map(|k| (s.hi[k].min(b) - s.lo[k].max(a)).max(0.0)).sum()
}

/// The cells of a planar grid wholly inside a sector field of view, row by row.
#[derive(Debug, Clone, Copy)]
struct SectorRows {
    sx: f64,
    sy: f64,
    r_max: f64,
    r_min: f64,
    alpha: f64,
    cell: f64,
    inv_cell: f64,
    /// Half-angle up to 90 degrees and no minimum range: each line meets the sector in one
    /// interval.
    convex: bool,
    /// Inward normals of the bearing half-planes `n . (p - s) >= 0` of the edges at
    /// heading `+- alpha`.
    n_plus: [f64; 2],
    n_minus: [f64; 2],
}

impl SectorRows {
    /// The field of view `fov` at pose `x` on cells of side `cell`; `None` when the pose or
    /// the range is not finite and positive.
    fn new(x: &Pose, fov: &Fov, cell: f64) -> Option<Self> {
        let (sx, sy, heading) = (x[0], x[1], x[2]);
        let (r_max, r_min, alpha) = (fov.max_range, fov.min_range, fov.half_angle);
        if !(sx.is_finite() && sy.is_finite() && heading.is_finite() && r_max > 0.0 && r_max.is_finite()) {
            return None;
        }
        let (s_plus, c_plus) = (heading + alpha).sin_cos();
        let (s_minus, c_minus) = (heading - alpha).sin_cos();
        Some(SectorRows {
            sx,
            sy,
            r_max,
            r_min,
            alpha,
            cell,
            inv_cell: 1.0 / cell,
            convex: alpha <= std::f64::consts::FRAC_PI_2 && r_min <= 0.0,
            n_plus: [s_plus, -c_plus],
            n_minus: [-s_minus, c_minus],
        })
    }

    /// The rows (cell indices) that meet the outer disc.
    fn rows(&self) -> (i64, i64) {
        let c = self.cell;
        let lo = ((self.sy - self.r_max) / c).floor().clamp(-MAX_INDEX, MAX_INDEX) as i64;
        let hi = ((self.sy + self.r_max) / c).floor().clamp(-MAX_INDEX, MAX_INDEX) as i64;
        (lo, hi)
    }

    /// The part of the horizontal line at `y` inside the field of view, as disjoint
    /// intervals of `x`: the outer disc's chord, less the inner disc's chord (minimum
    /// range), within both bearing half-planes (half-angle up to 90 degrees) or either (a
    /// wider sector).
    fn line(&self, y: f64) -> Spans {
        let sx = self.sx;
        let dy = y - self.sy;
        if dy.abs() > self.r_max {
            return Spans::one(1.0, 0.0);
        }
        let w = (self.r_max * self.r_max - dy * dy).sqrt();
        let mut spans = Spans::one(sx - w, sx + w);
        if self.r_min > dy.abs() {
            let wi = (self.r_min * self.r_min - dy * dy).sqrt();
            spans = spans.intersect(&[(f64::NEG_INFINITY, sx - wi), (sx + wi, f64::INFINITY)]);
        }
        if self.alpha < std::f64::consts::PI {
            let a = half_line(self.n_plus, sx, dy);
            let b = half_line(self.n_minus, sx, dy);
            spans = if self.alpha <= std::f64::consts::FRAC_PI_2 {
                spans.intersect(&[(a.0.max(b.0), a.1.min(b.1))])
            } else {
                // Either half-plane: their union, as disjoint intervals.
                let (first, second) = if a.0 <= b.0 { (a, b) } else { (b, a) };
                if first.0 > first.1 {
                    spans.intersect(&[second])
                } else if second.0 > second.1 {
                    spans.intersect(&[first])
                } else if second.0 <= first.1 {
                    spans.intersect(&[(first.0, first.1.max(second.1))])
                } else {
                    spans.intersect(&[first, second])
                }
            };
        }
        spans
    }

    /// The cells of row `j` (`[y0, y0 + c]`) the field of view covers, with the covered
    /// fraction of each by the two-point rule across the row: the mean of the covered
    /// lengths of the cell on the lines `y0 + c/4` and `y0 + 3c/4`, exact along each line.
    /// Between consecutive interval ends of the two lines the count of covering lines is
    /// constant, so whole cells there form pieces of fraction 0.5 or 1; a cell holding an
    /// end gets its own fraction.
    fn cover(&self, j: i64, out: &mut RowCover) {
        let c = self.cell;
        let y0 = j as f64 * c;
        if self.convex {
            return self.cover_convex(y0, out);
        }
        let (a, b) = (self.line(y0 + 0.25 * c), self.line(y0 + 0.75 * c));
        let mut ends = [0.0f64; 16];
        let mut n = 0;
        for s in [&a, &b] {
            for k in 0..s.n {
                ends[n] = s.lo[k];
                ends[n + 1] = s.hi[k];
                n += 2;
            }
        }
        let ends = &mut ends[..n];
        ends.sort_unstable_by(f64::total_cmp);
        let index = |x: f64| floor_index(x / c);
        let fraction = |i: i64| {
            let x0 = i as f64 * c;
            (overlap(&a, x0, x0 + c) + overlap(&b, x0, x0 + c)) / (2.0 * c)
        };
        let mut last_cut = i64::MIN;
        for k in 0..ends.len() {
            // The cell holding this end (once), then the whole cells up to the next end.
            let cut = index(ends[k]);
            if cut != last_cut {
                out.push(cut, cut, fraction(cut));
                last_cut = cut;
            }
            if let Some(&next) = ends.get(k + 1) {
                let covering = overlap(&a, ends[k], next) + overlap(&b, ends[k], next);
                if covering > 0.0 && next > ends[k] {
                    let first = cut + 1;
                    let last = index(next) - 1;
                    out.push(first, last, covering / (2.0 * (next - ends[k])));
                }
            }
        }
    }
}

impl SectorRows {
    /// [`SectorRows::line`] of a convex sector (half-angle up to 90 degrees, no minimum
    /// range): one interval, empty when `lo > hi`.
    #[inline]
    fn line_convex(&self, y: f64) -> (f64, f64) {
        let dy = y - self.sy;
        let w2 = self.r_max * self.r_max - dy * dy;
        if w2 < 0.0 {
            return (1.0, 0.0);
        }
        let w = w2.sqrt();
        let a = half_line(self.n_plus, self.sx, dy);
        let b = half_line(self.n_minus, self.sx, dy);
        ((self.sx - w).max(a.0).max(b.0), (self.sx + w).min(a.1).min(b.1))
    }

    /// [`SectorRows::cover`] of a convex sector: the same pieces from one interval per line.
    fn cover_convex(&self, y0: f64, out: &mut RowCover) {
        let (c, inv_c) = (self.cell, self.inv_cell);
        let a = self.line_convex(y0 + 0.25 * c);
        let b = self.line_convex(y0 + 0.75 * c);
        let on = |s: (f64, f64), x0: f64, x1: f64| (s.1.min(x1) - s.0.max(x0)).max(0.0);
        let mut ends = [0.0f64; 4];
        let mut n = 0;
        for s in [a, b] {
            if s.0 <= s.1 {
                ends[n] = s.0;
                ends[n + 1] = s.1;
                n += 2;
            }
        }
        let ends = &mut ends[..n];
        // Insertion sort of at most four values.
        for k in 1..ends.len() {
            let mut m = k;
            while m > 0 && ends[m - 1] > ends[m] {
                ends.swap(m - 1, m);
                m -= 1;
            }
        }
        let mut last_cut = i64::MIN;
        for k in 0..ends.len() {
            let cut = floor_index(ends[k] * inv_c);
            if cut != last_cut {
                let x0 = cut as f64 * c;
                out.push(cut, cut, (on(a, x0, x0 + c) + on(b, x0, x0 + c)) * 0.5 * inv_c);
                last_cut = cut;
            }
            if let Some(&next) = ends.get(k + 1)
                && next > ends[k]
            {
                let covering = on(a, ends[k], next) + on(b, ends[k], next);
                if covering > 0.0 {
                    out.push(cut + 1, floor_index(next * inv_c) - 1, covering / (2.0 * (next - ends[k])));
                }
            }
        }
    }
}

/// The part of a horizontal line (at `dy` from `s`) in the half-plane `n . (p - s) >= 0`,
/// as an interval of `x`.
fn half_line(n: [f64; 2], sx: f64, dy: f64) -> (f64, f64) {
    if n[0] > 0.0 {
        (sx - n[1] * dy / n[0], f64::INFINITY)
    } else if n[0] < 0.0 {
        (f64::NEG_INFINITY, sx - n[1] * dy / n[0])
    } else if n[1] * dy >= 0.0 {
        (f64::NEG_INFINITY, f64::INFINITY)
    } else {
        (f64::INFINITY, f64::NEG_INFINITY)
    }
}

/// The undetected intensity of one PMBM map: the Section V constant, or the thinned grid
/// (one planar grid in a world of one landmark type with a sector field of view; one
/// intensity per type otherwise).
#[derive(Debug, Default, PartialEq)]
pub enum Undetected {
    /// `kappa_u` everywhere, at every scan.
    #[default]
    Constant,
    /// `kappa_u` times the grid's multiplier.
    Thinned(ThinnedGrid),
    /// `kappa_u` times one multiplier per landmark type (indexed by the type's mark).
    Typed(Vec<TypeIntensity>),
}

impl Clone for Undetected {
    fn clone(&self) -> Self {
        match self {
            Undetected::Constant => Undetected::Constant,
            Undetected::Thinned(g) => Undetected::Thinned(g.clone()),
            Undetected::Typed(t) => Undetected::Typed(t.clone()),
        }
    }

    fn clone_from(&mut self, src: &Self) {
        match (self, src) {
            (Undetected::Thinned(d), Undetected::Thinned(s)) => d.clone_from(s),
            (Undetected::Typed(d), Undetected::Typed(s)) => d.clone_from(s),
            (d, s) => *d = s.clone(),
        }
    }
}

impl Undetected {
    /// The intensity of `model` with cells of `cell` metres (`thinned`) in a world of one
    /// landmark type with a detection sector.
    pub fn new(model: UndetectedModel, cell: f64) -> Self {
        match model {
            UndetectedModel::Constant => Undetected::Constant,
            UndetectedModel::Thinned => Undetected::Thinned(ThinnedGrid::new(cell)),
        }
    }

    /// The intensity `undetected` of the world of `sensor` with cells of `cell` metres: as
    /// [`Undetected::new`] in a world of one type, one [`TypeIntensity`] per type (by its
    /// [`SensorModel::detection_region`]) in a world of several.
    pub fn for_sensor<const X: usize, const M: usize, const Z: usize, S: SensorModel<X, M, Z>>(
        undetected: UndetectedModel,
        cell: f64,
        sensor: &S,
    ) -> Self {
        let types = sensor.marks();
        if undetected == UndetectedModel::Constant || types.len() == 1 {
            return Undetected::new(undetected, cell);
        }
        let per_type = types.iter().map(|&mark| match (sensor.mapped(mark), sensor.detection_region(mark)) {
            (false, _) | (true, None) => TypeIntensity::Unmapped,
            (true, Some(DetectionRegion::Everywhere { .. })) => TypeIntensity::Uniform(1.0),
            (true, Some(DetectionRegion::Sector(..))) => TypeIntensity::Sector(ThinnedGrid::new(cell)),
            (true, Some(DetectionRegion::Ball { .. })) => TypeIntensity::Layers(LayeredGrid::new(cell)),
        });
        Undetected::Typed(per_type.collect())
    }

    /// `lambda_u,k-1 / kappa_u` of landmarks of the type with mark index `mark` averaged over
    /// a new landmark's Gaussian `N(mean, cov)` (see [`ThinnedGrid::mean_multiplier`] and
    /// [`LayeredGrid::mean_multiplier`]): exactly 1 for the constant intensity.
    pub fn birth_multiplier<const M: usize>(
        &self,
        mean: &SVector<f64, M>,
        cov: &SMatrix<f64, M, M>,
        mark: usize,
    ) -> f64 {
        let planar = |g: &ThinnedGrid| {
            g.mean_multiplier(&Point2::new(mean[0], mean[1]), &cov.fixed_view::<2, 2>(0, 0).into_owned())
        };
        match self {
            Undetected::Constant => 1.0,
            Undetected::Thinned(g) => planar(g),
            Undetected::Typed(types) => match types.get(mark) {
                Some(TypeIntensity::Uniform(u)) => *u,
                Some(TypeIntensity::Sector(g)) => planar(g),
                Some(TypeIntensity::Layers(l)) if M >= 3 => l.mean_multiplier(mean[2], |g| planar(g)),
                _ => 1.0,
            },
        }
    }

    /// Step i at the state `x` (planar pose `planar`: its x, y and heading) with `model`'s
    /// detection regions: returns `int p_D lambda_u,k-1 / kappa_u` as the grids represent it,
    /// then thins (0 and nothing done for the constant intensity, or for a model without a
    /// detection region, which validation refuses). A type detected everywhere with one
    /// `p_D` adds nothing to the returned integral: its part is the same for every pose and
    /// every particle (and infinite without a bounded support), so it cancels in the particle
    /// weights.
    pub fn thin<const X: usize, const M: usize, const Z: usize, S: SensorModel<X, M, Z>>(
        &mut self,
        model: &S,
        x: &SVector<f64, X>,
        planar: &Pose,
        scratch: &mut ThinScratch,
    ) -> f64 {
        match self {
            Undetected::Constant => 0.0,
            Undetected::Thinned(g) => match model.detection_sector() {
                Some((fov, detection)) => g.thin_sector_in(planar, &fov, &detection, scratch),
                None => 0.0,
            },
            Undetected::Typed(types) => {
                let mut mass = 0.0;
                for (t, intensity) in types.iter_mut().enumerate() {
                    let Some(region) = model.marks().get(t).and_then(|&mark| model.detection_region(mark)) else {
                        continue;
                    };
                    mass += match (intensity, region) {
                        (TypeIntensity::Uniform(u), DetectionRegion::Everywhere { pd }) => {
                            let kept = *u * (1.0 - pd.clamp(0.0, PD_MAX));
                            *u = if kept < f64::from(FLUSH) { 0.0 } else { kept };
                            0.0
                        }
                        (TypeIntensity::Sector(g), DetectionRegion::Sector(fov, detection)) => {
                            g.thin_sector_in(planar, &fov, &detection, scratch)
                        }
                        (TypeIntensity::Layers(l), DetectionRegion::Ball { radius, pd }) if X >= 3 => {
                            l.thin_ball([x[0], x[1], x[2]], radius, pd, scratch)
                        }
                        _ => 0.0,
                    };
                }
                mass
            }
        }
    }

    /// Drops the shared tiles (a spare particle's map keeps none alive).
    pub fn release(&mut self) {
        match self {
            Undetected::Thinned(g) => g.clear(),
            Undetected::Typed(types) => types.iter_mut().for_each(TypeIntensity::release),
            Undetected::Constant => {}
        }
    }
}

/// The thinned undetected intensity of one landmark type in a world of several
/// ([`Undetected::Typed`]), by where the type is detected ([`DetectionRegion`]).
#[derive(Debug, Default, PartialEq)]
pub enum TypeIntensity {
    /// A type the filters do not map (its landmarks are the world's anchors), or one without
    /// a detection region: no intensity is kept.
    #[default]
    Unmapped,
    /// Detected everywhere with one `p_D`: one multiplier, `prod_k (1 - p_D)`.
    Uniform(f64),
    /// A planar sector: the planar grid.
    Sector(ThinnedGrid),
    /// A ball around the vehicle: slabs of the third coordinate, each a planar grid.
    Layers(LayeredGrid),
}

impl Clone for TypeIntensity {
    fn clone(&self) -> Self {
        match self {
            TypeIntensity::Unmapped => TypeIntensity::Unmapped,
            TypeIntensity::Uniform(u) => TypeIntensity::Uniform(*u),
            TypeIntensity::Sector(g) => TypeIntensity::Sector(g.clone()),
            TypeIntensity::Layers(l) => TypeIntensity::Layers(l.clone()),
        }
    }

    fn clone_from(&mut self, src: &Self) {
        match (self, src) {
            (TypeIntensity::Sector(d), TypeIntensity::Sector(s)) => d.clone_from(s),
            (TypeIntensity::Layers(d), TypeIntensity::Layers(s)) => d.clone_from(s),
            (d, s) => *d = s.clone(),
        }
    }
}

impl TypeIntensity {
    fn release(&mut self) {
        match self {
            TypeIntensity::Sector(g) => g.clear(),
            TypeIntensity::Layers(l) => l.layers.clear(),
            TypeIntensity::Unmapped | TypeIntensity::Uniform(_) => {}
        }
    }
}

/// The multiplier of the undetected intensity over three coordinates: slabs of the third
/// coordinate (`z`) one cell thick, `[k c, (k + 1) c)`, each a [`ThinnedGrid`] over the
/// first two with the same cell (cubic cells); a slab no scan has reached holds nothing and
/// reads 1.
///
/// A ball of radius `r` around `v` thins each slab it reaches by the disc it cuts at the
/// slab's middle height `z_k`, of radius `sqrt(r^2 - (z_k - v_z)^2)`, with the planar grid's
/// exact-area rule ([`ThinnedGrid::thin_sector`] with a half angle of pi). The slab's middle
/// stands for the whole slab (our choice; a resolution error in `z` of the kind the module
/// docs describe across a cell's edge): a slab the sphere cuts is thinned as its middle is.
#[derive(Debug, Default, PartialEq)]
pub struct LayeredGrid {
    cell: f64,
    first: i64,
    layers: Vec<ThinnedGrid>,
}

impl Clone for LayeredGrid {
    fn clone(&self) -> Self {
        let mut l = LayeredGrid::default();
        l.clone_from(self);
        l
    }

    /// Reuses the slabs' allocations (the tiles are shared, see [`ThinnedGrid`]).
    fn clone_from(&mut self, src: &Self) {
        self.cell = src.cell;
        self.first = src.first;
        self.layers.clone_from(&src.layers);
    }
}

impl LayeredGrid {
    /// An unthinned grid of cubic cells of side `cell` (m).
    pub fn new(cell: f64) -> Self {
        LayeredGrid { cell, first: 0, layers: Vec::new() }
    }

    /// Slabs held (reached by a scan so far).
    pub fn layers(&self) -> usize {
        self.layers.len()
    }

    fn index(&self, z: f64) -> i64 {
        (z / self.cell).floor().clamp(-MAX_INDEX, MAX_INDEX) as i64
    }

    /// `lambda_u / kappa_u` at `(x, y, z)`: the slab of `z`'s multiplier at `(x, y)`.
    pub fn multiplier(&self, x: f64, y: f64, z: f64) -> f64 {
        if !z.is_finite() {
            return 1.0;
        }
        self.layer(self.index(z)).map_or(1.0, |g| g.multiplier(x, y))
    }

    fn layer(&self, k: i64) -> Option<&ThinnedGrid> {
        usize::try_from(k - self.first).ok().and_then(|i| self.layers.get(i))
    }

    /// `planar(slab)` on the slab of height `z` (a new landmark's mean multiplier over its
    /// first two coordinates, [`ThinnedGrid::mean_multiplier`]; the spread in `z` is not
    /// averaged, our choice): 1 where no scan has reached.
    pub fn mean_multiplier(&self, z: f64, planar: impl Fn(&ThinnedGrid) -> f64) -> f64 {
        if !z.is_finite() {
            return 1.0;
        }
        self.layer(self.index(z)).map_or(1.0, planar)
    }

    /// The slab `k`, created (unthinned) if absent.
    fn layer_mut(&mut self, k: i64) -> &mut ThinnedGrid {
        let cell = self.cell;
        if self.layers.is_empty() {
            self.first = k;
        }
        if k < self.first {
            let grow = (self.first - k) as usize;
            self.layers.splice(0..0, std::iter::repeat_n(ThinnedGrid::new(cell), grow));
            self.first = k;
        }
        let i = (k - self.first) as usize;
        if i >= self.layers.len() {
            self.layers.resize(i + 1, ThinnedGrid::new(cell));
        }
        &mut self.layers[i]
    }

    /// Step i for one scan that detects with probability `pd` every landmark within `radius`
    /// of `centre` (see the type's docs). Returns `int p_D lambda_u,k-1 / kappa_u` as the
    /// grid represents it (each slab's removed area times the cell side), before the
    /// thinning.
    pub fn thin_ball(&mut self, centre: [f64; 3], radius: f64, pd: f64, scratch: &mut ThinScratch) -> f64 {
        if !(centre.iter().all(|c| c.is_finite()) && radius > 0.0 && radius.is_finite()) {
            return 0.0;
        }
        let c = self.cell;
        let detection = DetectionModel::Constant { pd };
        let pose = Pose::new(centre[0], centre[1], 0.0);
        let mut mass = 0.0;
        for k in self.index(centre[2] - radius)..=self.index(centre[2] + radius) {
            let dz = (k as f64 + 0.5) * c - centre[2];
            if dz.abs() >= radius {
                continue;
            }
            let disc = Fov::new((radius * radius - dz * dz).sqrt(), std::f64::consts::PI);
            mass += c * self.layer_mut(k).thin_sector_in(&pose, &disc, &detection, scratch);
        }
        mass
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    use rand::{RngExt, SeedableRng};
    use rfslam_core::rng::Rng;

    const PD: f64 = 0.9;

    fn constant(pd: f64) -> DetectionModel {
        DetectionModel::Constant { pd }
    }

    /// Whether the whole cell `(i, j)` lies inside `fov` at `x` (its four corners; exact for
    /// a convex sector).
    fn corners_inside(fov: &Fov, x: &Pose, c: f64, i: i64, j: i64) -> bool {
        [(0.0, 0.0), (1.0, 0.0), (0.0, 1.0), (1.0, 1.0)]
            .iter()
            .all(|(a, b)| fov.contains(x, &Point2::new((i as f64 + a) * c, (j as f64 + b) * c)))
    }

    /// The fraction of the cell `(i, j)` inside `fov` at `x`, from 20 x 20 points.
    fn sampled_fraction(fov: &Fov, x: &Pose, c: f64, i: i64, j: i64) -> f64 {
        let n = 20;
        let inside = (0..n)
            .flat_map(|a| (0..n).map(move |b| (a, b)))
            .filter(|&(a, b)| {
                let p = Point2::new(
                    (i as f64 + (a as f64 + 0.5) / n as f64) * c,
                    (j as f64 + (b as f64 + 0.5) / n as f64) * c,
                );
                fov.contains(x, &p)
            })
            .count();
        inside as f64 / (n * n) as f64
    }

    /// A small case by hand: 1 m cells, a 10 m sector of +-0.8 rad, p_D = 0.9, three scans.
    /// The cell [3, 4] x [0, 1] is seen whole only from the origin (heading 0); [8, 9] x
    /// [0, 1] from the origin and from (5, 0); [9, 10] x [0, 1] is cut by the first scan's
    /// 10 m edge, which covers `(sqrt(100 - 1/16) - 9 + sqrt(100 - 9/16) - 9) / 2` of it on
    /// the lines y = 1/4 and 3/4, and seen whole from (5, 0). Cells no scan reaches keep 1.
    #[test]
    fn thinned_intensity_is_the_product_over_the_scans() {
        let fov = Fov::new(10.0, 0.8);
        let mut g = ThinnedGrid::new(1.0);
        let poses =
            [Pose::new(0.0, 0.0, 0.0), Pose::new(5.0, 0.0, 0.0), Pose::new(0.0, 0.0, std::f64::consts::FRAC_PI_2)];
        for x in &poses {
            g.thin_sector(x, &fov, &constant(PD));
        }
        let q = (1.0 - PD) as f32;
        assert_eq!(g.multiplier(3.5, 0.5), f64::from(q));
        assert_eq!(g.multiplier(8.5, 0.5), f64::from(q * q));
        let f = ((100.0f64 - 0.0625).sqrt() - 9.0 + (100.0f64 - 0.5625).sqrt() - 9.0) / 2.0;
        assert_eq!(g.multiplier(9.5, 0.5), f64::from((1.0 - PD * f) as f32 * q));
        // Seen whole from the third pose only (heading +90 deg): [0, 1] x [5, 6].
        assert_eq!(g.multiplier(0.5, 5.5), f64::from(q));
        assert_eq!(g.multiplier(-3.5, -0.5), 1.0);
        assert_eq!(g.multiplier(-200.0, 400.0), 1.0);
        // Every cell wholly inside the field of view of some scans and outside the others'
        // holds q to the power of those scans, exactly.
        for i in -12..12 {
            for j in -12..12 {
                let whole = poses.iter().filter(|x| corners_inside(&fov, x, 1.0, i, j)).count();
                let touched = poses.iter().filter(|x| sampled_fraction(&fov, x, 1.0, i, j) > 0.0).count();
                if whole == touched {
                    let expected: f32 = (0..whole).map(|_| q).product();
                    assert_eq!(g.multiplier(i as f64 + 0.5, j as f64 + 0.5), f64::from(expected), "cell ({i}, {j})");
                }
            }
        }
    }

    /// The returned integral is the intensity the scan removes (`A_cell sum mult` before
    /// minus after), and on fresh ground `p_D` times the sector's area, within 0.5 %.
    #[test]
    fn the_integral_is_the_intensity_removed() {
        let fov = Fov::new(30.0, 1.2);
        let x = Pose::new(3.3, -7.1, 0.7);
        let c = 0.5;
        let mut g = ThinnedGrid::new(c);
        let total = |g: &ThinnedGrid| {
            (-100..100)
                .flat_map(|i| (-100..100).map(move |j| (i, j)))
                .map(|(i, j)| g.multiplier((i as f64 + 0.5) * c, (j as f64 + 0.5) * c))
                .sum::<f64>()
                * c
                * c
        };
        for scan in 0..3 {
            let before = total(&g);
            let removed = g.thin_sector(&x, &fov, &constant(PD));
            let after = total(&g);
            assert!((before - after - removed).abs() < 1e-5 * removed, "scan {scan}: {} vs {removed}", before - after);
            if scan == 0 {
                assert!((removed - PD * fov.area()).abs() < 5e-3 * removed, "{removed} vs {}", PD * fov.area());
            }
        }
    }

    /// The covered fraction of every cell (from the multiplier after one scan) against 400
    /// points of the cell, on random sectors with and without a minimum range, narrower and
    /// wider than 180 deg: 1 exactly for a cell wholly inside a convex sector, 0 for one
    /// the sector does not reach, within 0.25 (the two-point rule across a row, exact along
    /// it) elsewhere; summed, the sector's area within 1 %.
    #[test]
    fn scans_cover_the_field_of_view() {
        let mut rng = Rng::seed_from_u64(7);
        for case in 0..60 {
            let half_angle = rng.random_range(0.05..std::f64::consts::PI);
            let min_range = if case % 3 == 0 { rng.random_range(0.0..4.0) } else { 0.0 };
            let fov = Fov { min_range, ..Fov::new(rng.random_range(8.0..20.0), half_angle) };
            let x = Pose::new(rng.random_range(-5.0..5.0), rng.random_range(-5.0..5.0), rng.random_range(-4.0..4.0));
            let c = rng.random_range(0.3..1.0);
            let mut g = ThinnedGrid::new(c);
            g.thin_sector(&x, &fov, &constant(PD));
            let convex = half_angle <= std::f64::consts::FRAC_PI_2 && min_range == 0.0;
            let n = (26.0 / c) as i64;
            let mut area = 0.0;
            for i in -n..n {
                for j in -n..n {
                    let f = (1.0 - g.multiplier((i as f64 + 0.5) * c, (j as f64 + 0.5) * c)) / PD;
                    area += f * c * c;
                    let truth = sampled_fraction(&fov, &x, c, i, j);
                    if convex && corners_inside(&fov, &x, c, i, j) {
                        assert_eq!(
                            g.multiplier((i as f64 + 0.5) * c, (j as f64 + 0.5) * c),
                            f64::from((1.0 - PD) as f32)
                        );
                    }
                    assert!((f - truth).abs() <= 0.25 + 0.05, "case {case}: cell ({i}, {j}) covered {f} of {truth}");
                }
            }
            assert!((area - fov.area()).abs() < 0.01 * fov.area(), "case {case}: {area} vs {}", fov.area());
        }
    }

    /// With `p_D = 0` nothing is thinned: the multiplier is 1 everywhere, bit for bit, no
    /// tile is held, the integral is 0, and a birth reads exactly `kappa_u`.
    #[test]
    fn zero_detection_probability_leaves_the_constant_intensity() {
        let fov = Fov::new(50.0, 1.0);
        for detection in [constant(0.0), DetectionModel::RangeLinear { pd0: 0.0 }] {
            let mut g = ThinnedGrid::new(1.0);
            for k in 0..20 {
                let x = Pose::new(k as f64, 0.5 * k as f64, 0.1 * k as f64);
                assert_eq!(g.thin_sector(&x, &fov, &detection), 0.0);
            }
            assert!((-40..40).all(|i| (-40..40).all(|j| g.multiplier(i as f64, j as f64).to_bits() == 1f64.to_bits())));
            let u = Undetected::Thinned(g);
            let cov = Matrix2::new(0.3, 0.1, 0.1, 0.2);
            assert_eq!(u.birth_multiplier(&nalgebra::Vector2::new(3.0, 4.0), &cov, 0).to_bits(), 1f64.to_bits());
        }
    }

    /// Copies share their tiles until one writes them: a scan copies only the tiles it
    /// writes, and a tile whose cells in view are all zero already is not written (it stays
    /// shared); the other copy is untouched.
    #[test]
    fn copies_share_tiles_until_written() {
        let fov = Fov::new(100.0, std::f64::consts::PI);
        let det = constant(0.99);
        let mut a = ThinnedGrid::new(1.0);
        let x = Pose::new(0.0, 0.0, 0.0);
        for _ in 0..40 {
            a.thin_sector(&x, &fov, &det);
        }
        let tile_ptr = |g: &ThinnedGrid, ti: i64, tj: i64| {
            let row = &g.rows[(tj - g.first_row) as usize];
            Arc::as_ptr(row.tiles[(ti - row.first) as usize].as_ref().unwrap())
        };
        // The tile of cells [0, 32) x [0, 32) lies wholly within 46 m: zero after 40 scans.
        assert_eq!(a.multiplier(0.5, 0.5), 0.0);
        assert_eq!(a.multiplier(31.5, 31.5), 0.0);
        let b = a.clone();
        assert_eq!(tile_ptr(&a, 0, 0), tile_ptr(&b, 0, 0));
        assert_eq!(tile_ptr(&a, 3, 0), tile_ptr(&b, 3, 0));
        let edge = b.multiplier(99.5, 13.5);
        assert!(edge > 0.0, "a cell the edge cuts keeps intensity: {edge}");
        a.thin_sector(&x, &fov, &det);
        assert_eq!(tile_ptr(&a, 0, 0), tile_ptr(&b, 0, 0), "an all-zero tile is neither written nor copied");
        assert_ne!(tile_ptr(&a, 3, 0), tile_ptr(&b, 3, 0), "a tile with live cells in view is copied");
        assert!(a.multiplier(99.5, 13.5) < edge);
        assert_eq!(b.multiplier(99.5, 13.5), edge, "the other copy is untouched");
    }

    /// A ball thins the slabs it reaches: the integral it returns is `p_D` times the ball's
    /// volume on an unthinned grid (the slabs' midpoint rule, within 1 % at ten slabs per
    /// radius), a point well inside reads `1 - p_D`, points outside the ball read 1, and the
    /// integral a later scan returns is the intensity it removes from the cells. (The cells
    /// the sphere cuts keep more than `1 - p_D` after the first scan, so a second scan from
    /// the same place removes more than the continuous `p_D (1 - p_D)` of the volume: 500
    /// against 377 m^3 when this was written, at these ten cells per radius; the grid's
    /// resolution error of the module docs.)
    #[test]
    fn a_ball_thins_its_volume() {
        let (r, centre) = (10.0, [0.3, -0.2, 0.1]);
        let volume = 4.0 / 3.0 * std::f64::consts::PI * r * r * r;
        let mut g = LayeredGrid::new(1.0);
        let first = g.thin_ball(centre, r, PD, &mut ThinScratch::default());
        assert!((first - PD * volume).abs() < 0.01 * PD * volume, "{first} vs {}", PD * volume);
        assert_eq!(g.layers(), 20);
        assert!((g.multiplier(0.5, 0.5, 0.5) - (1.0 - PD)).abs() < 1e-6);
        assert!((g.multiplier(3.5, -2.5, -6.5) - (1.0 - PD)).abs() < 1e-6);
        assert_eq!(g.multiplier(0.5, 0.5, 12.5), 1.0, "above the ball");
        assert_eq!(g.multiplier(11.5, 0.5, 0.5), 1.0, "beside the ball");
        assert_eq!(g.multiplier(8.5, 8.5, 0.5), 1.0, "within the slab's disc's square, outside the disc");
        let cells = |g: &LayeredGrid| {
            let range = || (-12..12).map(|i| i as f64 + 0.5);
            range()
                .flat_map(|x| range().flat_map(move |y| range().map(move |z| (x, y, z))))
                .map(|(x, y, z)| g.multiplier(x, y, z))
                .collect::<Vec<_>>()
        };
        let before = cells(&g);
        let second = g.thin_ball([1.3, 0.4, -0.6], r, PD, &mut ThinScratch::default());
        let removed: f64 = before.iter().zip(cells(&g)).map(|(b, a)| b - a).sum();
        assert!((second - removed).abs() < 1e-4 * removed, "{second} vs {removed}");
        assert!(second > PD * (1.0 - PD) * volume && second < PD * volume, "{second}");
        assert!((g.multiplier(0.5, 0.5, 0.5) - (1.0 - PD) * (1.0 - PD)).abs() < 1e-6);
    }

    /// The radio world's types each keep their own intensity: the base station (an anchor)
    /// none, the virtual anchors (detected everywhere) one multiplier `(1 - p_D)^k` and no part
    /// of the integral, the scattering points a ball of the visibility radius around the
    /// vehicle's position; copies thin independently.
    #[test]
    fn radio_types_thin_by_their_regions() {
        use rfslam_core::model::{LandmarkType, RadioSensor};
        let sensor = RadioSensor::published();
        let pd = sensor.pd;
        let mut u = Undetected::for_sensor(UndetectedModel::Thinned, 5.0, &sensor);
        let Undetected::Typed(types) = &u else { panic!("a typed intensity: {u:?}") };
        assert!(matches!(
            types.as_slice(),
            [TypeIntensity::Unmapped, TypeIntensity::Uniform(1.0), TypeIntensity::Layers(_)]
        ));
        let x = SVector::<f64, 5>::from([70.0, 0.0, 0.0, 1.5, 300.0]);
        let planar = Pose::new(70.0, 0.0, 1.5);
        let before = u.clone();
        let mass = u.thin(&sensor, &x, &planar, &mut ThinScratch::default());
        let ball = pd * 4.0 / 3.0 * std::f64::consts::PI * 50f64.powi(3);
        assert!((mass - ball).abs() < 0.02 * ball, "{mass} vs {ball}");
        let cov = SMatrix::<f64, 3, 3>::identity() * 0.01;
        let at = |u: &Undetected, p: [f64; 3], t: LandmarkType| {
            u.birth_multiplier(&SVector::from(p), &cov, usize::from(t.mark()))
        };
        assert_eq!(at(&u, [0.0, 0.0, 40.0], LandmarkType::BaseStation), 1.0);
        assert!((at(&u, [-200.0, 0.0, 10.0], LandmarkType::VirtualAnchor) - (1.0 - pd)).abs() < 1e-12);
        assert!((at(&u, [80.0, 5.0, 12.0], LandmarkType::ScatteringPoint) - (1.0 - pd)).abs() < 1e-6);
        assert_eq!(at(&u, [140.0, 0.0, 12.0], LandmarkType::ScatteringPoint), 1.0, "70 m away");
        assert_eq!(at(&before, [80.0, 5.0, 12.0], LandmarkType::ScatteringPoint), 1.0, "the copy is untouched");
        u.thin(&sensor, &x, &planar, &mut ThinScratch::default());
        let va = at(&u, [-200.0, 0.0, 10.0], LandmarkType::VirtualAnchor);
        assert!((va - (1.0 - pd) * (1.0 - pd)).abs() < 1e-12, "{va}");
        let mut none = Undetected::for_sensor(UndetectedModel::Constant, 5.0, &sensor);
        assert_eq!(none.thin(&sensor, &x, &planar, &mut ThinScratch::default()), 0.0);
        assert_eq!(at(&none, [80.0, 5.0, 12.0], LandmarkType::ScatteringPoint), 1.0);
    }
}
