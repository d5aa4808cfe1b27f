//! The parameter vocabulary every filter shares: the error naming a key, the ranges a value
//! may take (stated once, here), the parameters of the particle population every RBPF of
//! rfslam has ([`RbpfParams`]), and the key list of a parameter table taken from its serde
//! implementation.
//!
//! A filter's parameter table is one flat TOML table. A filter whose parameters are made of
//! parts (its own keys, [`RbpfParams`], a proposal's) declares them with `#[serde(flatten)]`
//! and `#[serde(remote = "Self")]`, and [`flat_params!`](crate::flat_params) writes its
//! `Serialize` and `Deserialize`: missing keys take the *outer* type's defaults (so one
//! filter may resample every step by default and another at 20 % ESS with the same
//! [`RbpfParams`]), and [`check_keys`] rejects a key no part accepts, listing every key the
//! filter accepts.

use nalgebra::{Matrix3, SMatrix, SVector};
use serde::de::Error as _;
use serde::{Deserialize, Deserializer, Serialize};

use crate::model::{Vehicle, VehicleModel};
use crate::motion::propagate_with_covariance;
use crate::rbpf::{ResampleRule, ResampleScheme};
use crate::types::ControlSegment;

/// An invalid filter parameter: the key and what is wrong with it.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{key}: {message}")]
pub struct ParamError {
    /// Parameter name (as in the configuration).
    pub key: String,
    /// What is wrong.
    pub message: String,
}

impl ParamError {
    /// A new error for `key`.
    pub fn new(key: impl Into<String>, message: impl Into<String>) -> Self {
        ParamError { key: key.into(), message: message.into() }
    }
}

/// An interval a real parameter must lie in. An infinite end is always open, so NaN and
/// the infinities are outside every interval with an infinite end.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Interval {
    lo: f64,
    lo_open: bool,
    hi: f64,
    hi_open: bool,
}

impl Interval {
    /// Any finite number.
    pub const FINITE: Interval = Interval { lo: f64::NEG_INFINITY, lo_open: true, hi: f64::INFINITY, hi_open: true };
    /// `(0, inf)`, finite: weights, gates, thresholds, spreads.
    pub const POSITIVE: Interval = Interval { lo: 0.0, lo_open: true, hi: f64::INFINITY, hi_open: true };
    /// `[0, inf)`, finite: rates, tolerances, jitter.
    pub const NON_NEGATIVE: Interval = Interval { lo: 0.0, lo_open: false, hi: f64::INFINITY, hi_open: true };
    /// `(0, 1]`: a probability that may not be zero (detection, survival).
    pub const PROBABILITY: Interval = Interval { lo: 0.0, lo_open: true, hi: 1.0, hi_open: false };
    /// `[0, 1]`: a fraction or a probability that may be zero.
    pub const UNIT: Interval = Interval { lo: 0.0, lo_open: false, hi: 1.0, hi_open: false };
    /// `[0, 1)`: a pruning threshold (1 would prune everything).
    pub const BELOW_ONE: Interval = Interval { lo: 0.0, lo_open: false, hi: 1.0, hi_open: true };
    /// `(0, 1)`: a probability that may be neither 0 nor 1 (a prior).
    pub const OPEN_UNIT: Interval = Interval { lo: 0.0, lo_open: true, hi: 1.0, hi_open: true };

    /// `[lo, hi]`.
    pub const fn closed(lo: f64, hi: f64) -> Interval {
        Interval { lo, lo_open: false, hi, hi_open: false }
    }

    /// `[-m, m]`: a signed value bounded in magnitude.
    pub const fn magnitude(m: f64) -> Interval {
        Interval::closed(-m, m)
    }

    /// The same lower end, and `hi` (closed) as the upper end: `POSITIVE.up_to(1e6)` is
    /// `(0, 1e6]`.
    pub const fn up_to(self, hi: f64) -> Interval {
        Interval { hi, hi_open: false, ..self }
    }

