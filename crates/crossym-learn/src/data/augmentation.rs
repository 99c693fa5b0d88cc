//! Data augmentation with the composed group `G_MRT = (SO(2) × S) ⋊ C2` acting in `Q`
//! (paper Sec. VI-A; eqs. 18, 23).
//!
//! Every sample `(q, q̇)` of a joint-space demonstration is mapped by
//!
//! `q' = ρ(σ) Φ_R(θ, Φ_S(ln λ, q))`,   `q̇' = ρ(σ) dΦ_R dΦ_S q̇`   (eq. 23, paper order)
//!
//! with `Φ_R`, `Φ_S` the horizontally lifted rotation and scaling (flows of
//! `J⁺ X_X`, eq. 18) and `ρ(σ)` the morphological arm swap. The differentials come from the
//! variational equation integrated with the flow. One flow per sample covers a whole
//! rotation grid: `Φ_R(θ_{k+1}) = Φ_R(Δθ) ∘ Φ_R(θ_k)` (a one-parameter group), stepping out
//! from 0 in both directions. A transformed trajectory is kept only if it is feasible:
//! no singularity along any flow and every sample inside the joint limits; dropped ones are
//! counted with their reason. Sub-groups (`G_R`, `G_RT`, the identity) are the same code
//! with smaller grids.

use serde::{Deserialize, Serialize};

use crossym_math::kinematics::{Kinematics, KinematicsWorkspace};
use crossym_math::symmetry::built::BuiltSymmetry;
use crossym_math::symmetry::compose::Condition;
use crossym_math::symmetry::finite::SignedPermutation;
use crossym_math::symmetry::parts::{composition_parts, CompositionParts};
use crossym_math::symmetry::transfer::lift::{LiftError, LiftedAction};
use crossym_policy::{GridError, GroupGrid, JointTrajectory, SubGroup};

/// Why an augmentation grid or an augmenter is refused.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum AugmentationError {
    /// The grid itself is invalid.
    #[error(transparent)]
    Grid(#[from] GridError),
    /// The grid scales but the composition has no scaling symmetry.
    #[error("the grid scales by {scales:?} but [composition] order names no scaling symmetry")]
    NoScaling {
        /// The grid's scales.
        scales: Vec<f64>,
    },
    /// The reflection acts on another dimension than the robot's joint space.
    #[error("reflection acts on R^{reflection}, dim Q = {dof}")]
    ReflectionDim {
        /// Dimension the reflection acts on.
        reflection: usize,
        /// Joints of the robot.
        dof: usize,
    },
}

/// `[augmentation]`: the grids of the full composed group for training and testing.
/// Sub-groups (`identity`, `R`, `RT`, `MRT`) are restrictions of these grids.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct AugmentationConfig {
    /// Training grid (paper: Δθ = 30°, λ ∈ {0.5, …, 1.0}, σ = ±1).
    pub train: GroupGrid,
    /// Test grid (paper: Δθ = 15°, same λ and σ).
    pub test: GroupGrid,
}

/// A transformed demonstration and the condition that produced it.
#[derive(Debug, Clone)]
pub struct Augmented {
    /// `s = (θ, λ, σ)`.
    pub condition: Condition,
    /// The transformed trajectory (`x` is `f(q')`).
    pub traj: JointTrajectory,
}

/// Why a transformed trajectory was dropped.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum DropReason {
    /// A flow reached a kinematic singularity.
    Singular,
    /// A sample left the limits of joint `joint` (index in the robot's joint order).
    JointLimits {
        /// The first joint found outside its limits.
        joint: usize,
    },
    /// The integrator failed.
    Integration,
}

/// The augmented set with its bookkeeping.
#[derive(Debug, Clone, Default)]
pub struct AugmentedSet {
    /// Feasible transformed trajectories.
    pub trajectories: Vec<Augmented>,
    /// Dropped `(demo, condition, reason)`.
    pub dropped: Vec<(usize, Condition, DropReason)>,
}

impl AugmentedSet {
    /// The trajectories of a sub-group (cloned), e.g. `G_R` out of a `G_MRT` set.
    pub fn subset(&self, g: SubGroup) -> Vec<&Augmented> {
        self.trajectories
            .iter()
            .filter(|a| g.contains(&a.condition))
            .collect()
    }

    /// Number of dropped trajectories for `reason`.
    pub fn dropped_for(&self, reason: DropReason) -> usize {
        self.dropped.iter().filter(|d| d.2 == reason).count()
    }
}

/// Applies the lifted composed group to demonstrations.
pub struct Augmenter<'a> {
    kin: &'a Kinematics,
    rotation: LiftedAction<'a>,
    scaling: Option<LiftedAction<'a>>,
    reflection: SignedPermutation,
}

