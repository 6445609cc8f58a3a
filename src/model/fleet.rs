//! A fleet (docs/model.md#fleet) as a [`Model`]: one block of conditions per vehicle of
//! `[fleet]`'s table, each the vehicle model of that vehicle's study, with the vehicle's id
//! as the first axis (`vehicle`) of every table.
//!
//! The vehicles are prepared once, in parallel, for their conditions' infos, and prepared
//! again when their realisations are computed, a few at a time: a fleet of a thousand keeps
//! in memory the cycles of only the vehicles being realised ([`FleetModel::model`]). A
//! prepared vehicle is a pure function of its study, so whichever thread prepares it, and
//! however often, its realisations are the same bits.
//!
//! Each vehicle's draws are its own: its realisations use the run's seed mixed with the
//! vehicle's id ([`vehicle_seed`]), so two vehicles never share a noise sequence, the
//! fleet's spread across vehicles is not narrowed by common draws, and a vehicle's results
//! do not move when other rows of the table are added, removed or reordered.

use std::collections::VecDeque;
use std::sync::{Arc, Mutex, OnceLock};

use rayon::prelude::*;

use super::vehicle::VehicleModel;
use super::{Axis, AxisValue, ConditionInfo, Layout, Model};
use crate::study::{Study, StudyError};

/// The axis of a fleet's vehicles: each one's id.
pub const VEHICLE_AXIS: &str = "vehicle";

/// The layout of a fleet study: its vehicles' (they differ only in `[vehicle]`), with the
/// vehicle's id as the first axis.
pub fn layout(study: &Study) -> Layout {
    let vs = study.vehicle().expect("a fleet is of vehicles");
    let mut layout = super::vehicle::layout(vs);
    layout.axes.insert(0, Axis::text(VEHICLE_AXIS));
    if let Some(fleet) = study.fleet() {
        layout.context.insert(
            0,
            format!(
                "fleet: {} vehicles of {}",
                fleet.vehicles.len(),
                fleet.written
            ),
        );
    }
    layout
}

