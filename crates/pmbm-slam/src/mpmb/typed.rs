//! `mpmb-slam` in a world of several landmark types: every Bernoulli keeps one Gaussian per
//! type with the type's probability (\[Kim2022\] Section III-B's `f(x, m)`, as
//! [`crate::pmbm::typed`] does for PMBM and PMB), in [`MpmbFilter::types`] beside the
//! Bernoulli, which holds its most likely type's density for the vehicle update (step 6) and
//! the estimate.
//!
//! - Step ii: `e_j = sum_m e_j(m)`, `w_m = e_j(m) / e_j`, each type's density the cubature
//!   moment of its own inverse.
//! - Step iii: `p_D(m)` at `(mu_s, mean_m)`; `q = sum_m w_m p_D(m)`, `r (1 - q) / (1 - r q)`,
//!   `w_m` proportional to `w_m (1 - p_D(m))`.
//! - Step iv: each type's joint cubature over `[s; m]`; `nu_i(z_j) = r sum_m w_m p_D(m)
//!   N(z_j; z_hat_m, S_m)`, the type's landmark block updated, `w_m` proportional to its term.
//! - TOMB/P: [`crate::pmbm::typed::tomb_merge_typed`].

use nalgebra::{SMatrix, SVector};
use rfslam_assign::tomb::{GaussianBernoulli, tomb_new_track};
use rfslam_core::model::{LandmarkMark, VehicleModel};
use rfslam_core::rbpf::log_sum_exp;

use super::{CubatureUpdate, Detection, LN_2PI, MpmbFilter};
use crate::cubature::{InputPoints, PairMoments, PosePoints, lower_factor};
use crate::model::InvertibleSensorModel;
use crate::pmbm::typed::{MAX_TYPES, TypeDensity, most_likely, tomb_merge_typed};

/// One type's cubature moments at a Bernoulli: `z_hat - dmean` split as the pose points'
/// `y0` and the moments' mean offset, `ln (w_m p_D(m))`, and the update (factor of `S`,
/// `ln det S`, gain, updated covariance).
#[derive(Clone, Copy)]
struct TypeMoments<const M: usize, const Z: usize, const X: usize> {
    y0: SVector<f64, Z>,
    pm: PairMoments<M, Z, X>,
    ln_wp: f64,
    /// The update under `R_U`, shared by every measurement; `None` with per-measurement
    /// covariances.
    update: Option<CubatureUpdate<M, Z>>,
}