fn reason(e: &LiftError) -> DropReason {
    match e {
        LiftError::Singular { .. } | LiftError::BadStart { .. } => DropReason::Singular,
        _ => DropReason::Integration,
    }
}

impl<'a> Augmenter<'a> {
    /// Transforms every demonstration (in parallel, one task per demonstration and scale) and
    /// calls `progress` after each task (`demos.len() × scales` calls).
    pub fn augment(
        &self,
        demos: &[&JointTrajectory],
        grid: &GroupGrid,
        progress: &(dyn Fn() + Sync),
    ) -> AugmentedSet {
        use rayon::prelude::*;
        let scales = grid.scales_used();
        // One task per (demonstration, scale): enough tasks to keep both cores busy.
        let tasks: Vec<(&JointTrajectory, f64)> = demos
            .iter()
            .flat_map(|d| scales.iter().map(move |&s| (*d, s)))
            .collect();
        let parts: Vec<AugmentedSet> = tasks
            .par_iter()
            .map(|(d, s)| {
                let part = self.augment_scale(d, *s, grid);
                progress();
                part
            })
            .collect();
        let mut out = AugmentedSet::default();
        for p in parts {
            out.trajectories.extend(p.trajectories);
            out.dropped.extend(p.dropped);
        }
        out
    }

    /// Lifted rotation and scaling (acting on `X`) and the reflection `ρ_Q` (acting on `Q`).
    pub fn new(
        kin: &'a Kinematics,
        rotation: LiftedAction<'a>,
        scaling: Option<LiftedAction<'a>>,
        reflection: SignedPermutation,
    ) -> Result<Self, AugmentationError> {
        if reflection.dim() != kin.dof() {
            return Err(AugmentationError::ReflectionDim {
                reflection: reflection.dim(),
                dof: kin.dof(),
            });
        }
        Ok(Self {
            kin,
            rotation,
            scaling,
            reflection,
        })
    }

    /// Checks that this augmenter can produce every condition of `grid` (a scaling other
    /// than 1 needs a scaling symmetry).
    pub fn supports(&self, grid: &GroupGrid) -> Result<(), AugmentationError> {
        if self.scaling.is_none() && grid.scales_used().iter().any(|&s| s != 1.0) {
            return Err(AugmentationError::NoScaling {
                scales: grid.scales_used(),
            });
        }
        Ok(())
    }

    /// Transforms one demonstration by every condition of `grid` (σ = +1 and −1 share flows).
    pub fn augment_one(&self, demo: &JointTrajectory, grid: &GroupGrid) -> AugmentedSet {
        let mut set = AugmentedSet::default();
        for scale in grid.scales_used() {
            let part = self.augment_scale(demo, scale, grid);
            set.trajectories.extend(part.trajectories);
            set.dropped.extend(part.dropped);
        }
        set
    }

    /// Transforms one demonstration by the conditions of `grid` with scaling `scale`.
    pub fn augment_scale(
        &self,
        demo: &JointTrajectory,
        scale: f64,
        grid: &GroupGrid,
    ) -> AugmentedSet {
        let (wanted, angles) = angles_at_scale(grid, scale);
        let zero = angles
            .iter()
            .position(|&a| a == 0.0)
            .expect("grid contains 0");
        let mut set = AugmentedSet::default();
        let flows = self.flow_through_angles(demo, scale, &angles, zero);
        let mut kws = self.kin.workspace();
        for (ai, &theta) in angles.iter().enumerate() {
            let sigmas: &[i8] = if grid.reflection || wanted.is_some() {
                &[1, -1]
            } else {
                &[1]
            };
            for &sigma in sigmas {
                let condition = Condition {
                    theta,
                    scale,
                    reflection: sigma,
                };
                if wanted
                    .as_ref()
                    .is_some_and(|w| !w.iter().any(|c| c.theta == theta && c.reflection == sigma))
                {
                    continue;
                }
                if let Some(r) = flows.failed[ai] {
                    set.dropped.push((demo.demo, condition, r));
                    continue;
                }
                let (q, qd) = (flows.q[ai].clone(), flows.v[ai].clone());
                match self.reflect_and_check(demo, condition, q, qd, &mut kws) {
                    Ok(a) => set.trajectories.push(a),
                    Err(r) => set.dropped.push((demo.demo, condition, r)),
                }
            }
        }
        set
    }