    /// `(0, MAX_PARAM]`: a weight, intensity, gate, threshold or spread.
    pub const BOUNDED_POSITIVE: Interval = Interval::POSITIVE.up_to(MAX_PARAM);
    /// `[0, MAX_PARAM]`: a rate, tolerance or jitter.
    pub const BOUNDED_NON_NEGATIVE: Interval = Interval::NON_NEGATIVE.up_to(MAX_PARAM);

    /// Whether `v` lies in the interval (never for NaN).
    pub fn contains(&self, v: f64) -> bool {
        let above = if self.lo_open { v > self.lo } else { v >= self.lo };
        let below = if self.hi_open { v < self.hi } else { v <= self.hi };
        above && below
    }

    /// `Ok` if `v` lies in the interval, else an error naming `key`, the interval and `v`.
    pub fn check(&self, key: &str, v: f64) -> Result<(), ParamError> {
        if self.contains(v) { Ok(()) } else { Err(ParamError::new(key, format!("must be {self} (got {})", short(v)))) }
    }

    /// [`Interval::check`] of an optional value (`None` passes).
    pub fn check_opt(&self, key: &str, v: Option<f64>) -> Result<(), ParamError> {
        v.map_or(Ok(()), |v| self.check(key, v))
    }
}

impl std::fmt::Display for Interval {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let op = |open: bool, strict: &'static str, wide: &'static str| if open { strict } else { wide };
        match (self.lo.is_finite(), self.hi.is_finite()) {
            (false, false) => write!(f, "finite"),
            (true, false) => write!(f, "finite and {} {}", op(self.lo_open, ">", ">="), short(self.lo)),
            (false, true) => write!(f, "finite and {} {}", op(self.hi_open, "<", "<="), short(self.hi)),
            (true, true) => write!(
                f,
                "in {}{}, {}{}",
                op(self.lo_open, "(", "["),
                short(self.lo),
                short(self.hi),
                op(self.hi_open, ")", "]")
            ),
        }
    }
}

/// The largest magnitude of a filter's real parameter that has no natural bound (a weight,
/// intensity, rate, gate, threshold, jitter or spread): a million, far beyond any meaningful
/// setting (the defaults are at most 50), and small enough that the sums and squares a
/// filter forms from it over a run stay finite (`birth_weight` or `q_jitter` of 1e308
/// overflowed to `inf`).
pub const MAX_PARAM: f64 = 1e6;

/// `v` as a person reads it in a message: plain (`0.25`, `1000000`) unless it is very large
/// or very small, then in exponent form (`1e9`, `1e308`, `-1e-300`) rather than hundreds of
/// digits.
pub fn short(v: f64) -> String {
    let a = v.abs();
    if a.is_finite() && a != 0.0 && !(1e-6..1e9).contains(&a) { format!("{v:e}") } else { format!("{v}") }
}

/// The inclusive range of a count parameter (iterations, sweeps, hypotheses, features).
/// Every count has an upper end, so that no setting can make one step run for hours or
/// allocate without bound; the ends are stated once, here, and in `docs/configuration.md`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct CountRange {
    lo: usize,
    hi: usize,
}

impl CountRange {
    /// `[1, 1000]`: iterations of an iterated update (IPL), children per particle.
    pub const ITERATIONS: CountRange = CountRange { lo: 1, hi: 1_000 };
    /// `[1, 1000]`: hypotheses, ranked assignments, mixture features kept per particle.
    pub const HYPOTHESES: CountRange = CountRange { lo: 1, hi: 1_000 };
    /// `[1, 10000]`: Gibbs sweeps per particle and step.
    pub const SWEEPS: CountRange = CountRange { lo: 1, hi: 10_000 };

    /// `[lo, hi]`.
    pub const fn new(lo: usize, hi: usize) -> CountRange {
        CountRange { lo, hi }
    }

    /// The same upper end with lower end `lo`.
    pub const fn from(self, lo: usize) -> CountRange {
        CountRange { lo, hi: self.hi }
    }

