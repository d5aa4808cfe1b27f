//! Local hypotheses of a world of several landmark types (\[Kim2022\] Section III-B): a
//! Bernoulli's density is `f(x, m)` over the landmark's position and type, kept here as one
//! Gaussian per type with the type's probability, `f(x, m) = w_m N(x; mean_m, cov_m)`.
//!
//! - Step ii (Appendix A): a measurement's new Bernoulli has `r = sum_m e(m) / nu` and the type
//!   probabilities `w_m = e(m) / sum_m e(m)`, each type's density from that type's inverse.
//! - Step iii: the missed hypothesis keeps `r (1 - q) / (1 - r q)` with
//!   `q = sum_m w_m p_D(m)`, and `w_m` becomes proportional to `w_m (1 - p_D(m))`; `p_D(m)` is
//!   \[Kim2022\] Section V's adaptive one per Bernoulli and type (`P_D` where that type's
//!   density gates a measurement, else 0).
//! - Step iv: the detected hypothesis of measurement `z` has
//!   `nu(z) = r sum_m w_m p_D(m) N(z; h(mean_m, m), S_m)`, each type's density updated by its own
//!   EKF, and `w_m` proportional to the type's term.
//! - TOMB/P (eqs. 48-49): `r = sum_k p_k r_k`; type `m` weighs `sum_k p_k r_k w_km` and its
//!   density is the moment match of the children's type-`m` densities with those weights.
//!
//! The type reported is the most likely one, `argmax_m w_m` (Section V's `argmax_m e(m)` at
//! birth, updated by every scan since). The local hypothesis itself ([`LocalHypothesis`])
//! holds that type's mark and density, so that the association, the reduction and the
//! estimates read one Gaussian as in a world of one type; the per-type densities sit beside
//! it in [`PmbmDensity::types`], `types[h * T..(h + 1) * T]` for local hypothesis `h` and
//! the world's `T` types (in the order of `SensorModel::marks`; a type a Bernoulli cannot be has
//! `w_m = 0`). A world of one type keeps no such entries and runs the code of its parent
//! module unchanged.

use nalgebra::{SMatrix, SVector};
use rfslam_assign::AssignError;
use rfslam_assign::tomb::{moment_match, probability};
use rfslam_core::gaussian::symmetrise;
use rfslam_core::rbpf::log_sum_exp;

use super::{Detection, LN_2PI, LocalHypothesis, PmbmDensity, UpdateSettings, Workspace};
use crate::model::InvertibleSensorModel;

/// The most landmark types a world may have: a local hypothesis's per-type work sits in
/// arrays of this length (no allocation per hypothesis or measurement).
pub const MAX_TYPES: usize = 8;

/// One landmark type's part of a local hypothesis's density: `ln w_m`, the type's
/// probability given that the landmark exists (`-inf`: not this type), and its Gaussian.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TypeDensity<const M: usize> {
    /// `ln w_m`.
    pub ln_w: f64,
    /// Mean of the type's density.
    pub mean: SVector<f64, M>,
    /// Covariance of the type's density.
    pub cov: SMatrix<f64, M, M>,
}

impl<const M: usize> TypeDensity<M> {
    /// A type the Bernoulli is not (its Gaussian only holds the place).
    fn absent(mean: SVector<f64, M>, cov: SMatrix<f64, M, M>) -> Self {
        TypeDensity { ln_w: f64::NEG_INFINITY, mean, cov }
    }
}

/// The number of landmark types of the sensor's world ([`rfslam_core::SensorModel::marks`]).
pub fn type_count<const X: usize, const M: usize, const Z: usize, S: InvertibleSensorModel<X, M, Z>>(
    model: &S,
) -> usize {
    model.marks().len().min(MAX_TYPES)
}

/// The per-type densities of a local hypothesis known to be of one type: `h`'s own.
pub fn single_type<const M: usize>(h: &LocalHypothesis<M>, types: usize) -> impl Iterator<Item = TypeDensity<M>> + '_ {
    (0..types).map(move |m| TypeDensity {
        ln_w: if m == usize::from(h.mark) { 0.0 } else { f64::NEG_INFINITY },
        mean: h.mean,
        cov: h.cov,
    })
}

