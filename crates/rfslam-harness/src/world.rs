//! The list of worlds: every world is declared once, in one line of the `worlds!` list, and every
//! layer that runs a filter (the job runner of a sweep, `rfslam run`, `rfslam simulate`)
//! goes through it: a world brings its vehicle and sensor models, its data set's model
//! tables, its scenario, the data set of a run and the filters' models of a data set.
//!
//! A world is a type implementing [`World`]; [`WorldKind`] names the worlds, and
//! [`WorldKind::visit`] calls a [`Visitor`] with the world's type, so that code written once,
//! generic over the world, serves every world.
//!
//! Adding a world (or a planar sensor model): its model file, then one line in `worlds!`.

use std::any::Any;
use std::marker::PhantomData;
use std::sync::Arc;

use rfslam_core::model::{
    BearingOnlyModel, RadioSensor, RadioVehicle, RangeBearingModel, RelativePositionModel, StateComponent,
    VehicleModel, WorldVehicle,
};
use rfslam_core::{InvertibleSensorModel, Motion, PlanarSensor, PlanarSensorModel, SensorModel, WorldModels};
use rfslam_data::{DataError, Dataset, DatasetModels, ModelConfig, RadioModels, RadioScenario, ScenarioConfig};
use rfslam_sim::ScenarioData;

use crate::memory::JobSize;

/// A world: the vehicle and sensor models its filters run on (states of `X` components,
/// landmarks of `M` coordinates, measurements of `Z` components), the model tables its data
/// sets carry, its scenario, and how a scenario becomes the data set of a run and a data set
/// the filters' models.
pub trait World<const X: usize, const M: usize, const Z: usize>: 'static {
    /// The world's name, as data sets (`dataset.toml`'s `world`) and outputs name it.
    const NAME: &'static str;
    /// The vehicle model.
    type Vehicle: WorldVehicle<X>;
    /// The sensor model.
    type Sensor: InvertibleSensorModel<X, M, Z>;
    /// The model tables of its data sets (`dataset.toml`).
    type Models: DatasetModels + Send + Sync;
    /// A scenario of the world, validated, with what it loads once (a generated world's
    /// landmarks and trajectory).
    type Scenario: Any + Send + Sync;

    /// The data set of run `seed` of the scenario `sc`.
    fn dataset(sc: &Self::Scenario, seed: u64) -> Result<Dataset<Self::Models, X, M, Z>, DataError>;

    /// The models the filters assume on the scenario `sc` (those of its every data set),
    /// built from the scenario alone: what an experiment's filters are checked against.
    #[allow(clippy::type_complexity)]
    fn scenario_models(sc: &Self::Scenario) -> Result<WorldModels<Self::Vehicle, Self::Sensor, X, M, Z>, DataError>;

    /// The models the filters assume on the data set `ds`.
    #[allow(clippy::type_complexity)]
    fn models(
        ds: &Dataset<Self::Models, X, M, Z>,
    ) -> Result<WorldModels<Self::Vehicle, Self::Sensor, X, M, Z>, DataError>;

    /// The sizes of a job on the scenario `sc` (its scans, landmarks and clutter), from
    /// which its memory is estimated before it starts ([`crate::memory::JobMemory::of`]).
    fn job_size(sc: &Self::Scenario) -> Result<JobSize, DataError>;

    /// A small scenario of the world, valid as it is, whose run 1 is the template data set of
    /// `rfslam init-dataset --world NAME` (every file with its columns and real values).
    fn template() -> Result<Self::Scenario, DataError>;

    /// What each state component is (the vehicle model's).
    fn components(models: &WorldModels<Self::Vehicle, Self::Sensor, X, M, Z>) -> [StateComponent; X] {
        models.vehicle.model.components()
    }

    /// [`World::models`] of the data set `ds`, checked against its scans: each scan's source
    /// (`scans.csv`'s `source`) is one the sensor has ([`SensorModel::sources`]).
    #[allow(clippy::type_complexity)]
    fn dataset_models(
        ds: &Dataset<Self::Models, X, M, Z>,
    ) -> Result<WorldModels<Self::Vehicle, Self::Sensor, X, M, Z>, DataError> {
        let models = Self::models(ds)?;
        let sources = models.sensor.sources();
        if let Some(k) = ds.scans.iter().position(|s| s.source >= sources) {
            return Err(DataError::Mismatch(format!(
                "data set `{}`: scan {k} (scans.csv) is of source {}, but the {} world's sensor has {sources} source(s)",
                ds.meta.name,
                ds.scans[k].source,
                Self::NAME
            )));
        }
        Ok(models)
    }
}

