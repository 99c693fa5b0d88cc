//! The end-effector distance barrier of a two-arm robot (`safety.min_ee_distance`):
//! `h(q) = ‖p₁ − p₂‖ − d_min ≥ 0` with its gradient `∂h/∂q = uᵀ[J₁ − J₂]`,
//! `u = (p₁ − p₂)/‖p₁ − p₂‖`, handed to the safety filter as one more linear constraint.
//!
//! Built from the FK and Jacobian the tick already computed; no barrier when none is
//! configured, when the Jacobian is not finite (the filter then brakes anyway) or when the
//! end-effectors coincide (no direction to keep them apart along). Allocation-free after
//! construction.

use crossym_math::kinematics::{Kinematics, KinematicsWorkspace};

use crate::safety::Barrier;

/// The barrier's setting and its gradient buffer (see the module docs).
pub(crate) struct EeBarrier {
    min_distance: Option<f64>,
    grad: Vec<f64>,
}

impl EeBarrier {
    /// The barrier `min_distance` (task units; `None`: none) for `n` joints.
    pub fn new(min_distance: Option<f64>, n: usize) -> Self {
        Self {
            min_distance,
            grad: vec![0.0; n],
        }
    }

    /// The barrier at the posture of `ws` (after [`Kinematics::jacobian`]); `jac_ok`: the
    /// Jacobian is finite.
    pub fn at(
        &mut self,
        kin: &Kinematics,
        ws: &KinematicsWorkspace,
        jac_ok: bool,
    ) -> Option<Barrier<'_>> {
        match self.min_distance {
            Some(d_min) if jac_ok => ee_barrier(kin, ws, d_min, &mut self.grad),
            _ => None,
        }
    }
}

/// `h` and `∂h/∂q` from `ws` into `grad`; `None` when the end-effectors coincide.
fn ee_barrier<'g>(
    kin: &Kinematics,
    ws: &KinematicsWorkspace,
    d_min: f64,
    grad: &'g mut [f64],
) -> Option<Barrier<'g>> {
    let d = kin.chains()[0].task.dim();
    let (x1, x2) = (kin.x_offset(0), kin.x_offset(1));
    let mut dist2 = 0.0;
    for r in 0..d {
        let e = ws.x[x1 + r] - ws.x[x2 + r];
        dist2 += e * e;
    }
    let dist = dist2.sqrt();
    if !(dist.is_finite() && dist > 1e-9) {
        return None;
    }
    for (col, g) in grad.iter_mut().enumerate() {
        let mut acc = 0.0;
        for r in 0..d {
            let u = (ws.x[x1 + r] - ws.x[x2 + r]) / dist;
            acc += u * (ws.jac[(x1 + r, col)] - ws.jac[(x2 + r, col)]);
        }
        *g = acc;
    }
    Some(Barrier {
        gradient: grad,
        value: dist - d_min,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::node::test_robot::planar;

    /// Two one-joint arms on a base, 2 apart along x, links of 1 along x.
    fn two_arms() -> Kinematics {
        const URDF: &str = r#"<robot name="two">
  <link name="base"/> <link name="a"/> <link name="b"/> <link name="ta"/> <link name="tb"/>
  <joint name="ja" type="revolute"> <parent link="base"/> <child link="a"/>
    <axis xyz="0 0 1"/> <limit lower="-3" upper="3" effort="10" velocity="2"/> </joint>
  <joint name="jb" type="revolute"> <parent link="base"/> <child link="b"/>
    <origin xyz="2 0 0"/> <axis xyz="0 0 1"/> <limit lower="-3" upper="3" effort="10" velocity="2"/> </joint>
  <joint name="fa" type="fixed"> <parent link="a"/> <child link="ta"/> <origin xyz="1 0 0"/> </joint>
  <joint name="fb" type="fixed"> <parent link="b"/> <child link="tb"/> <origin xyz="1 0 0"/> </joint>
</robot>"#;
        planar(URDF, &[("a", "base", "ta"), ("b", "base", "tb")])
    }

    #[test]
    fn the_barrier_is_the_distance_less_the_minimum_and_its_gradient_moves_them_apart() {
        let kin = two_arms();
        let mut ws = kin.workspace();
        // Arm a points along +x to (1, 0); arm b turned by π/2 to (2, 1).
        let q = [0.0, std::f64::consts::FRAC_PI_2];
        kin.jacobian(&q, &mut ws);
        let mut b = EeBarrier::new(Some(0.5), 2);
        let h = b.at(&kin, &ws, true).unwrap();
        let dist = 2f64.sqrt();
        assert!((h.value - (dist - 0.5)).abs() < 1e-12, "{}", h.value);
        // ∂h/∂q by finite differences.
        let g = h.gradient.to_vec();
        for j in 0..2 {
            let mut qp = q;
            qp[j] += 1e-6;
            let mut wp = kin.workspace();
            kin.jacobian(&qp, &mut wp);
            let hp = EeBarrier::new(Some(0.5), 2)
                .at(&kin, &wp, true)
                .unwrap()
                .value;
            let fd = (hp - h.value) / 1e-6;
            assert!((fd - g[j]).abs() < 1e-5, "joint {j}: {fd} against {}", g[j]);
        }
        // None when not configured or the Jacobian is not finite.
        assert!(EeBarrier::new(None, 2).at(&kin, &ws, true).is_none());
        assert!(b.at(&kin, &ws, false).is_none());
    }
}