impl<V, S, const X: usize, const M: usize, const Z: usize> MpmbFilter<V, S, X, M, Z>
where
    V: VehicleModel<X, 3>,
    S: InvertibleSensorModel<X, M, Z>,
{
    /// Steps iii-iv of every Bernoulli with its per-type densities (`nt` types). Returns the
    /// Cholesky failures (a type whose `P` or `S` fails is not detectable).
    pub(super) fn map_children_typed(&mut self, l_u: &SMatrix<f64, X, X>, nt: usize) -> u32 {
        let (model, ws, mu, survival) = (&self.model, &mut self.ws, self.mean, self.params.survival_fov);
        let noise = self.per_measurement.then_some(&self.noise[..]);
        let inflation = self.params.noise_inflation;
        let mut chol = 0;
        ws.missed.clear();
        ws.missed_types.clear();
        ws.ln_miss.clear();
        ws.det_start.clear();
        ws.det.clear();
        ws.det_types.clear();
        let n = self.n_s + M;
        for (i, b) in self.bernoullis.iter().enumerate() {
            ws.det_start.push(ws.det.len());
            let prior = &self.types[i * nt..(i + 1) * nt];
            let (mut w, mut p) = ([0.0; MAX_TYPES], [0.0; MAX_TYPES]);
            let mut q = 0.0;
            for (m, td) in prior.iter().enumerate().filter(|(_, td)| td.ln_w > f64::NEG_INFINITY) {
                w[m] = td.ln_w.exp();
                p[m] = model.detection_probability(&mu, &td.mean, &td.cov, model.marks()[m]);
                q += w[m] * p[m];
            }
            // Survival where the landmark is detectable (1: the static map of [Kim2022]).
            let r = if q > 0.0 { b.r * survival } else { b.r };
            let nu0 = 1.0 - r * q;
            let r_miss = if nu0 > 0.0 { (r * (1.0 - q) / nu0).clamp(0.0, 1.0) } else { 0.0 };
            let miss_start = ws.missed_types.len();
            ws.missed_types.extend_from_slice(prior);
            if q > 0.0 && q < 1.0 {
                let ln_keep = (1.0 - q).ln();
                for (m, td) in ws.missed_types[miss_start..].iter_mut().enumerate() {
                    td.ln_w += (1.0 - p[m]).ln() - ln_keep;
                }
            }
            let mut missed = GaussianBernoulli { r: r_miss, ..*b };
            most_likely(&mut missed, &ws.missed_types[miss_start..]);
            ws.missed.push(missed);
            ws.ln_miss.push(nu0.ln());
            if q <= 0.0 || self.z.is_empty() {
                continue;
            }
            let mut mom: [Option<TypeMoments<M, Z, X>>; MAX_TYPES] = [None; MAX_TYPES];
            for (m, td) in prior.iter().enumerate() {
                if p[m] <= 0.0 {
                    continue;
                }
                let mark = model.marks()[m];
                let Some(l_p) = lower_factor(&td.cov) else {
                    chol += 1;
                    continue;
                };
                let res = |a: &SVector<f64, Z>, b: &SVector<f64, Z>| model.residual(a, b);
                let pose = PosePoints::new(n, &mu, l_u, |s| model.predict(s, &td.mean, mark), res);
                let input = InputPoints::new(n, &td.mean, &l_p, &pose.y0, |x| model.predict(&mu, x, mark), res);
                let pm = PairMoments::new(n, &pose, &input);
                let update = match noise {
                    None => {
                        let Some(u) = CubatureUpdate::new(&pm, &td.cov, &self.r_u[m]) else {
                            chol += 1;
                            continue;
                        };
                        Some(u)
                    }
                    Some(_) => None,
                };
                let ln_wp = td.ln_w + p[m].ln();
                mom[m] = Some(TypeMoments { y0: pose.y0, pm, ln_wp, update });
            }
            let ln_r = r.ln();
            for (j, zj) in self.z.iter().enumerate() {
                let mut terms = [f64::NEG_INFINITY; MAX_TYPES];
                let mut nus = [SVector::<f64, Z>::zeros(); MAX_TYPES];
                let mut updates: [Option<CubatureUpdate<M, Z>>; MAX_TYPES] = [None; MAX_TYPES];
                for m in 0..nt {
                    let Some(tm) = &mom[m] else { continue };
                    let Some(u) = tm.update.or_else(|| {
                        let r_u = noise.map_or(self.r_u[m], |n| n[j] * inflation);
                        CubatureUpdate::new(&tm.pm, &prior[m].cov, &r_u).or_else(|| {
                            chol += 1;
                            None
                        })
                    }) else {
                        continue;
                    };
                    let v = model.residual(zj, &tm.y0) - tm.pm.dmean;
                    let Some(y) = u.l.solve_lower_triangular(&v) else { continue };
                    let maha = y.norm_squared();
                    if maha > self.gate {
                        continue;
                    }
                    terms[m] = tm.ln_wp - 0.5 * (Z as f64 * LN_2PI + u.log_det + maha);
                    nus[m] = v;
                    updates[m] = Some(u);
                }
                if terms[..nt].iter().all(|&t| t == f64::NEG_INFINITY) {
                    continue;
                }
                let lse = log_sum_exp(&terms[..nt]);
                let start = ws.det_types.len();
                for (m, td) in prior.iter().enumerate() {
                    ws.det_types.push(match &updates[m] {
                        Some(u) if terms[m] > f64::NEG_INFINITY => {
                            TypeDensity { ln_w: terms[m] - lse, mean: td.mean + u.k * nus[m], cov: u.cov }
                        }
                        _ => TypeDensity { ln_w: f64::NEG_INFINITY, ..*td },
                    });
                }
                let mut child = GaussianBernoulli { r: 1.0, ..*b };
                most_likely(&mut child, &ws.det_types[start..]);
                ws.det.push(Detection { j, ln_nu: ln_r + lse, child });
            }
        }
        ws.det_start.push(ws.det.len());
        chol
    }

    /// Step ii with every mapped type's density in the measurement's Bernoulli.
    pub(super) fn births_typed(&mut self, l_u: &SMatrix<f64, X, X>, nt: usize) {
        let (model, ws, mu, s, undetected) = (&self.model, &mut self.ws, self.mean, &self.params, &self.undetected);
        ws.ln_nu_new.clear();
        ws.born.clear();
        ws.born_types.clear();
        let n = self.n_s + Z;
        let sub = |a: &SVector<f64, M>, b: &SVector<f64, M>| a - b;
        let noise = self.per_measurement.then_some(&self.noise[..]);
        for (j, zj) in self.z.iter().enumerate() {
            let own = noise.and_then(|n| lower_factor(&(n[j] * s.noise_inflation)));
            let start = ws.born_types.len();
            let mut e = [0.0; MAX_TYPES];
            let mut e_sum = 0.0;
            for (m, &mark) in model.marks().iter().take(nt).enumerate() {
                let l_ru = match noise {
                    None => self.l_ru[m].as_ref(),
                    Some(_) => own.as_ref(),
                };
                let l_ru = l_ru.filter(|_| model.mapped(mark));
                let Some(l_ru) = l_ru else {
                    ws.born_types.push(TypeDensity {
                        ln_w: f64::NEG_INFINITY,
                        mean: SVector::zeros(),
                        cov: SMatrix::identity(),
                    });
                    continue;
                };
                let pose = PosePoints::new(n, &mu, l_u, |x| model.inverse(x, zj, mark).m, sub);
                let input = InputPoints::new(n, zj, l_ru, &pose.y0, |z| model.inverse(&mu, z, mark).m, sub);
                let pm = PairMoments::new(n, &pose, &input);
                let mean = pose.y0 + pm.dmean;
                let lambda = s.undetected_intensity * undetected.birth_multiplier(&mean, &pm.cov, m);
                let integral = match noise {
                    None => model.birth_integral(&mu, zj, mark),
                    Some(n) => model.birth_integral_with_noise(&mu, zj, mark, &n[j]),
                };
                e[m] = model.detection_probability(&mu, &mean, &pm.cov, mark) * lambda * integral;
                e_sum += e[m];
                ws.born_types.push(TypeDensity { ln_w: 0.0, mean, cov: pm.cov });
            }
            for (m, td) in ws.born_types[start..].iter_mut().enumerate() {
                td.ln_w = if e_sum > 0.0 && e[m] > 0.0 { (e[m] / e_sum).ln() } else { f64::NEG_INFINITY };
            }
            let nu = e_sum + model.clutter_intensity(zj).max(s.min_clutter_intensity);
            ws.ln_nu_new.push(nu.ln());
            // No type gives a density: a Bernoulli of existence 0, pruned in the merge.
            let mut b = GaussianBernoulli {
                r: (e_sum / nu).clamp(0.0, 1.0),
                mean: SVector::zeros(),
                cov: SMatrix::identity(),
                mark: 0,
            };
            if e_sum > 0.0 {
                most_likely(&mut b, &ws.born_types[start..]);
            }
            ws.born.push(b);
        }
    }

    /// Step 5's TOMB/P with the per-type densities (see [`Self::merge`]).
    pub(super) fn merge_typed(&mut self, solved: bool, nt: usize) {
        let ws = &mut self.ws;
        ws.next.clear();
        ws.next_types.clear();
        let mut row = 0;
        for i in 0..self.bernoullis.len() {
            let (d0, d1) = (ws.det_start[i], ws.det_start[i + 1]);
            let missed = (&ws.missed[i], &ws.missed_types[i * nt..(i + 1) * nt]);
            let start = ws.next_types.len();
            let merged = if d0 < d1 && ws.rows.get(row) == Some(&i) {
                row += 1;
                let merged = if solved {
                    let p = ws.lbp.track_marginals(row - 1);
                    let dets = (d0..d1).map(|k| {
                        let d = &ws.det[k];
                        (p[d.j + 1], &d.child, &ws.det_types[k * nt..(k + 1) * nt])
                    });
                    let children = std::iter::once((p[0], missed.0, missed.1)).chain(dets);
                    tomb_merge_typed(children, nt, &mut ws.next_types).ok()
                } else {
                    None
                };
                merged.unwrap_or_else(|| {
                    ws.next_types.truncate(start);
                    ws.next_types.extend_from_slice(missed.1);
                    *missed.0
                })
            } else {
                ws.next_types.extend_from_slice(missed.1);
                *missed.0
            };
            // An anchor is known: it keeps its exact position, zero covariance and r = 1.
            let b = &self.bernoullis[i];
            if !self.model.mapped(S::Mark::from_index(b.mark)) {
                ws.next.push(*b);
                ws.next_types.truncate(start);
                ws.next_types.extend_from_slice(&self.types[i * nt..(i + 1) * nt]);
            } else if merged.r >= self.params.bernoulli_prune {
                ws.next.push(merged);
            } else {
                ws.next_types.truncate(start);
            }
        }
        for (j, b) in ws.born.iter().enumerate() {
            let p0 = if solved { ws.lbp.new_marginals().get(j).copied().unwrap_or(1.0) } else { 1.0 };
            if let Ok(r) = tomb_new_track(p0, b.r)
                && r >= self.params.bernoulli_prune
            {
                ws.next.push(GaussianBernoulli { r, ..*b });
                ws.next_types.extend_from_slice(&ws.born_types[j * nt..(j + 1) * nt]);
            }
        }
        std::mem::swap(&mut self.bernoullis, &mut ws.next);
        std::mem::swap(&mut self.types, &mut ws.next_types);
    }
}