/// A planar world: the planar vehicle (the odometry's motion model) and the planar sensor
/// model `S` (measurements of `Z` components), the planar scenarios and data sets
/// (`[motion]`, `[sensor]`, `[detection]`, `[clutter]`).
pub struct PlanarWorld<S>(PhantomData<S>);

/// A planar scenario with its world, loaded once (none for a recorded data set or Victoria
/// Park).
#[derive(Debug, Clone)]
pub struct PlanarScenario {
    /// The scenario file, validated.
    pub config: ScenarioConfig,
    /// Its world.
    pub world: Option<Arc<rfslam_sim::World>>,
}

impl<S: PlanarSensorModel<Z>, const Z: usize> World<3, 2, Z> for PlanarWorld<S> {
    const NAME: &'static str = S::PLANAR.name;
    type Vehicle = Motion;
    type Sensor = S;
    type Models = ModelConfig;
    type Scenario = PlanarScenario;

    fn dataset(sc: &PlanarScenario, seed: u64) -> Result<Dataset<ModelConfig, 3, 2, Z>, DataError> {
        sc.config.dataset_of::<S, Z>(sc.world.as_deref(), seed)
    }

    fn scenario_models(sc: &PlanarScenario) -> Result<WorldModels<Motion, S, 3, 2, Z>, DataError> {
        Ok(sc.config.models_in::<Z>(sc.world.as_deref())?.world::<S>())
    }

    fn models(ds: &Dataset<ModelConfig, 3, 2, Z>) -> Result<WorldModels<Motion, S, 3, 2, Z>, DataError> {
        Ok(ds.models().world::<S>())
    }

    /// From the loaded world and the scenario's clutter rate, without building the models
    /// (which may read a data set's files again).
    fn job_size(sc: &PlanarScenario) -> Result<JobSize, DataError> {
        Ok(JobSize::generated(sc.world.as_deref(), sc.config.clutter.rate))
    }

    /// A procedural world of 6 landmarks and 30 scans with the embedded default's noise and
    /// clutter, the sensor `S` and its noise keys (0.3 for a key in degrees, 0.8 otherwise:
    /// the published range-bearing sensor's values).
    fn template() -> Result<PlanarScenario, DataError> {
        let mut sensor = String::new();
        if !S::PLANAR.is_default() {
            sensor.push_str(&format!("model = \"{}\"\n", S::PLANAR.name));
        }
        for k in S::PLANAR.noise {
            sensor.push_str(&format!("{} = {}\n", k.key, if k.degrees { "0.3" } else { "0.8" }));
        }
        let config =
            ScenarioConfig::from_toml_str(&PLANAR_TEMPLATE.replace("{sensor}", &sensor), "init-dataset template")?;
        let world = rfslam_sim::ScenarioData::load_world(&config)?.map(Arc::new);
        Ok(PlanarScenario { config, world })
    }
}

/// The planar worlds' template scenario: the embedded default's noise and clutter on a small
/// procedural world (6 landmarks, 30 scans), so that the files stay short enough to read;
/// `{sensor}` is the sensor's model and noise keys.
const PLANAR_TEMPLATE: &str = r#"name = "my-dataset"

