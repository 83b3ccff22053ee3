//! The suture thread against analytic answers of beam theory, each at a given segment count:
//! the cantilever under its own weight, the end moment's circular arc, the beam-column that
//! Euler's buckling load bounds, and the catenary. Each returns the rod's figure, the analytic
//! one and the relative error; tests/thread.rs asserts that the errors shrink with the
//! segments and `bench thread` prints them.
//!
//! The discrete rod lumps its bending at the joints and its mass at the points, a first-order
//! error in the segment length.

use crate::math::Vec3;
use crate::rod::solver::RodSolverSettings;
use crate::rod::{Rod, RodSolver, ThreadMaterial};

const FRAME: f32 = 1.0 / 60.0;
const GRAVITY: Vec3 = Vec3::new(0.0, 0.0, -9.81);
/// The beams here: 2 cm of 3-0 nylon.
const BEAM_LENGTH: f32 = 0.02;

/// One case at one segment count.
#[derive(Clone, Copy, Debug)]
pub struct RodCheck {
    pub segments: usize,
    /// The rod's figure (m).
    pub measured: f64,
    /// The analytic figure (m).
    pub expected: f64,
    /// Relative error (for the end moment: tip distance from the arc's end over L).
    pub error: f64,
}

/// A case as a function of the segment count.
pub type RodCase = fn(usize) -> RodCheck;

/// The cases, by name.
pub const CASES: [(&str, RodCase); 4] = [
    ("cantilever tip vs qL⁴/8EI", cantilever_under_own_weight),
    ("end moment tip vs circular arc", end_moment_arc),
    ("beam-column tip at P_cr/2 (Euler)", euler_beam_column),
    ("catenary sag", catenary_sag),
];

/// A rod along +x from the origin, built in at the origin: the first point held and the first
/// frame clamped (a cantilever's clamp fixes the slope as well as the position).
pub fn cantilever(length: f32, segments: usize) -> Rod {
    let mut rod = Rod::straight(
        ThreadMaterial::nylon_3_0(),
        Vec3::zeros(),
        Vec3::x(),
        length,
        segments,
    );
    rod.pin_point(0);
    rod.clamp_frame(0);
    rod
}

fn solver(rod: &Rod, gravity: Vec3) -> RodSolver {
    RodSolver::new(rod, RodSolverSettings::default(), gravity)
}

fn frames(rod: &mut Rod, solver: &mut RodSolver, count: usize, mut each: impl FnMut(&Rod)) {
    for _ in 0..count {
        solver.step_frame(rod, FRAME);
        each(rod);
    }
}

/// Small-deflection tip of a cantilever under its own weight against δ = qL⁴/(8EI): a 2 cm 3-0
/// nylon thread (δ ≈ 24 µm, δ/L ≈ 1e-3), after 1 s (the first mode, ~130 Hz, is damped by the
/// implicit steps well within it).
pub fn cantilever_under_own_weight(segments: usize) -> RodCheck {
    let mut rod = cantilever(BEAM_LENGTH, segments);
    let mut solver = solver(&rod, GRAVITY);
    frames(&mut rod, &mut solver, 60, |_| {});
    let m = rod.material;
    let q = (m.linear_density() * GRAVITY.norm()) as f64;
    let expected = q * (BEAM_LENGTH as f64).powi(4) / (8.0 * m.bending_stiffness() as f64);
    let tip = -rod.points[segments].z as f64;
    RodCheck {
        segments,
        measured: tip,
        expected,
        error: (tip - expected).abs() / expected,
    }
}

/// End moment: the cantilever with a moment M = 0.3·EI/L at its free end, without gravity,
/// bends into a circular arc of radius EI/M; the tip turns 0.3 rad and sits at
/// (R·sin θ, 0, R·(1 − cos θ)). The moment is a couple of follower forces ±M/l normal to the
/// last segment, renewed each frame so that it stays a pure moment as the end turns. Error:
/// the tip's distance from the arc's end over L; `measured` and `expected` are the tips' z.
pub fn end_moment_arc(segments: usize) -> RodCheck {
    let length = BEAM_LENGTH;
    let mut rod = cantilever(length, segments);
    let ei = rod.material.bending_stiffness();
    let moment = 0.3 * ei / length;
    let mut solver = solver(&rod, Vec3::zeros());
    let l = rod.rest_lengths[segments - 1];
    frames(&mut rod, &mut solver, 1, |_| {});
    for _ in 0..60 {
        let t = (rod.points[segments] - rod.points[segments - 1]).normalize();
        // t × n = −y: a moment about −y, turning the tip towards +z.
        let force = Vec3::new(-t.z, 0.0, t.x) * (moment / l);
        rod.external_forces[segments] = force;
        rod.external_forces[segments - 1] = -force;
        frames(&mut rod, &mut solver, 1, |_| {});
    }
    let radius = ei / moment;
    let theta = length / radius;
    let expected = Vec3::new(radius * theta.sin(), 0.0, radius * (1.0 - theta.cos()));
    let tip = rod.points[segments];
    RodCheck {
        segments,
        measured: tip.z as f64,
        expected: expected.z as f64,
        error: ((tip - expected).norm() / length) as f64,
    }
}

