//! The GOSPA of a map estimate against the true landmarks detected so far: the map score of
//! `steps.csv` ([`crate::trace::StepsWriter`]) and of the map GOSPA over time (`[metrics]
//! gospa_every`, [`crate::metric`]), one piece of code for both.
//!
//! In an exploration world most landmarks enter the field of view along the way; scoring the
//! map after step k against every true landmark would count the ones not yet seen as missed.
//! A landmark counts as detected from the first scan whose truth labels name it; on data
//! without truth labels every landmark counts as detected from the start.

use nalgebra::SVector;
use rfslam_core::Estimate;

use crate::run::Scoring;

/// The true landmarks of a run, which of them have been detected so far, and the GOSPA of a
/// map estimate against those.
pub struct SeenGospa<const M: usize = 2> {
    /// GOSPA cut-off `c` (m) and order `p`.
    c: f64,
    p: f64,
    /// True landmarks sorted by id, and whether each has been detected so far.
    landmarks: Vec<(i64, SVector<f64, M>)>,
    seen: Vec<bool>,
    /// How many are detected so far.
    count: usize,
    /// Whether any scan carries truth labels (else every landmark counts as detected).
    labelled: bool,
    /// Scratch: the detected landmarks' and the estimate's positions.
    truth_pts: Vec<SVector<f64, M>>,
    est_pts: Vec<SVector<f64, M>>,
}

impl<const M: usize> SeenGospa<M> {
    /// The landmarks of a run's data (none detected yet on labelled data, all on unlabelled
    /// data), scored with GOSPA cut-off `c` and order `p`.
    pub fn new<const X: usize, const Z: usize>(data: &Scoring<X, M, Z>, c: f64, p: f64) -> Self {
        let mut landmarks: Vec<(i64, SVector<f64, M>)> =
            data.landmarks.iter().flat_map(|l| l.iter()).map(|l| (l.id, l.position)).collect();
        landmarks.sort_by_key(|l| l.0);
        let labelled = data.scans.iter().any(|s| s.truth.is_some());
        SeenGospa {
            c,
            p,
            seen: vec![!labelled; landmarks.len()],
            count: if labelled { 0 } else { landmarks.len() },
            landmarks,
            labelled,
            truth_pts: Vec::new(),
            est_pts: Vec::new(),
        }
    }

    /// Whether the data set has true landmarks (without them there is nothing to score).
    pub fn has_truth(&self) -> bool {
        !self.landmarks.is_empty()
    }

    /// Marks the landmarks a scan's truth labels name (`labels`, one per measurement;
    /// negative for clutter) as detected. Nothing on unlabelled data.
    pub fn detect(&mut self, labels: Option<&[i64]>) {
        if !self.labelled {
            return;
        }
        for &id in labels.into_iter().flatten().filter(|&&id| id >= 0) {
            if let Ok(i) = self.landmarks.binary_search_by_key(&id, |l| l.0)
                && !self.seen[i]
            {
                self.seen[i] = true;
                self.count += 1;
            }
        }
    }

    /// The number of true landmarks detected so far (0 without true landmarks).
    pub fn count(&self) -> usize {
        self.count
    }

    /// GOSPA (alpha = 2) of `estimate`'s map against the landmarks detected so far; NaN
    /// without true landmarks or when the estimate has a non-finite position.
    pub fn gospa<const X: usize>(&mut self, estimate: &Estimate<X, M>) -> f64 {
        if self.landmarks.is_empty() {
            return f64::NAN;
        }
        self.truth_pts.clear();
        self.truth_pts.extend(self.landmarks.iter().zip(&self.seen).filter(|(_, s)| **s).map(|(l, _)| l.1));
        self.est_pts.clear();
        self.est_pts.extend(estimate.map.iter().map(|m| m.position));
        rfslam_metrics::gospa(&self.truth_pts, &self.est_pts, self.c, self.p).map_or(f64::NAN, |g| g.total)
    }
}