[world]
kind = "procedural"
seed = 1
steps = 30
dt = 1.0
speed = 1.0
max_turn_rate_deg = 1.0
extent = 60.0
landmarks = 6

[motion]
model = "velocity"
sigma_v = 0.8
sigma_omega_deg = 0.5

[sensor]
max_range = 40.0
half_angle_deg = 90.0
{sensor}
[detection]
model = "constant"
pd = 0.95

[clutter]
rate = 1.0
intensity = "cartesian"
"#;

/// The 5G mmWave world of the PMBM-SLAM paper (\[Kim2022\] Section VI-A): the radio vehicle
/// (`[x, y, z, heading, clock bias]`) and the TOA/DOD/DOA sensor, landmarks of three types
/// in 3-D, the base station known.
pub struct Radio5g;

impl World<5, 3, 5> for Radio5g {
    const NAME: &'static str = "radio5g";
    type Vehicle = RadioVehicle;
    type Sensor = RadioSensor;
    type Models = RadioModels;
    type Scenario = RadioScenario;

    fn dataset(sc: &RadioScenario, seed: u64) -> Result<rfslam_sim::RadioDataset, DataError> {
        rfslam_sim::radio_dataset(sc, seed)
    }

    fn scenario_models(sc: &RadioScenario) -> Result<rfslam_sim::RadioWorldModels, DataError> {
        let world = rfslam_sim::RadioWorld::from_scenario(sc);
        Ok(WorldModels {
            vehicle: rfslam_sim::radio_filters_vehicle(sc, &world.x0),
            sensor: rfslam_sim::radio_sensor(sc, true),
            landmark_types: world.landmarks.iter().map(|l| (l.0, l.2)).collect(),
        })
    }

    fn models(ds: &rfslam_sim::RadioDataset) -> Result<rfslam_sim::RadioWorldModels, DataError> {
        rfslam_sim::radio_world_models(ds)
    }

    fn job_size(sc: &RadioScenario) -> Result<JobSize, DataError> {
        let world = rfslam_sim::RadioWorld::from_scenario(sc);
        Ok(JobSize {
            scans: (world.steps() + 1) as f64,
            landmarks: world.landmarks.len() as f64,
            clutter_rate: sc.clutter.rate.max(0.0),
        })
    }

    /// The published world (every key at its default).
    fn template() -> Result<RadioScenario, DataError> {
        RadioScenario::from_toml_str("name = \"my-dataset\"\n\n[world]\nkind = \"radio5g\"\n", "init-dataset template")
    }
}

/// Code generic over the world, called with a world's type by [`WorldKind::visit`].
pub trait Visitor {
    /// What the visit gives.
    type Output;

    /// The visit of the world `W`.
    fn visit<W: World<X, M, Z>, const X: usize, const M: usize, const Z: usize>(self) -> Self::Output;
}