    /// Whether `n` lies in the range.
    pub fn contains(&self, n: usize) -> bool {
        (self.lo..=self.hi).contains(&n)
    }

    /// `Ok` if `n` lies in the range, else an error naming `key`, the range and `n`.
    pub fn check(&self, key: &str, n: usize) -> Result<(), ParamError> {
        if self.contains(n) {
            Ok(())
        } else {
            Err(ParamError::new(key, format!("must be an integer in [{}, {}] (got {n})", self.lo, self.hi)))
        }
    }
}

/// The most particles a filter may have, whatever the machine: 10^8 particles of 56 bytes,
/// held twice, are 11 GB before any map (the memory check of a sweep refuses less where the
/// machine's memory is known).
pub const MAX_PARTICLES: usize = 100_000_000;

/// `Ok` if there is at least one particle and at most [`MAX_PARTICLES`] (the error names the
/// key `particles`).
pub fn particles(n: usize) -> Result<(), ParamError> {
    match n {
        0 => Err(ParamError::new("particles", "at least one particle")),
        n if n > MAX_PARTICLES => {
            Err(ParamError::new("particles", format!("at most {MAX_PARTICLES} particles (got {n})")))
        }
        _ => Ok(()),
    }
}

/// `Ok` if every entry of a diagonal jitter is in `[0, MAX_PARAM]`.
pub fn jitter(key: &str, diagonal: &[f64; 3]) -> Result<(), ParamError> {
    let range = Interval::BOUNDED_NON_NEGATIVE;
    if diagonal.iter().all(|&j| range.contains(j)) {
        Ok(())
    } else {
        Err(ParamError::new(key, format!("entries must be {range} (got {diagonal:?})")))
    }
}

/// The parameters of the particle population shared by every Rao-Blackwellised particle
/// filter of rfslam (the RB-PHD filters, FastSLAM, the delta-GLMB filters): when to resample
/// and the jitter of the predicted pose covariance. Flattened into each filter's table; the
/// filter's own `Default` sets its published `resample_ess_fraction`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct RbpfParams {
    /// Resample (systematic) when `ESS <= resample_ess_fraction * N`, `N` the (nominal)
    /// number of particles; 0: never (unless the filter forces it), 1: every step.
    pub resample_ess_fraction: f64,
    /// Resample when `ESS <=` this absolute value instead (Victoria Park: 1); none by default.
    pub resample_ess: Option<f64>,
    /// Jitter added to the diagonal of the predicted pose covariance (m^2, m^2, rad^2): two
    /// control noises drive three pose coordinates, so `F_u Q_u F_u^T` has rank 2 and its
    /// density is undefined without it (\[PHD-SLAM-3.0-code\]: `[1e-9, 1e-9, 1e-18]`).
    pub q_jitter: [f64; 3],
    /// How the parents are drawn: `"systematic"` (none: the default) or `"stratified"`, the
    /// scheme of the public PHD-SLAM 3.0 code ([`crate::rbpf::ResampleScheme::Stratified`]).
    pub resampling: Option<ResampleScheme>,
}

impl Default for RbpfParams {
    fn default() -> Self {
        RbpfParams { resample_ess_fraction: 0.2, resample_ess: None, q_jitter: [1e-9, 1e-9, 1e-18], resampling: None }
    }
}

impl RbpfParams {
    /// The defaults with another `resample_ess_fraction`.
    pub fn with_fraction(resample_ess_fraction: f64) -> Self {
        RbpfParams { resample_ess_fraction, ..Default::default() }
    }