/// The seed the realisations of the vehicle called `id` are drawn with: the run's `seed`
/// mixed with the FNV-1a hash of the id by SplitMix64's finaliser (Steele, Lea & Flood
/// 2014).
pub fn vehicle_seed(seed: u64, id: &str) -> u64 {
    let hash = crate::numeric::hash::Fnv1a::of(id.as_bytes());
    let mut z = seed ^ hash.wrapping_mul(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// A vehicle's model, once prepared (its cell filled by whichever thread first needs it).
type Prepared = Arc<OnceLock<Arc<VehicleModel>>>;

/// A vehicle's conditions' infos and draw groups.
type VehicleBlock = (Vec<ConditionInfo>, Vec<usize>);

/// A fleet's model.
pub struct FleetModel {
    study: Study,
    layout: Layout,
    infos: Vec<ConditionInfo>,
    /// Per condition, its draw group (its vehicle's group, offset by the vehicle).
    groups: Vec<usize>,
    /// Conditions per vehicle.
    per_vehicle: usize,
    /// The vehicles prepared most recently, oldest first.
    cache: Mutex<VecDeque<(usize, Prepared)>>,
    /// How many prepared vehicles the cache keeps.
    capacity: usize,
    /// The threads a vehicle is prepared on while its realisations wait.
    pool: rayon::ThreadPool,
}

impl std::fmt::Debug for FleetModel {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("FleetModel")
            .field("vehicles", &(self.infos.len() / self.per_vehicle.max(1)))
            .field("per_vehicle", &self.per_vehicle)
            .finish_non_exhaustive()
    }
}

impl FleetModel {
    /// Prepare every vehicle of `study`'s fleet for its conditions' infos (a vehicle that
    /// cannot be simulated is an error naming it and its row).
    pub fn new(study: &Study) -> Result<Self, StudyError> {
        let fleet = study.fleet().expect("a study with a fleet");
        let layout = layout(study);
        let per_vehicle: Vec<Result<VehicleBlock, StudyError>> = (0..fleet.vehicles.len())
            .into_par_iter()
            .map(|v| {
                let model = VehicleModel::new(&study.fleet_vehicle(v)?)?;
                let id = AxisValue::Text(fleet.vehicles[v].id.clone());
                let infos = (0..model.condition_count())
                    .map(|c| {
                        let mut info = model.condition_info(c).clone();
                        info.axes.insert(0, id.clone());
                        info
                    })
                    .collect();
                let groups = (0..model.condition_count())
                    .map(|c| model.draw_group(c))
                    .collect();
                Ok((infos, groups))
            })
            .collect();
        let (mut infos, mut groups) = (Vec::new(), Vec::new());
        let mut per = None;
        for (v, block) in per_vehicle.into_iter().enumerate() {
            let (block_infos, block_groups) = block?;
            let n = block_infos.len();
            assert_eq!(
                *per.get_or_insert(n),
                n,
                "every vehicle has the same conditions"
            );
            groups.extend(block_groups.into_iter().map(|g| v * n + g));
            infos.extend(block_infos);
        }
        let threads = rayon::current_num_threads();
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .map_err(|e| study.error_at("fleet", format!("cannot start threads: {e}")))?;
        Ok(FleetModel {
            study: study.clone(),
            layout,
            infos,
            groups,
            per_vehicle: per.expect("a fleet has a vehicle"),
            cache: Mutex::new(VecDeque::new()),
            capacity: 2 * threads + 2,
            pool,
        })
    }

    /// The seed of vehicle `v`'s realisations in a run with `seed`.
    fn seed_of(&self, seed: u64, v: usize) -> u64 {
        let fleet = self.study.fleet().expect("a study with a fleet");
        vehicle_seed(seed, &fleet.vehicles[v].id)
    }

    /// Vehicle `v`'s prepared model: from the cache, or prepared now. It is prepared on
    /// a thread of its own pool, which this thread waits for without taking up another task
    /// of the run (one that might wait for this very vehicle).
    fn model(&self, v: usize) -> Arc<VehicleModel> {
        let cell = {
            let mut cache = self.cache.lock().expect("the cache lock is never poisoned");
            match cache.iter().find(|(k, _)| *k == v) {
                Some((_, cell)) => cell.clone(),
                None => {
                    let cell = Arc::new(OnceLock::new());
                    cache.push_back((v, cell.clone()));
                    if cache.len() > self.capacity {
                        cache.pop_front();
                    }
                    cell
                }
            }
        };
        cell.get_or_init(|| {
            std::thread::scope(|s| {
                s.spawn(|| {
                    self.pool.install(|| {
                        let study = self
                            .study
                            .fleet_vehicle(v)
                            .expect("every vehicle was validated when the fleet was read");
                        Arc::new(
                            VehicleModel::new(&study)
                                .expect("every vehicle was prepared when the fleet was read"),
                        )
                    })
                })
                .join()
                .expect("preparing a vehicle does not panic")
            })
        })
        .clone()
    }
}

impl Model for FleetModel {
    fn layout(&self) -> &Layout {
        &self.layout
    }

    fn condition_count(&self) -> usize {
        self.infos.len()
    }

    fn condition_info(&self, c: usize) -> &ConditionInfo {
        &self.infos[c]
    }

    fn realise(&self, seed: u64, c: usize, r: u64, slots: &mut [f64]) {
        let v = c / self.per_vehicle;
        self.model(v)
            .realise(self.seed_of(seed, v), c % self.per_vehicle, r, slots);
    }

    fn draw_group(&self, c: usize) -> usize {
        self.groups[c]
    }

    fn realise_group(
        &self,
        seed: u64,
        conditions: &[usize],
        first: u64,
        count: usize,
        slots: &mut [f64],
    ) {
        let v = conditions[0] / self.per_vehicle;
        let local: Vec<usize> = conditions.iter().map(|c| c % self.per_vehicle).collect();
        debug_assert!(
            conditions.iter().all(|c| c / self.per_vehicle == v),
            "one vehicle's group"
        );
        self.model(v)
            .realise_group(self.seed_of(seed, v), &local, first, count, slots);
    }
}