/// Declares the list of worlds: each line is a variant of [`WorldKind`], the world's type
/// and its dimensions `[X, M, Z]`.
macro_rules! worlds {
    ($($(#[$doc:meta])* $variant:ident => $world:ty, [$x:literal, $m:literal, $z:literal];)*) => {
        /// Every world, by name ([`World::NAME`]).
        #[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
        pub enum WorldKind {
            $($(#[$doc])* $variant,)*
        }

        impl WorldKind {
            /// Every world, in the order of the list.
            pub const ALL: &'static [WorldKind] = &[$(WorldKind::$variant,)*];

            /// The world's name.
            pub fn name(self) -> &'static str {
                match self {
                    $(WorldKind::$variant => <$world as World<$x, $m, $z>>::NAME,)*
                }
            }

            /// Calls `v` with this world's type.
            pub fn visit<V: Visitor>(self, v: V) -> V::Output {
                match self {
                    $(WorldKind::$variant => v.visit::<$world, $x, $m, $z>(),)*
                }
            }
        }
    };
}

worlds! {
    /// The planar range-bearing sensor (\[Kaltiokallio2024\] eq. 50): the papers' 2-D worlds
    /// and Victoria Park.
    RangeBearing => PlanarWorld<RangeBearingModel>, [3, 2, 2];
    /// The planar relative-position sensor.
    RelativePosition => PlanarWorld<RelativePositionModel>, [3, 2, 2];
    /// The planar bearing-only sensor.
    BearingOnly => PlanarWorld<BearingOnlyModel>, [3, 2, 1];
    /// The 5G mmWave radio world of \[Kim2022\].
    Radio5g => Radio5g, [5, 3, 5];
}

impl WorldKind {
    /// The world of the name `name`.
    pub fn from_name(name: &str) -> Option<WorldKind> {
        WorldKind::ALL.iter().copied().find(|w| w.name() == name)
    }

    /// The names of every world, comma separated (for error messages).
    pub fn names() -> String {
        WorldKind::ALL.iter().map(|w| w.name()).collect::<Vec<_>>().join(", ")
    }

    /// The world of a planar scenario or data set's `[sensor] model` (every planar sensor has
    /// one: a test checks the list against [`rfslam_core::model::PLANAR_SENSORS`]).
    pub fn planar(sensor: PlanarSensor) -> Option<WorldKind> {
        WorldKind::from_name(sensor.name)
    }
}

/// A scenario of some world, parsed and validated: its world and the world's
/// [`World::Scenario`].
#[derive(Clone)]
pub struct WorldScenario {
    /// The world.
    pub kind: WorldKind,
    scenario: Arc<dyn Any + Send + Sync>,
}

impl std::fmt::Debug for WorldScenario {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("WorldScenario").field("kind", &self.kind).finish_non_exhaustive()
    }
}

impl WorldScenario {
    /// A planar scenario with its loaded world.
    pub fn planar(config: ScenarioConfig, world: Option<Arc<rfslam_sim::World>>) -> Result<WorldScenario, DataError> {
        let sensor = config.sensor.model;
        let kind = WorldKind::planar(sensor)
            .ok_or_else(|| DataError::Mismatch(format!("the planar sensor `{}` has no world", sensor.name)))?;
        Ok(WorldScenario { kind, scenario: Arc::new(PlanarScenario { config, world }) })
    }

    /// A radio scenario.
    pub fn radio(sc: RadioScenario) -> WorldScenario {
        WorldScenario { kind: WorldKind::Radio5g, scenario: Arc::new(sc) }
    }

    /// The world `W`'s scenario; `None` when this is a scenario of another world.
    pub fn get<W: World<X, M, Z>, const X: usize, const M: usize, const Z: usize>(&self) -> Option<&W::Scenario> {
        self.scenario.downcast_ref::<W::Scenario>()
    }

    /// The planar scenario, when this is one.
    pub fn planar_config(&self) -> Option<&ScenarioConfig> {
        self.scenario.downcast_ref::<PlanarScenario>().map(|p| &p.config)
    }

    /// The radio scenario, when this is one.
    pub fn radio_config(&self) -> Option<&RadioScenario> {
        self.scenario.downcast_ref::<RadioScenario>()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every planar sensor of `rfslam_core::model::PLANAR_SENSORS` has its world in the list,
    /// of its name and of as many measurement components.
    #[test]
    fn every_planar_sensor_has_a_world() {
        struct Dims;
        impl Visitor for Dims {
            type Output = usize;
            fn visit<W: World<X, M, Z>, const X: usize, const M: usize, const Z: usize>(self) -> usize {
                Z
            }
        }
        for sensor in rfslam_core::model::PLANAR_SENSORS {
            let kind = WorldKind::planar(*sensor).unwrap_or_else(|| panic!("{} has no world", sensor.name));
            assert_eq!(kind.name(), sensor.name);
            assert_eq!(kind.visit(Dims), sensor.dim(), "{}", sensor.name);
            assert_eq!(sensor.noise.len(), sensor.dim(), "{}: one noise key per component", sensor.name);
        }
    }
}