    /// Checks ranges, with `particles` the (nominal) number of particles. `resample_ess` is
    /// at most `N` (above it every step would resample), except with one particle, which is
    /// never resampled: there any non-negative value passes, so one absolute threshold can
    /// serve a sweep over `particles = [1, 5, 10]`.
    pub fn validate(&self, particles: usize) -> Result<(), ParamError> {
        self::particles(particles)?;
        Interval::UNIT.check("resample_ess_fraction", self.resample_ess_fraction)?;
        let ess_range = if particles == 1 { Interval::NON_NEGATIVE } else { Interval::closed(0.0, particles as f64) };
        ess_range.check_opt("resample_ess", self.resample_ess)?;
        jitter("q_jitter", &self.q_jitter)
    }

    /// The ESS at or below which `n` particles are resampled.
    pub fn threshold(&self, n: usize) -> f64 {
        self.resample_ess.unwrap_or(self.resample_ess_fraction * n as f64)
    }

    /// Resampling of `n` particles (to `n`) when the ESS falls to [`RbpfParams::threshold`].
    pub fn rule(&self, n: usize) -> ResampleRule {
        ResampleRule {
            threshold: self.threshold(n),
            force: false,
            n_out: n,
            scheme: self.resampling.unwrap_or_default(),
        }
    }

    /// `diag(q_jitter)`.
    pub fn jitter(&self) -> Matrix3<f64> {
        Matrix3::from_diagonal(&self.q_jitter.into())
    }

    /// The prediction every RBPF makes for a particle (or a family of identical copies), for
    /// a vehicle of any state: `x_bar = f(x_{k-1}, u)` through the odometry segments and
    /// `Q = F_u Q_u F_u^T` (plus the model's additive process noise) plus
    /// [`RbpfParams::jitter_for`] (`diag(q_jitter)` for the planar pose).
    pub fn predict_state<V: VehicleModel<X, 3>, const X: usize>(
        &self,
        vehicle: &Vehicle<V, X>,
        x: &SVector<f64, X>,
        odometry: &[ControlSegment],
    ) -> (SVector<f64, X>, SMatrix<f64, X, X>) {
        let (x_bar, q) = propagate_with_covariance(&vehicle.model, x, odometry, &vehicle.control_noise);
        (x_bar, q + self.jitter_for(&vehicle.model))
    }

    /// The jitter of a vehicle state: `q_jitter`'s three variances on the state's x, y and
    /// heading components, and none on any other (height, clock bias) or on a component the
    /// model does not estimate ([`VehicleModel::planar_diagonal`]). `diag(q_jitter)` for the
    /// planar pose.
    pub fn jitter_for<V: VehicleModel<X, 3>, const X: usize>(&self, vehicle: &V) -> SMatrix<f64, X, X> {
        vehicle.planar_diagonal(self.q_jitter)
    }
}

/// Every key the parameter table `P` accepts (its own and its flattened parts'), sorted,
/// taken from serialising `P::default()` (optional keys whose default is none included).
pub fn keys<P: Serialize + Default>() -> Vec<String> {
    let mut keys = match serde_json::to_value(P::default()) {
        Ok(serde_json::Value::Object(map)) => map.keys().cloned().collect(),
        _ => Vec::new(),
    };
    keys.sort();
    keys
}

/// Rejects a key of `table` that `P` does not accept, naming it and listing every key `P`
/// accepts (serde's "unknown field" wording).
pub fn check_keys<P: Serialize + Default>(table: &toml::Table) -> Result<(), ParamError> {
    let accepted = keys::<P>();
    match table.keys().find(|k| !accepted.contains(k)) {
        None => Ok(()),
        Some(k) => {
            let list = accepted.iter().map(|a| format!("`{a}`")).collect::<Vec<_>>().join(", ");
            let expected =
                if list.is_empty() { "there are no fields".to_string() } else { format!("expected one of {list}") };
            Err(ParamError::new(k.clone(), format!("unknown field `{k}`, {expected}")))
        }
    }
}