    /// Every sample of `demo` scaled by `scale`, then carried by one rotation flow out from
    /// θ = 0 in each direction through `angles` (`angles[zero] = 0`).
    fn flow_through_angles(
        &self,
        demo: &JointTrajectory,
        scale: f64,
        angles: &[f64],
        zero: usize,
    ) -> AngleFlows {
        let n = demo.n;
        let len = demo.len();
        // One workspace per field, so that each flow warm-starts from the last flow of
        // the same field (FlowSettings::warm_start).
        let mut lws = self.rotation.workspace();
        let mut sws = self.rotation.workspace();
        // Per angle: positions and velocities for all samples, or a drop reason.
        let mut q_out: Vec<Vec<f64>> = vec![Vec::with_capacity(len * n); angles.len()];
        let mut v_out: Vec<Vec<f64>> = vec![Vec::with_capacity(len * n); angles.len()];
        let mut failed: Vec<Option<DropReason>> = vec![None; angles.len()];
        let (mut qs, mut vs) = (vec![0.0; n], vec![0.0; n]);
        // Flow times and angle indices of the two orbits out from θ = 0.
        let idx_pos: Vec<usize> = (zero + 1..angles.len()).collect();
        let idx_neg: Vec<usize> = (0..zero).rev().collect();
        let ts_pos: Vec<f64> = idx_pos.iter().map(|&k| angles[k]).collect();
        let ts_neg: Vec<f64> = idx_neg.iter().map(|&k| angles[k]).collect();
        for i in 0..len {
            let (q, v) = (demo.q(i), demo.qdot(i));
            if scale == 1.0 {
                qs.copy_from_slice(q);
                vs.copy_from_slice(v);
            } else {
                let r = match &self.scaling {
                    Some(sc) => sc
                        .act_with_differential(&[scale.ln()], q, v, &mut qs, &mut vs, &mut sws)
                        .map(|_| ())
                        .map_err(|e| reason(&e)),
                    None => Err(DropReason::Integration),
                };
                if let Err(r) = r {
                    failed.iter_mut().for_each(|f| *f = f.or(Some(r)));
                    break;
                }
            }
            q_out[zero].extend_from_slice(&qs);
            v_out[zero].extend_from_slice(&vs);
            // One flow out from θ = 0 in each direction through the grid's angles,
            // up to the first angle an earlier sample already lost.
            for (ts, idx) in [(&ts_pos, &idx_pos), (&ts_neg, &idx_neg)] {
                // Angles from the first lost one outwards are all marked lost.
                let live = idx
                    .iter()
                    .position(|&k| failed[k].is_some())
                    .unwrap_or(idx.len());
                let mut reached = 0;
                let st = self.rotation.act_with_differential_through(
                    &[1.0],
                    &ts[..live],
                    &qs,
                    &vs,
                    &mut lws,
                    &mut |j, qa, va| {
                        q_out[idx[j]].extend_from_slice(qa);
                        v_out[idx[j]].extend_from_slice(va);
                        reached = j + 1;
                    },
                );
                // Every angle further out than a failure is unreachable for this
                // sample too.
                if let Err(e) = st {
                    let r = reason(&e);
                    for &k in &idx[reached..] {
                        failed[k].get_or_insert(r);
                    }
                }
            }
        }
        AngleFlows {
            q: q_out,
            v: v_out,
            failed,
        }
    }

    /// The flowed positions `q` and velocities `qd` of `demo` under `condition`: reflected
    /// when `σ = −1`, refused outside the joint limits, with their task path.
    fn reflect_and_check(
        &self,
        demo: &JointTrajectory,
        condition: Condition,
        mut q: Vec<f64>,
        mut qd: Vec<f64>,
        kws: &mut KinematicsWorkspace,
    ) -> Result<Augmented, DropReason> {
        let (n, len) = (demo.n, demo.len());
        if condition.reflection == -1 {
            let mut tmp = vec![0.0; n];
            for i in 0..len {
                self.reflection.apply(&q[i * n..(i + 1) * n], &mut tmp);
                q[i * n..(i + 1) * n].copy_from_slice(&tmp);
                self.reflection.apply(&qd[i * n..(i + 1) * n], &mut tmp);
                qd[i * n..(i + 1) * n].copy_from_slice(&tmp);
            }
        }
        let limits = self.kin.limits();
        let outside = (0..len).find_map(|i| {
            let qi = &q[i * n..(i + 1) * n];
            (!self.kin.within_limits(qi)).then(|| {
                qi.iter()
                    .zip(limits)
                    .position(|(v, l)| !l.contains(*v))
                    .unwrap_or(0)
            })
        });
        if let Some(joint) = outside {
            return Err(DropReason::JointLimits { joint });
        }
        let mut x = Vec::with_capacity(len * demo.m);
        for i in 0..len {
            x.extend(self.kin.forward(&q[i * n..(i + 1) * n], kws).iter());
        }
        Ok(Augmented {
            condition,
            traj: JointTrajectory {
                demo: demo.demo,
                n,
                m: demo.m,
                dt: demo.dt,
                q,
                qdot: qd,
                x,
            },
        })
    }
}