/// Euler buckling, through the beam-column it bounds: the cantilever under an axial tip load
/// P = ½·P_cr, P_cr = π²EI/(4L²) (clamped-free), and a small lateral tip load H deflects by
/// δ = H·(tan kL − kL)/(P·k), k = √(P/EI) (Timoshenko & Gere §1.11), twice its P = 0 value,
/// diverging as P → P_cr.
pub fn euler_beam_column(segments: usize) -> RodCheck {
    let length = BEAM_LENGTH;
    let mut rod = cantilever(length, segments);
    let ei = rod.material.bending_stiffness() as f64;
    let critical = std::f64::consts::PI.powi(2) * ei / (4.0 * (length as f64).powi(2));
    let p = 0.5 * critical;
    // δ/L ≈ 1e-3 without the axial load: small deflection.
    let h = 3.0 * ei * 1e-3 / (length as f64).powi(2);
    let k = (p / ei).sqrt();
    let kl = k * length as f64;
    let expected = h * (kl.tan() - kl) / (p * k);
    rod.external_forces[segments] = Vec3::new(-p as f32, 0.0, h as f32);
    let mut solver = solver(&rod, Vec3::zeros());
    frames(&mut rod, &mut solver, 60, |_| {});
    let tip = rod.points[segments].z as f64;
    RodCheck {
        segments,
        measured: tip,
        expected,
        error: (tip - expected).abs() / expected,
    }
}

/// Catenary: the analytic hanging curve z = a·(cosh(x/a) − cosh(s/(2a))) between pins `s`
/// apart, with a from the length L = 2a·sinh(s/(2a)) (bisection, f64).
pub fn catenary_parameter(span: f64, length: f64) -> f64 {
    let (mut lo, mut hi) = (1e-4 * span, 1e4 * span);
    for _ in 0..200 {
        let a = 0.5 * (lo + hi);
        // Longer for smaller a.
        if 2.0 * a * (span / (2.0 * a)).sinh() > length {
            lo = a;
        } else {
            hi = a;
        }
    }
    0.5 * (lo + hi)
}

/// A thread hung on the catenary of its length between two pins 12 cm apart (15 cm long),
/// points at equal arc lengths, rest shape straight: the largest relative distance of the
/// middle point from the analytic sag over 1 s (the discrete chain's own equilibrium differs
/// from the curve, and it swings about it). A catenary has no bending stiffness: 3-0 nylon's
/// bending length √(EI/q) is 29 mm, a quarter of the span, so the thread here is 100 times
/// denser (2.9 mm, 1/17 of the catenary's a ≈ 5 cm). `measured` is the middle point's depth
/// at the end, `expected` the sag.
pub fn catenary_sag(segments: usize) -> RodCheck {
    let (span, length) = (0.12f64, 0.15f64);
    let a = catenary_parameter(span, length);
    let points: Vec<Vec3> = (0..=segments)
        .map(|i| {
            let s = length * (i as f64 / segments as f64 - 0.5);
            let x = a * (s / a).asinh();
            let z = a * ((x / a).cosh() - (span / (2.0 * a)).cosh());
            Vec3::new((x + 0.5 * span) as f32, 0.0, z as f32)
        })
        .collect();
    let mut material = ThreadMaterial::nylon_3_0();
    material.density *= 100.0;
    let mut rod = Rod::from_polyline(material, points);
    for d in &mut rod.rest_darboux {
        *d = nalgebra::Quaternion::identity();
    }
    rod.pin_point(0);
    rod.pin_point(segments);
    // The analytic curve of the chain as built (its chords' length).
    let a = catenary_parameter(span, rod.rest_length() as f64);
    let sag = a * ((span / (2.0 * a)).cosh() - 1.0);
    let mut solver = solver(&rod, GRAVITY);
    let mut worst = 0.0f64;
    frames(&mut rod, &mut solver, 60, |r| {
        let middle = -r.points[segments / 2].z as f64;
        worst = worst.max(((middle - sag) / sag).abs());
    });
    RodCheck {
        segments,
        measured: -rod.points[segments / 2].z as f64,
        expected: sag,
        error: worst,
    }
}