/// Reads a parameter table: [`check_keys`], then serde. A type error names the key serde
/// names (else `params`). The harness's registry does the same with a finer search for the
/// key of a type error.
pub fn from_table<P: Serialize + serde::de::DeserializeOwned + Default>(table: &toml::Table) -> Result<P, ParamError> {
    check_keys::<P>(table)?;
    toml::Value::Table(table.clone()).try_into::<P>().map_err(|e| {
        let msg = e.message().trim().to_string();
        let key = msg.split('`').nth(1).filter(|k| table.contains_key(*k)).unwrap_or("params").to_string();
        ParamError::new(key, msg)
    })
}

/// The `Deserialize` of a flattened parameter table (what [`flat_params!`](crate::flat_params)
/// writes): reads the table, fills the keys it lacks from `P::default()` (serialised), and
/// hands the whole to `raw`, the serde-derived (`remote = "Self"`) deserializer. Keys of
/// other parts pass through untouched, so a part may itself be flattened.
pub fn with_defaults<'de, D, P>(d: D, raw: fn(toml::Value) -> Result<P, toml::de::Error>) -> Result<P, D::Error>
where
    D: Deserializer<'de>,
    P: Serialize + Default,
{
    let given = toml::Table::deserialize(d)?;
    let mut table = match toml::Value::try_from(P::default()) {
        Ok(toml::Value::Table(t)) => t,
        _ => toml::Table::new(),
    };
    table.extend(given);
    raw(toml::Value::Table(table)).map_err(|e| D::Error::custom(e.message()))
}