/// Per grid angle: the flowed positions and velocities of every sample (row-major
/// `len × n`), or why the angle was lost.
struct AngleFlows {
    q: Vec<Vec<f64>>,
    v: Vec<Vec<f64>>,
    failed: Vec<Option<DropReason>>,
}

/// The conditions an explicit list asks for at `scale` (`None` for a grid) and the angles
/// to flow through at that scale, ascending and containing 0.
fn angles_at_scale(grid: &GroupGrid, scale: f64) -> (Option<Vec<Condition>>, Vec<f64>) {
    // With an explicit list: the angles requested at this scale (and 0, the start).
    let wanted: Option<Vec<Condition>> = grid.conditions.as_ref().map(|_| {
        grid.conditions()
            .into_iter()
            .filter(|c| c.scale == scale)
            .collect()
    });
    let angles = match &wanted {
        Some(w) => {
            let mut a: Vec<f64> = w.iter().map(|c| c.theta).collect();
            a.push(0.0);
            a.sort_by(f64::total_cmp);
            a.dedup();
            a
        }
        None => grid.angles(),
    };
    (wanted, angles)
}

/// The lifted flows' settings of the letter task's augmenter (and of canonicalised
/// policies): rtol 1e-7, atol 1e-9, warm-started (consecutive samples of a trajectory flow
/// from nearby points).
pub fn letter_flow() -> crossym_math::symmetry::transfer::flow::FlowSettings {
    crossym_math::symmetry::transfer::flow::FlowSettings {
        rtol: 1e-7,
        atol: 1e-9,
        warm_start: true,
        ..Default::default()
    }
}

/// The letter task's augmenter: `M`, `R`, `S` of `order` found in `built`, the lifted
/// flows integrated at rtol 1e-7 / atol 1e-9 (task-space equivariance ≈ 3e-7 on the
/// letters, whose tracking error is 4e-5), warm-started along each trajectory.
pub fn letter_augmenter<'a>(
    kin: &'a Kinematics,
    built: &'a [BuiltSymmetry],
    order: &[String],
) -> Result<Augmenter<'a>, String> {
    let CompositionParts {
        reflection: rho,
        rotation: rot,
        scaling: sc,
    } = composition_parts(built, order).map_err(|e| e.to_string())?;
    let flow = letter_flow();
    Augmenter::new(
        kin,
        LiftedAction::new(kin, rot, flow).map_err(|e| e.to_string())?,
        sc.map(|sc| LiftedAction::new(kin, sc, flow))
            .transpose()
            .map_err(|e| e.to_string())?,
        rho,
    )
    .map_err(|e| e.to_string())
}

/// The nominal trajectories of `demo` under each of `conditions`, for the composition
/// `order` of `built` ([`letter_augmenter`]), in the order given.
///
/// Each is the demonstration transformed by eq. 23, as in the augmentation; an infeasible
/// condition is an error naming its drop reason.
pub fn nominal_trajectories(
    kin: &Kinematics,
    built: &[BuiltSymmetry],
    order: &[String],
    demo: &JointTrajectory,
    conditions: &[Condition],
) -> Result<Vec<Augmented>, String> {
    let augmenter = letter_augmenter(kin, built, order)?;
    let mut out = Vec::with_capacity(conditions.len());
    for c in conditions {
        c.validate().map_err(|e| e.to_string())?;
        let deg = c.theta.to_degrees().abs();
        let grid = GroupGrid {
            rotation_step_deg: (deg > 1e-9).then_some(deg),
            scales: vec![c.scale],
            reflection: c.reflection == -1,
            max_rotation_deg: Some(deg),
            conditions: None,
        };
        grid.validate().map_err(|e| e.to_string())?;
        let set = augmenter.augment_scale(demo, c.scale, &grid);
        let same = |a: &Condition| (a.theta - c.theta).abs() < 1e-9 && a.reflection == c.reflection;
        if let Some(a) = set.trajectories.iter().find(|a| same(&a.condition)) {
            out.push(Augmented {
                condition: *c,
                traj: a.traj.clone(),
            });
        } else {
            let why = set
                .dropped
                .iter()
                .find(|d| same(&d.1))
                .map(|d| format!("{:?}", d.2))
                .unwrap_or_else(|| "not produced".into());
            return Err(format!(
                "condition (θ = {} rad, λ = {}, σ = {}) is infeasible for demo {}: {why}",
                c.theta, c.scale, c.reflection, demo.demo
            ));
        }
    }
    Ok(out)
}