/// Sets `h`'s mark, mean and covariance to its most likely type's (the first on a tie).
pub fn most_likely<const M: usize>(h: &mut LocalHypothesis<M>, types: &[TypeDensity<M>]) {
    let mut best = 0;
    for (m, t) in types.iter().enumerate() {
        if t.ln_w > types[best].ln_w {
            best = m;
        }
    }
    h.mark = best as u8;
    h.mean = types[best].mean;
    h.cov = types[best].cov;
}

/// One type's linearisation at a local hypothesis: predicted measurement, `H_m`, the
/// Cholesky factor of `S`, `ln det S`, `ln (w_m p_D(m))` and `R`.
#[derive(Clone, Copy)]
struct TypeLin<const M: usize, const Z: usize> {
    z: SVector<f64, Z>,
    hm: SMatrix<f64, Z, M>,
    l: SMatrix<f64, Z, Z>,
    log_det: f64,
    ln_wp: f64,
    noise: SMatrix<f64, Z, Z>,
}

/// Step iv of a typed local hypothesis `h` (existence `r` after survival, `p[m]` each
/// type's detection probability): a detected child `r = 1` for every measurement that some
/// type's density gates. Marks in `gated` the types that gate a measurement. Returns the
/// innovation covariances that failed Cholesky (that type is then not detectable).
#[allow(clippy::too_many_arguments)]
fn detect<const X: usize, const M: usize, const Z: usize, S: InvertibleSensorModel<X, M, Z>>(
    h: &LocalHypothesis<M>,
    prior: &[TypeDensity<M>],
    r: f64,
    p: &[f64; MAX_TYPES],
    x: &SVector<f64, X>,
    z: &[SVector<f64, Z>],
    noise: Option<&[SMatrix<f64, Z, Z>]>,
    model: &S,
    s: &UpdateSettings,
    ws: &mut Workspace<M>,
    gated: &mut [bool; MAX_TYPES],
) -> u32 {
    if let Some(noise) = noise {
        return detect_each(h, prior, r, p, x, z, noise, model, s, ws, gated);
    }
    let nt = prior.len();
    let mut chol = 0;
    let mut lins: [Option<TypeLin<M, Z>>; MAX_TYPES] = [None; MAX_TYPES];
    for (m, t) in prior.iter().enumerate() {
        if t.ln_w == f64::NEG_INFINITY || p[m] <= 0.0 {
            continue;
        }
        let mark = model.marks()[m];
        let noise = model.noise(mark);
        let lin = model.linearise(x, &t.mean, mark);
        let s_cov = symmetrise(&(lin.hm * t.cov * lin.hm.transpose() + noise));
        let Some(ch) = s_cov.cholesky() else {
            chol += 1;
            continue;
        };
        let l = ch.l();
        let log_det: f64 = (0..Z).map(|i| 2.0 * l[(i, i)].ln()).sum();
        lins[m] = Some(TypeLin { z: lin.z, hm: lin.hm, l, log_det, ln_wp: t.ln_w + p[m].ln(), noise });
    }
    // Each type's gain and updated covariance, computed at its first gated measurement.
    let mut gains: [Option<(SMatrix<f64, M, Z>, SMatrix<f64, M, M>)>; MAX_TYPES] = [None; MAX_TYPES];
    let ln_r = r.ln();
    for (j, zj) in z.iter().enumerate() {
        let mut terms = [f64::NEG_INFINITY; MAX_TYPES];
        let mut nus = [SVector::<f64, Z>::zeros(); MAX_TYPES];
        let mut any = false;
        for m in 0..nt {
            let Some(tl) = &lins[m] else { continue };
            let v = model.residual(zj, &tl.z);
            let Some(y) = tl.l.solve_lower_triangular(&v) else { continue };
            let maha = y.norm_squared();
            if maha > s.gate {
                continue;
            }
            terms[m] = tl.ln_wp - 0.5 * (Z as f64 * LN_2PI + tl.log_det + maha);
            nus[m] = v;
            gated[m] = true;
            any = true;
        }
        if !any {
            continue;
        }
        let lse = log_sum_exp(&terms[..nt]);
        let child = ws.hyps.len();
        ws.det.push(Detection { j, child: child as u32, ln_nu: ln_r + lse });
        for m in 0..nt {
            let t = &prior[m];
            if terms[m] == f64::NEG_INFINITY {
                ws.types.push(TypeDensity::absent(t.mean, t.cov));
                continue;
            }
            let tl = lins[m].as_ref().expect("a gated type is linearised");
            // K = P H^T S^-1 (S = L L^T); Joseph form of the covariance.
            let (k, cov) = *gains[m].get_or_insert_with(|| super::ekf_gain(&tl.hm, &t.cov, &tl.l, &tl.noise));
            ws.types.push(TypeDensity { ln_w: terms[m] - lse, mean: t.mean + k * nus[m], cov });
        }
        let mut c = LocalHypothesis { r: 1.0, ..*h };
        most_likely(&mut c, &ws.types[child * nt..(child + 1) * nt]);
        ws.hyps.push(c);
    }
    chol
}