/// `Serialize` and `Deserialize` of a parameter table made of `#[serde(flatten)]` parts,
/// declared with `#[derive(Serialize, Deserialize)] #[serde(remote = "Self", default)]` (see
/// the module docs): `flat_params!(MyParams);` or, generic over its parts,
/// `flat_params!(PhdParams<PP>);`.
#[macro_export]
macro_rules! flat_params {
    ($name:ident $(<$($g:ident),+>)?) => {
        impl$(<$($g: ::serde::Serialize),+>)? ::serde::Serialize for $name$(<$($g),+>)? {
            fn serialize<S: ::serde::Serializer>(&self, s: S) -> ::std::result::Result<S::Ok, S::Error> {
                $name::serialize(self, s)
            }
        }

        impl<'de $($(, $g: ::serde::Serialize + ::serde::de::DeserializeOwned + ::std::default::Default),+)?>
            ::serde::Deserialize<'de> for $name$(<$($g),+>)?
        {
            fn deserialize<D: ::serde::Deserializer<'de>>(d: D) -> ::std::result::Result<Self, D::Error> {
                $crate::params::with_defaults(d, $name::deserialize)
            }
        }
    };
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn interval_boundaries() {
        let cases: [(Interval, &[f64], &[f64]); 7] = [
            (Interval::FINITE, &[-1e300, 0.0, 1e300], &[f64::NAN, f64::INFINITY, f64::NEG_INFINITY]),
            (Interval::POSITIVE, &[1e-300, 1.0, f64::MAX], &[0.0, -0.0, -1.0, f64::INFINITY, f64::NAN]),
            (Interval::NON_NEGATIVE, &[0.0, -0.0, 1e-18, 1e300], &[-1e-300, f64::INFINITY, f64::NAN]),
            (Interval::PROBABILITY, &[1e-300, 0.5, 1.0], &[0.0, 1.0 + 1e-15, -1.0, f64::NAN]),
            (Interval::UNIT, &[0.0, 0.5, 1.0], &[-1e-300, 1.0 + 1e-15, f64::NAN]),
            (Interval::BELOW_ONE, &[0.0, 1.0 - 1e-15], &[1.0, -1e-300, f64::NAN]),
            (Interval::OPEN_UNIT, &[1e-300, 1.0 - 1e-15], &[0.0, 1.0, f64::NAN]),
        ];
        for (range, inside, outside) in cases {
            for &v in inside {
                assert_eq!(range.check("k", v), Ok(()), "{v} in {range}");
            }
            for &v in outside {
                let e = range.check("k", v).expect_err(&format!("{v} not in {range}"));
                assert_eq!(e.key, "k");
                assert!(e.message.contains(&range.to_string()) && e.message.contains(&short(v)), "{e}");
            }
        }
        let deg = Interval::closed(0.0, 180.0);
        assert!(deg.contains(0.0) && deg.contains(180.0) && !deg.contains(180.5) && !deg.contains(f64::NAN));
        assert_eq!(Interval::PROBABILITY.to_string(), "in (0, 1]");
        assert_eq!(Interval::POSITIVE.to_string(), "finite and > 0");
        assert_eq!(Interval::BELOW_ONE.check_opt("k", None), Ok(()));
        // Very large or small numbers are written in exponent form, not in hundreds of digits.
        assert_eq!(
            Interval::magnitude(1e9).check("k", 1e308).unwrap_err().message,
            "must be in [-1e9, 1e9] (got 1e308)"
        );
        let shown = [short(1e308), short(-1e-300), short(0.25), short(1e6), short(0.0), short(f64::NAN)];
        assert_eq!(shown, ["1e308", "-1e-300", "0.25", "1000000", "0", "NaN"]);
        // Bounded ranges: the upper end is closed, the lower end kept.
        assert_eq!(Interval::BOUNDED_POSITIVE.to_string(), "in (0, 1000000]");
        assert_eq!(Interval::BOUNDED_NON_NEGATIVE.to_string(), "in [0, 1000000]");
        assert!(Interval::BOUNDED_POSITIVE.contains(MAX_PARAM) && !Interval::BOUNDED_POSITIVE.contains(0.0));
        assert!(!Interval::BOUNDED_NON_NEGATIVE.contains(1e308) && Interval::BOUNDED_NON_NEGATIVE.contains(0.0));
        let m = Interval::magnitude(1e9);
        assert!(m.contains(-1e9) && m.contains(1e9) && !m.contains(1.5e9) && !m.contains(-1e308));
        assert_eq!(Interval::BELOW_ONE.check_opt("k", Some(1.0)).unwrap_err().key, "k");
    }

    #[test]
    fn counts_and_jitter() {
        assert_eq!(CountRange::SWEEPS.check("sweeps", 1), Ok(()));
        assert_eq!(CountRange::SWEEPS.check("sweeps", 10_000), Ok(()));
        assert_eq!(CountRange::SWEEPS.check("sweeps", 0).unwrap_err().key, "sweeps");
        let e = CountRange::SWEEPS.check("sweeps", 10_001).unwrap_err();
        assert_eq!(e.message, "must be an integer in [1, 10000] (got 10001)");
        assert!(CountRange::SWEEPS.from(0).contains(0));
        assert_eq!(particles(1), Ok(()));
        assert_eq!(particles(0).unwrap_err().key, "particles");
        assert_eq!(jitter("q_jitter", &[0.0, 1e-9, 1e-18]), Ok(()));
        assert_eq!(jitter("q_jitter", &[MAX_PARAM, 0.0, 0.0]), Ok(()));
        for bad in [[-1e-300, 0.0, 0.0], [0.0, f64::NAN, 0.0], [0.0, 0.0, f64::INFINITY], [1e308, 0.0, 0.0]] {
            assert_eq!(jitter("q_jitter", &bad).unwrap_err().key, "q_jitter", "{bad:?}");
        }
    }

    #[test]
    fn rbpf_params_ranges_and_threshold() {
        let p = RbpfParams::default();
        assert_eq!(p.validate(1), Ok(()));
        assert_eq!(p.validate(0).unwrap_err().key, "particles");
        assert_eq!(p.threshold(10), 0.2 * 10.0);
        let key = |p: RbpfParams, n| p.validate(n).unwrap_err().key;
        assert_eq!(key(RbpfParams::with_fraction(1.0 + 1e-12), 5), "resample_ess_fraction");
        assert_eq!(key(RbpfParams::with_fraction(-0.1), 5), "resample_ess_fraction");
        assert_eq!(RbpfParams::with_fraction(0.0).validate(5), Ok(()));
        let abs = |e| RbpfParams { resample_ess: Some(e), ..Default::default() };
        assert_eq!(abs(5.0).validate(5), Ok(()));
        assert_eq!(abs(0.0).validate(5), Ok(()));
        assert_eq!(key(abs(5.5), 5), "resample_ess");
        assert_eq!(key(abs(-1.0), 5), "resample_ess");
        // One particle is never resampled: an absolute threshold for larger N passes.
        assert_eq!(abs(2.5).validate(1), Ok(()));
        assert_eq!(key(abs(-1.0), 1), "resample_ess");
        assert_eq!(key(abs(f64::INFINITY), 1), "resample_ess");
        assert_eq!(abs(1.0).threshold(25), 1.0);
        assert_eq!(key(RbpfParams { q_jitter: [0.0, -1.0, 0.0], ..Default::default() }, 5), "q_jitter");
    }

    /// A filter's table: own keys, the shared RBPF keys with another default fraction.
    #[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
    #[serde(remote = "Self", default)]
    struct Own {
        gate: f64,
        cap: Option<usize>,
        #[serde(flatten)]
        rbpf: RbpfParams,
        on: bool,
    }

    impl Default for Own {
        fn default() -> Self {
            Own { gate: 9.0, cap: None, rbpf: RbpfParams::with_fraction(1.0), on: false }
        }
    }

    crate::flat_params!(Own);

    /// A table with a flattened part that is itself flattened (as a PHD variant's).
    #[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
    #[serde(remote = "Self", default)]
    struct Outer<X> {
        #[serde(flatten)]
        own: Own,
        #[serde(flatten)]
        extra: X,
    }

    #[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
    #[serde(deny_unknown_fields, default)]
    struct Extra {
        spread: f64,
    }

    crate::flat_params!(Outer<X>);

    fn table(s: &str) -> toml::Table {
        s.parse().unwrap()
    }

    #[test]
    fn keys_come_from_serde() {
        assert_eq!(
            keys::<Own>(),
            ["cap", "gate", "on", "q_jitter", "resample_ess", "resample_ess_fraction", "resampling"]
        );
        assert_eq!(keys::<Outer<Extra>>().len(), 8);
        assert!(keys::<Outer<Extra>>().contains(&"spread".to_string()));
    }

    /// Missing keys take the outer type's defaults, also through a nested flattened part;
    /// an unknown key is named with every accepted key listed, the shared ones included.
    #[test]
    fn flat_tables_read_with_the_outer_defaults() {
        let own: Own = from_table(&table("gate = 2.0")).unwrap();
        assert_eq!(own, Own { gate: 2.0, ..Default::default() });
        assert_eq!(own.rbpf.resample_ess_fraction, 1.0);
        let outer: Outer<Extra> = from_table(&table("spread = 3\nresample_ess = 2.0\ncap = 4")).unwrap();
        assert_eq!(outer.extra.spread, 3.0);
        assert_eq!(
            (outer.own.cap, outer.own.rbpf.resample_ess, outer.own.rbpf.resample_ess_fraction),
            (Some(4), Some(2.0), 1.0)
        );
        let direct: Outer<Extra> = toml::from_str("on = true").unwrap();
        assert_eq!(direct.own, Own { on: true, ..Default::default() });
        let e = from_table::<Outer<Extra>>(&table("resample_ess_fracton = 0.5")).unwrap_err();
        assert_eq!(e.key, "resample_ess_fracton");
        for k in ["resample_ess_fraction", "q_jitter", "gate", "spread"] {
            assert!(e.message.contains(&format!("`{k}`")), "{e}");
        }
        let e = from_table::<Own>(&table("gate = \"x\"")).unwrap_err();
        assert!(e.message.contains("invalid type"), "{e}");
        let back: toml::Table = toml::Value::try_from(Own::default()).unwrap().try_into().unwrap();
        assert_eq!(from_table::<Own>(&back).unwrap(), Own::default());
    }
}
