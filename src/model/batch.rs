//! Many lighting states in one query (`POST …/batch`, up to a thousand): light-group
//! states are weighted sums, and the per-patch emission states are solved together,
//! [`SOLVE_CHUNK`] at a time, as one multi-right-hand-side solve
//! ([`Transfer::solve_many`](crate::transport::transfer::Transfer::solve_many)).
//!
//! A [`BatchPlan`] is made first, from the count of states alone: it refuses what the
//! transfer cannot do (emission in columns mode) or would take too long (emission states
//! in hierarchical mode beyond [`MAX_EMISSION_SWEEP_WORK`]), and it knows the working
//! memory, so a server can reserve it before any work starts.

use super::query::BYTES_PER_PATCH_ANSWER;
use super::{Cancel, Lighting, Model, QueryError};
use crate::input_limits::MAX_EMISSION_SWEEP_WORK;
use crate::transport::transfer::{
    Solution, Transfer, TransferMode, HIERARCHY_MAX_SWEEPS, HIERARCHY_TOL, SOLVE_BYTES_PER_STATE,
    SOLVE_CHUNK,
};

/// Working memory that the hierarchical mode may spend on one chunk of emission states
/// (its columns span all ~2n nodes of the cluster tree, so large scenes take fewer states
/// at a time).
const HIERARCHY_CHUNK_BYTES: u64 = 256 << 20;

/// A batch of lighting states checked against the transfer before any work: how many
/// emission states are solved together, and the working memory.
#[derive(Debug, Clone, Copy)]
pub struct BatchPlan {
    /// States in the batch.
    pub states: usize,
    /// Of them, per-patch emission states.
    pub emission_states: usize,
    /// States handed to one solve.
    pub chunk: usize,
    /// Estimated peak working memory of the solves, bytes (the answers not included).
    pub bytes: u64,
}

/// The predicted work of `states` emission solves in hierarchical mode, in link sweeps
/// of one column: 3 columns per state × (links + 2 · nodes, the gather and the pull and
/// push through the tree) × the expected sweeps.
pub fn hierarchy_sweep_work(t: &Transfer, states: usize) -> u64 {
    let Some(h) = &t.hierarchy else { return 0 };
    let per_sweep = h.links.src.len() as u64 + 2 * h.nodes() as u64;
    3 * states as u64 * per_sweep * expected_sweeps(t)
}

/// The sweeps a hierarchical emission solve is expected to take: as many as the bake's
/// solve of the group sources took (stored with the transfer; a single patch's emission
/// converges in the same number or fewer, `tests/it/hierarchical.rs` measures it), or,
/// for a scene without light groups, the sweeps for the error to shrink by
/// [`HIERARCHY_TOL`] at ρ_max per sweep.
fn expected_sweeps(t: &Transfer) -> u64 {
    let sweeps = if t.info.sweeps > 0 {
        t.info.sweeps
    } else {
        let rho_max = t
            .rho
            .iter()
            .flat_map(|r| r.iter().copied())
            .fold(0f32, f32::max)
            .clamp(0.01, 0.99) as f64;
        (HIERARCHY_TOL.ln() / rho_max.ln()).ceil() as usize
    };
    sweeps.clamp(1, HIERARCHY_MAX_SWEEPS) as u64
}

/// What a batch reports for each state besides the power balance.
#[derive(Debug, Clone, Default)]
pub struct BatchReport {
    /// Grids whose statistics each state answers ([`Model::state_grid_answers`]).
    pub grids: Vec<usize>,
    /// Surfaces whose illuminance statistics each state answers.
    pub surfaces: Vec<usize>,
    /// Whether each state answers its per-patch radiosity.
    pub radiosity: bool,
}

impl Model {
    /// Peak bytes a batch planned as `plan` takes to answer `report` for each state: the
    /// solves' working memory (a chunk of emission states at a time), and every answer's
    /// surfaces, grids and (when asked) radiosity, then as text.
    pub fn batch_bytes(&self, plan: &BatchPlan, report: &BatchReport) -> u64 {
        let n = self.patches() as u64;
        let grid_points: u64 = report
            .grids
            .iter()
            .map(|&g| self.grids[g].len() as u64)
            .sum();
        let radiosity = if report.radiosity { 150 * n } else { 0 };
        let per_state = 400 * report.surfaces.len() as u64 + 48 * grid_points + radiosity;
        // A placed or emission state's grids gather from its radiosity: the changes' part and
        // the gather's importance, one state at a time.
        let gather = if report.grids.is_empty() { 0 } else { 24 * n };
        2 * plan.states as u64 * per_state + plan.bytes + BYTES_PER_PATCH_ANSWER * n + gather
    }