/// [`detect`] when each measurement has its own covariance `R_j` (`noise`): every type's
/// `S_j = H P H^T + R_j`, gate, likelihood and EKF update per measurement.
#[allow(clippy::too_many_arguments)]
fn detect_each<const X: usize, const M: usize, const Z: usize, S: InvertibleSensorModel<X, M, Z>>(
    h: &LocalHypothesis<M>,
    prior: &[TypeDensity<M>],
    r: f64,
    p: &[f64; MAX_TYPES],
    x: &SVector<f64, X>,
    z: &[SVector<f64, Z>],
    noise: &[SMatrix<f64, Z, Z>],
    model: &S,
    s: &UpdateSettings,
    ws: &mut Workspace<M>,
    gated: &mut [bool; MAX_TYPES],
) -> u32 {
    let nt = prior.len();
    let mut chol = 0;
    // Each type's linearisation and H P H^T, once for every measurement.
    let mut lins: [Option<(rfslam_core::model::Linearised<X, M, Z>, SMatrix<f64, Z, Z>)>; MAX_TYPES] =
        [None; MAX_TYPES];
    for (m, t) in prior.iter().enumerate() {
        if t.ln_w > f64::NEG_INFINITY && p[m] > 0.0 {
            let lin = model.linearise(x, &t.mean, model.marks()[m]);
            lins[m] = Some((lin, lin.hm * t.cov * lin.hm.transpose()));
        }
    }
    let ln_r = r.ln();
    for (j, (zj, r_j)) in z.iter().zip(noise).enumerate() {
        let mut terms = [f64::NEG_INFINITY; MAX_TYPES];
        let mut updated = [None; MAX_TYPES];
        for m in 0..nt {
            let (Some((lin, hph)), t) = (&lins[m], &prior[m]) else { continue };
            let Ok(pair) = super::gate_pair(lin, hph, zj, r_j, model, s.gate) else {
                chol += 1;
                continue;
            };
            let Some(super::GatedPair { l, log_det, v, maha }) = pair else { continue };
            terms[m] = t.ln_w + p[m].ln() - 0.5 * (Z as f64 * LN_2PI + log_det + maha);
            let (k, cov) = super::ekf_gain(&lin.hm, &t.cov, &l, r_j);
            updated[m] = Some((t.mean + k * v, cov));
            gated[m] = true;
        }
        if terms[..nt].iter().all(|&t| t == f64::NEG_INFINITY) {
            continue;
        }
        let lse = log_sum_exp(&terms[..nt]);
        let child = ws.hyps.len();
        ws.det.push(Detection { j, child: child as u32, ln_nu: ln_r + lse });
        for m in 0..nt {
            let t = &prior[m];
            ws.types.push(match updated[m] {
                Some((mean, cov)) => TypeDensity { ln_w: terms[m] - lse, mean, cov },
                None => TypeDensity::absent(t.mean, t.cov),
            });
        }
        let mut c = LocalHypothesis { r: 1.0, ..*h };
        most_likely(&mut c, &ws.types[child * nt..(child + 1) * nt]);
        ws.hyps.push(c);
    }
    chol
}

