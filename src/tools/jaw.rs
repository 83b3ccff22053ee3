//! The gripper jaw as dVRK drives it: a position servo (PD) whose effort is limited, acting
//! against the tissue's reaction about the hinge.
//!
//! The jaw's inertia is negligible next to its controller's damping (time constant
//! `d_gain / p_gain` = 15 ms with dVRK's gains), so the jaw is modelled quasi-statically:
//! its opening rate is the net torque over the damping,
//!
//! `d_gain · θ̇ = clamp(p_gain · (θ_sp − θ), ±effort_max) + τ_tissue`,
//!
//! with `τ_tissue` the generalised force the tissue exerts on the opening (positive pushes
//! the jaws apart), measured from the momentum the jaws exchanged with the tissue over the
//! last frame. In free air the jaw follows its setpoint with a 15 ms lag; closing onto
//! tissue it stops where the tissue's torque balances what the controller can apply, and a
//! setpoint below that angle only raises the squeeze, up to `effort_max`. The jaws cannot
//! close past each other: the opening stops at zero, where a negative setpoint presses
//! them together (dVRK's way of asking for a harder grip).
//!
//! With an effort command (`jaw/servo_jf`) the controller's effort is that command instead.

use serde::{Deserialize, Serialize};

/// Controller gains and effort limit of a jaw (SI: N·m/rad, N·m·s/rad, N·m).
///
/// Defaults are dVRK's: `p_gain` 6.0 and `d_gain` 0.09 from the jaw entry of
/// sawIntuitiveResearchKit's `share/pid/sawControllersPID-PSM.json`, `effort_max` 0.16 N·m
/// (`ftmax` of the jaw in `share/tool/LARGE_NEEDLE_DRIVER_400006.json`).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct JawGains {
    /// Proportional gain, N·m/rad.
    pub p_gain: f64,
    /// Derivative gain, N·m·s/rad.
    pub d_gain: f64,
    /// Largest effort the controller applies, N·m.
    pub effort_max: f64,
}

impl Default for JawGains {
    fn default() -> Self {
        JawGains {
            p_gain: 6.0,
            d_gain: 0.09,
            effort_max: 0.16,
        }
    }
}

impl JawGains {
    /// The first gain that is not finite and positive, with its key.
    pub fn invalid(&self) -> Option<(&'static str, f64)> {
        [
            ("p_gain", self.p_gain),
            ("d_gain", self.d_gain),
            ("effort_max", self.effort_max),
        ]
        .into_iter()
        .find(|(_, v)| !(v.is_finite() && *v > 0.0))
    }
}

/// What drives the jaw's controller.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum JawCommand {
    /// Position servo to this opening (rad).
    Position(f64),
    /// Effort command (N·m, positive opens), already within the limit.
    Effort(f64),
}

/// One jaw's state.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct JawServo {
    /// The controller's gains and effort limit.
    pub gains: JawGains,
    /// Opening reached (rad).
    pub angle: f64,
    /// The controller's effort on the opening (N·m; negative closes).
    pub effort: f64,
    /// Opening rate over the last update (rad/s).
    pub rate: f64,
}

/// Internal steps of one update: backward Euler on the controller's stiffness, so any
/// number is stable; a few keep the effort limit's corner accurate over a 60 Hz frame.
const STEPS: usize = 8;

impl JawServo {
    /// A jaw at rest at opening `angle` (rad).
    pub fn new(gains: JawGains, angle: f64) -> Self {
        JawServo {
            gains,
            angle,
            effort: 0.0,
            rate: 0.0,
        }
    }

    /// Advances the jaw by `dt` under `command` against `tissue_torque` (N·m, positive
    /// pushes the jaws apart).
    pub fn update(&mut self, command: JawCommand, tissue_torque: f64, dt: f64) {
        if dt.is_nan() || dt <= 0.0 {
            return;
        }
        let g = self.gains;
        let tissue = if tissue_torque.is_finite() {
            tissue_torque
        } else {
            0.0
        };
        let start = self.angle;
        let h = dt / STEPS as f64;
        for _ in 0..STEPS {
            let (angle, effort) = match command {
                JawCommand::Effort(e) => (self.angle + h * (e + tissue) / g.d_gain, e),
                JawCommand::Position(setpoint) => {
                    // Unsaturated backward Euler: d·(θ' − θ)/h = p·(θ_sp − θ') + τ.
                    let k = h * g.p_gain / g.d_gain;
                    let unsaturated =
                        (self.angle + k * setpoint + h * tissue / g.d_gain) / (1.0 + k);
                    let effort = g.p_gain * (setpoint - unsaturated);
                    if effort.abs() <= g.effort_max {
                        (unsaturated, effort)
                    } else {
                        let e = g.effort_max.copysign(effort);
                        (self.angle + h * (e + tissue) / g.d_gain, e)
                    }
                }
            };
            // The jaws meet at zero opening: below it they press on each other, with the
            // effort the controller has at zero.
            self.angle = angle.max(0.0);
            self.effort = match command {
                JawCommand::Position(setpoint) if angle < 0.0 => {
                    (g.p_gain * setpoint).clamp(-g.effort_max, g.effort_max)
                }
                _ => effort,
            };
        }
        self.rate = (self.angle - start) / dt;
    }