    /// Checks a batch of `states` lighting states, `emission_states` of them per-patch
    /// emissions: emission needs the factored or hierarchical transfer, and in
    /// hierarchical mode the predicted sweep work ([`hierarchy_sweep_work`]) must stay
    /// within [`MAX_EMISSION_SWEEP_WORK`]. Costs microseconds; refuse before parsing the
    /// emission vectors.
    pub fn plan_batch(
        &self,
        states: usize,
        emission_states: usize,
    ) -> Result<BatchPlan, QueryError> {
        let t = &self.baked.transfer;
        let n = t.n as u64;
        if emission_states == 0 {
            return Ok(BatchPlan {
                states,
                emission_states,
                chunk: SOLVE_CHUNK,
                bytes: 0,
            });
        }
        self.require_factored()?;
        let chunk = if t.mode == TransferMode::Hierarchical {
            let work = hierarchy_sweep_work(t, emission_states);
            if work > MAX_EMISSION_SWEEP_WORK {
                let per_state = hierarchy_sweep_work(t, 1).max(1);
                let fits = MAX_EMISSION_SWEEP_WORK / per_state;
                return Err(QueryError::Invalid(format!(
                    "{emission_states} per-patch emission states would take about {work:.3e} \
                     link sweeps in this scene's hierarchical transfer ({per_state:.3e} each), \
                     over the limit of {MAX_EMISSION_SWEEP_WORK:.0e} per request \
                     (MAX_EMISSION_SWEEP_WORK); send at most {fits} emission states per batch"
                )));
            }
            (HIERARCHY_CHUNK_BYTES / (SOLVE_BYTES_PER_STATE * n).max(1))
                .clamp(1, SOLVE_CHUNK as u64) as usize
        } else {
            SOLVE_CHUNK
        };
        let held = chunk.min(emission_states) as u64;
        Ok(BatchPlan {
            states,
            emission_states,
            chunk,
            bytes: SOLVE_BYTES_PER_STATE * n * held,
        })
    }

    /// Solves the states of a planned batch in order and hands each to `each` with its
    /// index and lighting. `lighting(k)` makes state k, a chunk of states at a time, so
    /// only a chunk of emission vectors is held at once; the emission states of a chunk
    /// are solved together ([`Transfer::solve_many`]). `cancel` is checked between chunks.
    pub fn solve_each<E: From<QueryError>>(
        &self,
        plan: &BatchPlan,
        mut lighting: impl FnMut(usize) -> Result<Lighting, E>,
        cancel: &Cancel,
        mut each: impl FnMut(usize, Lighting, Solution) -> Result<(), E>,
    ) -> Result<(), E> {
        let t = &self.baked.transfer;
        let mut emitted = 0;
        let mut start = 0;
        while start < plan.states {
            cancel.check()?;
            let end = (start + plan.chunk).min(plan.states);
            let lightings = (start..end)
                .map(&mut lighting)
                .collect::<Result<Vec<_>, E>>()?;
            let emissions: Vec<&[f32]> = lightings
                .iter()
                .filter_map(|l| match l {
                    Lighting::Emission(e) => Some(e.as_slice()),
                    Lighting::Groups(_) | Lighting::Placed(_) => None,
                })
                .collect();
            emitted += emissions.len();
            if emitted > plan.emission_states {
                return Err(QueryError::Invalid(format!(
                    "the batch has more emission states than the {} planned",
                    plan.emission_states
                ))
                .into());
            }
            for e in &emissions {
                self.check_emission(e)?;
            }
            let mut solved = if emissions.is_empty() {
                vec![]
            } else {
                t.solve_many(&emissions).ok_or_else(|| {
                    QueryError::Invalid("this scene's transfer cannot solve an emission".into())
                })?
            }
            .into_iter();
            drop(emissions);
            for (k, l) in (start..end).zip(lightings) {
                let sol = match &l {
                    Lighting::Groups(w) => t.relight(w),
                    // Each traced and solved on its own (planned as an emission state).
                    Lighting::Placed(_) => self.solve(&l)?,
                    Lighting::Emission(_) => solved.next().ok_or_else(|| {
                        QueryError::Invalid("an emission state was left unsolved".into())
                    })?,
                };
                each(k, l, sol)?;
            }
            start = end;
        }
        Ok(())
    }
}