/// Steps ii-iv of [`super::pmbm_update`] and [`super::pmb_update`] in a world of several
/// landmark types, with the densities of every type (see the module documentation).
pub fn children<const X: usize, const M: usize, const Z: usize, S: InvertibleSensorModel<X, M, Z>>(
    map: &PmbmDensity<M>,
    x: &SVector<f64, X>,
    z: &[SVector<f64, Z>],
    noise: Option<&[SMatrix<f64, Z, Z>]>,
    model: &S,
    s: &UpdateSettings,
    ws: &mut Workspace<M>,
) -> u32 {
    let nt = type_count(model);
    let mut chol = 0;
    ws.types.clear();
    for t in 0..map.tracks() {
        ws.track_start.push(ws.hyps.len());
        for hi in map.track_start[t]..map.track_start[t + 1] {
            let h = map.hyps[hi];
            let prior = &map.types[hi * nt..(hi + 1) * nt];
            ws.det_start.push(ws.det.len());
            let (mut w, mut p) = ([0.0; MAX_TYPES], [0.0; MAX_TYPES]);
            let mut p_fov = 0.0;
            if h.r > 0.0 {
                for (m, td) in prior.iter().enumerate().filter(|(_, td)| td.ln_w > f64::NEG_INFINITY) {
                    w[m] = td.ln_w.exp();
                    p[m] = model.detection_probability(x, &td.mean, &td.cov, model.marks()[m]);
                    p_fov += w[m] * p[m];
                }
            }
            // Survival inside the field of view (1: the static map of [Kim2022]).
            let r = if p_fov > 0.0 { h.r * s.survival } else { h.r };
            let miss = ws.hyps.len();
            ws.miss_child.push(miss as u32);
            ws.hyps.push(h);
            ws.types.extend_from_slice(prior);
            let mut gated = [false; MAX_TYPES];
            if p_fov > 0.0 && !z.is_empty() {
                chol += detect(&h, prior, r, &p, x, z, noise, model, s, ws, &mut gated);
            }
            // Step iii, with the adaptive p_D per type.
            let mut q = 0.0;
            let mut p_miss = [0.0; MAX_TYPES];
            for m in 0..nt {
                p_miss[m] = if s.missed_in_fov || gated[m] { p[m] } else { 0.0 };
                q += w[m] * p_miss[m];
            }
            let r = if q > 0.0 { r } else { h.r };
            let nu0 = 1.0 - r * q;
            ws.hyps[miss].r = if nu0 > 0.0 { (r * (1.0 - q) / nu0).clamp(0.0, 1.0) } else { 0.0 };
            if q > 0.0 && q < 1.0 {
                let ln_keep = (1.0 - q).ln();
                for (m, td) in ws.types[miss * nt..(miss + 1) * nt].iter_mut().enumerate() {
                    td.ln_w += (1.0 - p_miss[m]).ln() - ln_keep;
                }
                let (hyps, types) = (&mut ws.hyps, &ws.types);
                most_likely(&mut hyps[miss], &types[miss * nt..(miss + 1) * nt]);
            }
            ws.ln_miss.push(nu0.ln());
        }
    }
    ws.det_start.push(ws.det.len());
    // Step ii: one new track per measurement, "not started" then "exists", both with the
    // measurement's per-type densities.
    for (j, zj) in z.iter().enumerate() {
        let r_j = noise.map(|n| &n[j]);
        let mut e = [0.0; MAX_TYPES];
        let mut e_sum = 0.0;
        let start = ws.types.len();
        let mut first_mapped = None;
        for (m, &mark) in model.marks().iter().take(nt).enumerate() {
            if !model.mapped(mark) {
                ws.types.push(TypeDensity::absent(SVector::zeros(), SMatrix::zeros()));
                continue;
            }
            let (mean, cov, integral) = super::measurement_birth(model, x, zj, mark, r_j);
            // lambda_u,k-1 around the new landmark (`kappa_u` exactly for the constant intensity).
            let lambda = s.undetected_intensity * map.undetected.birth_multiplier(&mean, &cov, m);
            e[m] = model.detection_probability(x, &mean, &cov, mark) * lambda * integral;
            e_sum += e[m];
            first_mapped.get_or_insert(m);
            ws.types.push(TypeDensity { ln_w: 0.0, mean, cov });
        }
        for (m, td) in ws.types[start..].iter_mut().enumerate() {
            td.ln_w = match (e_sum > 0.0, first_mapped) {
                (true, _) if e[m] > 0.0 => (e[m] / e_sum).ln(),
                // No type can start a landmark here (r = 0): the first mapped type's density.
                (false, Some(f)) if f == m => 0.0,
                _ => f64::NEG_INFINITY,
            };
        }
        let mut b = LocalHypothesis { r: 0.0, mean: SVector::zeros(), cov: SMatrix::zeros(), mark: 0 };
        most_likely(&mut b, &ws.types[start..start + nt]);
        let nu = e_sum + model.clutter_intensity(zj).max(s.min_clutter_intensity);
        let r = (e_sum / nu).clamp(0.0, 1.0);
        ws.ln_nu_new.push(nu.ln());
        ws.r_new.push(r);
        ws.track_start.push(ws.hyps.len());
        ws.hyps.push(b);
        ws.hyps.push(LocalHypothesis { r, ..b });
        ws.types.extend_from_within(start..start + nt);
    }
    ws.track_start.push(ws.hyps.len());
    chol
}