    /// The part of the controller's closing effort that presses on whatever stops the jaws
    /// (tissue, a needle, or the other jaw with tissue caught between), not spent on moving
    /// them: zero while opening or closing freely.
    pub fn squeeze(&self) -> f64 {
        let closing_motion = (-self.rate).max(0.0) * self.gains.d_gain;
        (-self.effort - closing_motion).max(0.0)
    }

    /// Whether the controller drives the jaws closed: its closing effort is at least a tenth
    /// of the limit (a command to close, not the small effort that holds an open jaw
    /// against the tissue it rests on). The grip holds while it does and the tips are
    /// within a cell (see [`crate::tools::grip`]).
    pub fn driving_closed(&self) -> bool {
        self.effort <= -0.1 * self.gains.effort_max
    }

    /// Whether the controller presses the jaws onto something that has stopped them: it
    /// drives them closed and at least half of its effort goes into the squeeze. A thread
    /// is grasped while it does ([`crate::world::thread_body`]).
    pub fn pressing(&self) -> bool {
        self.driving_closed() && self.squeeze() >= -0.5 * self.effort
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const FRAME: f64 = 1.0 / 60.0;

    fn run(servo: &mut JawServo, command: JawCommand, tissue: impl Fn(f64) -> f64, frames: usize) {
        for _ in 0..frames {
            let t = tissue(servo.angle);
            servo.update(command, t, FRAME);
        }
    }

    #[test]
    fn free_air_follows_the_setpoint_with_no_effort_left() {
        let mut jaw = JawServo::new(JawGains::default(), 0.8);
        run(&mut jaw, JawCommand::Position(0.3), |_| 0.0, 60);
        assert!((jaw.angle - 0.3).abs() < 1e-6, "{}", jaw.angle);
        assert!(jaw.effort.abs() < 1e-5, "effort {}", jaw.effort);
        assert!(jaw.squeeze() < 1e-5);
        // Moving there took the effort limit (a 0.5 rad step asks for 3 N·m).
        let mut jaw = JawServo::new(JawGains::default(), 0.8);
        jaw.update(JawCommand::Position(0.3), 0.0, FRAME);
        assert_eq!(jaw.effort, -0.16);
        // Limited effort against damping alone: 0.16 / 0.09 rad/s.
        assert!((jaw.rate + 0.16 / 0.09).abs() < 1e-9, "rate {}", jaw.rate);
        assert!(jaw.squeeze() < 1e-9, "moving freely squeezes nothing");
    }

    #[test]
    fn closing_on_stiff_tissue_stops_where_its_torque_reaches_the_limit() {
        // Tissue touched at 0.4 rad, 2 N·m/rad stiffer as it is squeezed.
        let tissue = |a: f64| (2.0 * (0.4 - a)).max(0.0);
        let mut jaw = JawServo::new(JawGains::default(), 0.8);
        run(&mut jaw, JawCommand::Position(-0.3), tissue, 120);
        // Saturated controller: 0.16 = 2 (0.4 − θ) → θ = 0.32.
        assert!((jaw.angle - 0.32).abs() < 1e-4, "{}", jaw.angle);
        assert_eq!(jaw.effort, -0.16);
        assert!((jaw.squeeze() - 0.16).abs() < 1e-4);
        // A setpoint just below the contact angle squeezes less than the limit: the
        // balance 6 (θ_sp − θ) = −2 (0.4 − θ) with θ_sp = 0.38 gives θ = 0.385.
        let mut jaw = JawServo::new(JawGains::default(), 0.8);
        run(&mut jaw, JawCommand::Position(0.38), tissue, 120);
        assert!((jaw.angle - 0.385).abs() < 1e-4, "{}", jaw.angle);
        assert!((jaw.squeeze() - 0.03).abs() < 1e-4, "{}", jaw.squeeze());
    }

    #[test]
    fn jaws_meet_at_zero_and_a_negative_setpoint_presses_them_together() {
        let mut jaw = JawServo::new(JawGains::default(), 0.5);
        run(&mut jaw, JawCommand::Position(0.0), |_| 0.0, 60);
        assert!(
            jaw.angle.abs() < 1e-6 && jaw.squeeze() < 1e-5,
            "closing on air"
        );
        run(&mut jaw, JawCommand::Position(-0.35), |_| 0.0, 10);
        assert_eq!(jaw.angle, 0.0);
        assert_eq!(jaw.effort, -0.16);
        assert_eq!(jaw.squeeze(), 0.16);
        // −0.01 rad asks for 0.06 N·m, under the limit.
        run(&mut jaw, JawCommand::Position(-0.01), |_| 0.0, 10);
        assert!((jaw.squeeze() - 0.06).abs() < 1e-9);
    }

    #[test]
    fn an_effort_command_squeezes_with_that_effort() {
        let mut jaw = JawServo::new(JawGains::default(), 0.5);
        run(&mut jaw, JawCommand::Effort(-0.05), |_| 0.0, 60);
        assert_eq!(jaw.angle, 0.0);
        assert!((jaw.squeeze() - 0.05).abs() < 1e-12);
        run(&mut jaw, JawCommand::Effort(0.05), |_| 0.0, 1);
        assert!(jaw.angle > 0.0 && jaw.squeeze() == 0.0, "opening releases");
    }

    #[test]
    fn gains_must_be_positive() {
        assert!(JawGains::default().invalid().is_none());
        let bad = JawGains {
            effort_max: f64::NAN,
            ..Default::default()
        };
        assert_eq!(bad.invalid().map(|(k, _)| k), Some("effort_max"));
    }
}