/// TOMB/P of one existing track in a world of several types (\[Kim2022\] eqs. 48-49 with
/// `f(x, m)`): each child is its association probability `p_k`, its local hypothesis and its
/// `nt` per-type densities. `r = sum_k p_k r_k`; type `m` weighs `sum_k p_k r_k w_km` and its
/// density is the moment match of the children's type-`m` densities with those weights (the
/// `p_k w_km` weights when every `p_k r_k` is zero). Appends the merged per-type densities to
/// `out` and returns the merged Bernoulli with its most likely type's. Refuses probabilities
/// outside `[0, 1]` and non-finite densities, as [`rfslam_assign::tomb::tomb_merge`] does.
pub fn tomb_merge_typed<'a, const M: usize, I>(
    children: I,
    nt: usize,
    out: &mut Vec<TypeDensity<M>>,
) -> Result<LocalHypothesis<M>, AssignError>
where
    I: Iterator<Item = (f64, &'a LocalHypothesis<M>, &'a [TypeDensity<M>])> + Clone,
{
    let mut first = None;
    for (k, (p, h, types)) in children.clone().enumerate() {
        probability(k, "marginal outside [0, 1]", p)?;
        probability(k, "existence probability outside [0, 1]", h.r)?;
        if !types.iter().all(|t| t.mean.iter().chain(t.cov.iter()).all(|v| v.is_finite())) {
            return Err(AssignError::InvalidHypothesis { index: k, what: "non-finite mean or covariance" });
        }
        first.get_or_insert((*h, types));
    }
    let Some((first, first_types)) = first else {
        return Err(AssignError::InvalidHypothesis { index: 0, what: "at least one hypothesis is required" });
    };
    let r: f64 = children.clone().map(|(p, h, _)| p * h.r).sum();
    let by_existence = r > 0.0;
    let terms = |m: usize| {
        children.clone().map(move |(p, h, types)| {
            let t = &types[m];
            let a = if by_existence { p * h.r } else { p };
            (a * t.ln_w.exp(), t.mean, t.cov)
        })
    };
    let start = out.len();
    let mut total = 0.0;
    for (m, placeholder) in first_types.iter().enumerate().take(nt) {
        let weight: f64 = terms(m).map(|t| t.0).sum();
        total += weight;
        out.push(match moment_match(terms(m)) {
            Some((mean, cov)) => TypeDensity { ln_w: weight, mean, cov },
            None => TypeDensity::absent(placeholder.mean, placeholder.cov),
        });
    }
    if total <= 0.0 {
        out.truncate(start);
        return Err(AssignError::InvalidHypothesis { index: 0, what: "every marginal is zero" });
    }
    for t in &mut out[start..] {
        t.ln_w = if t.ln_w > 0.0 { (t.ln_w / total).ln() } else { f64::NEG_INFINITY };
    }
    let mut merged = LocalHypothesis { r: r.min(1.0), ..first };
    most_likely(&mut merged, &out[start..]);
    Ok(merged)
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{Matrix2, Vector2};
    use rfslam_assign::tomb::tomb_merge;

    fn td(w: f64, x: f64, var: f64) -> TypeDensity<2> {
        TypeDensity { ln_w: w.ln(), mean: Vector2::new(x, 0.0), cov: Matrix2::identity() * var }
    }

    fn bern(r: f64) -> LocalHypothesis<2> {
        LocalHypothesis { r, mean: Vector2::zeros(), cov: Matrix2::identity(), mark: 0 }
    }

    /// With one type the typed merge is TOMB/P's (eqs. 48-49).
    #[test]
    fn one_type_merge_is_tomb() {
        let (p, r) = ([0.3, 0.5, 0.2], [0.4, 1.0, 1.0]);
        let types = [td(1.0, 0.0, 1.0), td(1.0, 2.0, 0.5), td(1.0, -1.0, 2.0)];
        let hyps: Vec<_> =
            (0..3).map(|k| LocalHypothesis { r: r[k], mean: types[k].mean, cov: types[k].cov, mark: 0 }).collect();
        let mut out = Vec::new();
        let children = (0..3).map(|k| (p[k], &hyps[k], &types[k..k + 1]));
        let typed = tomb_merge_typed(children, 1, &mut out).unwrap();
        let plain = tomb_merge(&p, &hyps).unwrap();
        assert!((typed.r - plain.r).abs() < 1e-15);
        assert!((typed.mean - plain.mean).amax() < 1e-12 && (typed.cov - plain.cov).amax() < 1e-12);
        assert_eq!(out.len(), 1);
        assert!(out[0].ln_w.abs() < 1e-15);
    }

    /// Two types: type `m` weighs `sum_k p_k r_k w_km` (normalised), its density is the
    /// match of the type-`m` densities, and the Bernoulli holds the most likely type's.
    #[test]
    fn two_type_merge_weighs_each_type() {
        let hyps = [bern(0.5), bern(1.0)];
        let types = [[td(0.8, 0.0, 1.0), td(0.2, 10.0, 1.0)], [td(0.1, 1.0, 1.0), td(0.9, 11.0, 1.0)]];
        let p = [0.5, 0.5];
        let mut out = Vec::new();
        let children = (0..2).map(|k| (p[k], &hyps[k], &types[k][..]));
        let b = tomb_merge_typed(children, 2, &mut out).unwrap();
        assert!((b.r - 0.75).abs() < 1e-15);
        // Type 0: 0.25 * 0.8 + 0.5 * 0.1 = 0.25; type 1: 0.25 * 0.2 + 0.5 * 0.9 = 0.5.
        assert!((out[0].ln_w.exp() - 1.0 / 3.0).abs() < 1e-12);
        assert!((out[1].ln_w.exp() - 2.0 / 3.0).abs() < 1e-12);
        // Type 1's mean: (0.05 * 10 + 0.45 * 11) / 0.5 = 10.9.
        assert!((out[1].mean.x - 10.9).abs() < 1e-12);
        assert_eq!(b.mark, 1);
        assert_eq!(b.mean, out[1].mean);
    }

    /// The most likely type is the largest weight, the first on a tie; an absent type is
    /// never it while another is possible.
    #[test]
    fn most_likely_type() {
        let mut h = bern(1.0);
        most_likely(&mut h, &[td(0.5, 1.0, 1.0), td(0.5, 2.0, 1.0)]);
        assert_eq!((h.mark, h.mean.x), (0, 1.0));
        most_likely(&mut h, &[TypeDensity::absent(Vector2::zeros(), Matrix2::zeros()), td(1.0, 2.0, 1.0)]);
        assert_eq!((h.mark, h.mean.x), (1, 2.0));
    }
}
