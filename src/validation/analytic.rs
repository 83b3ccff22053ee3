//! Scenes with analytic answers, run through the same `World` as any scene file:
//! Hertz indentation, an axially vibrating bar, and a large Neo-Hookean stretch.
//!
//! Each is parameterised by resolution (cells across its characteristic length) so tests
//! can check error bounds and that errors shrink as dx shrinks.

use super::meter::Meter;
use crate::config::builders::*;
use crate::config::Scene;
use crate::mpm::{Lame, Method};
use crate::tools::{ContactModel, Shape};
use crate::world::World;

/// Hertz contact force of a rigid sphere of radius `r` indenting an elastic half-space by
/// `d`: F = 4/3 · E/(1−ν²) · √R · d^{3/2}.
pub fn hertz_force(e: f64, nu: f64, r: f64, d: f64) -> f64 {
    4.0 / 3.0 * e / (1.0 - nu * nu) * r.sqrt() * d.max(0.0).powf(1.5)
}

/// Nominal (first Piola) stress of a compressible Neo-Hookean bar stretched uniaxially to
/// `stretch` with free lateral faces: the lateral stretch t solves
/// μ(t² − 1) + λ ln(s t²) = 0 (zero lateral stress), then P = (μ(s² − 1) + λ ln(s t²)) / s.
pub fn neo_hookean_uniaxial_stress(e: f64, nu: f64, stretch: f64) -> f64 {
    let mu = e / (2.0 * (1.0 + nu));
    let lambda = e * nu / ((1.0 + nu) * (1.0 - 2.0 * nu));
    let s = stretch;
    let lateral = |t: f64| mu * (t * t - 1.0) + lambda * (s * t * t).ln();
    // The residual increases with t; bisect on a bracket that always contains the root.
    let (mut lo, mut hi) = (1e-3, 2.0);
    for _ in 0..200 {
        let mid = 0.5 * (lo + hi);
        if lateral(mid) > 0.0 {
            hi = mid;
        } else {
            lo = mid;
        }
    }
    let t = 0.5 * (lo + hi);
    (mu * (s * s - 1.0) + lambda * (s * t * t).ln()) / s
}

/// Material and time scale of the Hertz and stretch scenes.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Loading {
    /// Young's modulus, Pa.
    pub youngs_modulus: f64,
    /// Poisson's ratio (dimensionless, 0..0.5).
    pub poisson_ratio: f64,
    /// Loading time and output frame rate (s, Hz); `None`: a fixed number of elastic wave
    /// transits and frames (the default scenes, whose run time shrinks with stiffness).
    pub timing: Option<(f64, f64)>,
}

/// A stiff-tissue loading: `e` Pa, ν `nu`, loaded over 0.25 s at 120 frames a second (the
/// pace of a hand, not of an elastic wave).
pub fn stiff_loading(e: f64, nu: f64) -> Loading {
    Loading {
        youngs_modulus: e,
        poisson_ratio: nu,
        timing: Some((0.25, 120.0)),
    }
}

// ---------------------------------------------------------------------------------------
// Hertz indentation

/// Material and geometry of the Hertz scene.
pub const HERTZ_E: f64 = 10_000.0;
/// Poisson's ratio of the Hertz block.
pub const HERTZ_NU: f64 = 0.3;
/// Radius of the Hertz indenter sphere, m.
pub const HERTZ_RADIUS: f64 = 0.01;

#[derive(Clone, Debug)]
/// One frame of the Hertz scene within the compared range.
pub struct HertzSample {
    /// Indentation depth over sphere radius (dimensionless).
    pub depth_over_radius: f64,
    /// Measured indenter force along +z, N.
    pub force: f64,
    /// Hertz's force at that depth, N.
    pub analytic: f64,
}

#[derive(Clone, Debug)]
/// What the Hertz scene measured.
pub struct HertzResult {
    /// Grid resolution: cells per sphere radius.
    pub cells_per_radius: f64,
    /// Particles in the block.
    pub particles: usize,
    /// The frames with d/R in [0.05, 0.3].
    pub samples: Vec<HertzSample>,
}

impl HertzResult {
    /// RMS of the relative force error over d/R in [0.05, 0.3].
    pub fn rms_relative_error(&self) -> f64 {
        let errs: Vec<f64> = self
            .samples
            .iter()
            .map(|s| (s.force - s.analytic) / s.analytic)
            .collect();
        (errs.iter().map(|e| e * e).sum::<f64>() / errs.len() as f64).sqrt()
    }
}

/// Scene: a sphere of radius R pressed frictionlessly into a block 6R wide and 3R deep bonded
/// to the table, no gravity, slowly (the indentation takes many elastic wave transits).
pub fn hertz_scene(cells_per_radius: f64) -> (Scene, f64, f64) {
    hertz_scene_with(
        cells_per_radius,
        Loading {
            youngs_modulus: HERTZ_E,
            poisson_ratio: HERTZ_NU,
            timing: None,
        },
    )
}

/// [`hertz_scene`] with another material and time scale.
pub fn hertz_scene_with(cells_per_radius: f64, loading: Loading) -> (Scene, f64, f64) {
    let (e, nu) = (loading.youngs_modulus, loading.poisson_ratio);
    let r = HERTZ_RADIUS;
    let dx = r / cells_per_radius;
    let (w, h) = (6.0 * r, 3.0 * r);
    let table = 3.0 * dx;
    let top = table + h;
    let density = 1000.0;
    let c = Lame::from_young_poisson(e, nu).p_wave_speed(density);
    // Load over 12 transits of the block depth; damping near the block's lowest mode
    // removes the ringing so the force is the quasi-static one.
    let (duration, frame_rate) = loading
        .timing
        .unwrap_or((12.0 * h / c, 100.0 / (12.0 * h / c)));
    let d_max = 0.32 * r;
    let start = [0.0, 0.0, top + r + 0.5 * dx];
    let end = [0.0, 0.0, top + r - d_max];
    let margin = 4.0 * dx;
    let scene = scene(
        "hertz",
        frame_rate,
        domain(
            [-0.5 * w - margin, -0.5 * w - margin, 0.0],
            [
                w + 2.0 * margin,
                w + 2.0 * margin,
                top + 2.0 * r + 2.0 * margin,
            ],
            dx,
            [0.0; 3],
        ),
        Some(bonded_table(table)),
        vec![tissue(
            [0.0, 0.0, table + 0.5 * h],
            [w, w, h],
            material(e, nu, density, 0.5 * c / h),
        )],
        vec![tool(
            "indenter",
            Shape::Sphere { radius: r as f32 },
            ContactModel::Coulomb {
                friction: 0.0,
                drag: 0.0,
            },
            vec![
                key(0.0, start, [0.0; 3], 0.0),
                key(duration, end, [0.0; 3], 0.0),
            ],
        )],
    );
    (scene, top, duration)
}

/// Runs the Hertz scene; force from the indenter's contact wrench, indentation from the
/// sphere's lowest point below the undeformed surface.
pub fn hertz(cells_per_radius: f64) -> HertzResult {
    let (scene, _, _) = hertz_scene(cells_per_radius);
    hertz_on(
        cells_per_radius,
        scene.solver.backend,
        scene.solver.p2g_atomics,
    )
}

/// [`hertz`] on a chosen backend and P2G variant.
pub fn hertz_on(
    cells_per_radius: f64,
    backend: crate::mpm::backend::BackendChoice,
    p2g: crate::mpm::backend::P2gAtomics,
) -> HertzResult {
    let (mut scene, _, _) = hertz_scene(cells_per_radius);
    scene.solver.backend = backend;
    scene.solver.p2g_atomics = p2g;
    hertz_run(cells_per_radius, &scene, &mut Meter::default())
}

/// Runs a Hertz scene from [`hertz_scene`] (its solver settings possibly changed).
pub fn hertz_run(cells_per_radius: f64, scene: &Scene, meter: &mut Meter) -> HertzResult {
    let block = &scene.tissues[0];
    let top = block.center[2] + 0.5 * block.size[2];
    let duration = scene.tools[0].keyframes.last().map_or(0.0, |k| k.t);
    let (e, nu) = (block.material.youngs_modulus, block.material.poisson_ratio);
    let mut world = World::new(scene);
    let mut samples = Vec::new();
    while world.time() < duration - 1e-9 {
        let report = meter.step(&mut world).expect("Hertz scene is stable");
        let pose = world.tools()[0].pose_at(world.time());
        let depth = top - (pose.position.z - HERTZ_RADIUS);
        let d_over_r = depth / HERTZ_RADIUS;
        if (0.05..=0.3).contains(&d_over_r) {
            samples.push(HertzSample {
                depth_over_radius: d_over_r,
                force: report.wrenches[0].force.z,
                analytic: hertz_force(e, nu, HERTZ_RADIUS, depth),
            });
        }
    }
    HertzResult {
        cells_per_radius,
        particles: world.particles().len(),
        samples,
    }
}

// ---------------------------------------------------------------------------------------
// Axially vibrating bar

/// Young's modulus of the vibrating bar, Pa.
pub const BAR_E: f64 = 10_000.0;
/// Poisson's ratio of the vibrating bar.
pub const BAR_NU: f64 = 0.25;
/// Density of the vibrating bar, kg/m³.
pub const BAR_DENSITY: f64 = 1000.0;
/// Bar length over thickness.
pub const BAR_SLENDERNESS: f64 = 10.0;

#[derive(Clone, Debug)]
/// What the vibrating bar measured.
pub struct BarResult {
    /// Grid resolution: cells across the bar's thickness.
    pub cells_across: u32,
    /// Free length of the bar, m.
    pub length: f64,
    /// Measured period of the first axial mode, s (NaN when fewer than two crossings were seen).
    pub period: f64,
    /// The thin-bar period 4L/c with c = √(E/ρ), s.
    pub analytic_period: f64,
    /// Velocity amplitude kept per period (1: none lost), from the peaks of the free half's
    /// mean axial velocity between the measured crossings; the bar has no material damping,
    /// so the loss is the integrator's and the transfers' numerical damping.
    pub amplitude_per_period: f64,
}

impl BarResult {
    /// Signed relative period error, (measured − analytic) / analytic.
    pub fn relative_error(&self) -> f64 {
        (self.period - self.analytic_period) / self.analytic_period
    }
}

/// Scene: a bar along x, `cells_across` cells thick, one end held by a sticky clamp, no
/// gravity. Returns the scene, the clamp face x and the bar's free length.
pub fn bar_scene(cells_across: u32) -> (Scene, f64, f64) {
    let thickness = 0.004;
    let dx = thickness / cells_across as f64;
    let length = BAR_SLENDERNESS * thickness;
    let clamp_len = 4.0 * dx;
    let margin = 4.0 * dx;
    let x0 = 0.0; // clamp face
    let total = length + clamp_len;
    let size = [
        total + 2.0 * margin + 4.0 * dx,
        thickness + 2.0 * margin,
        thickness + 2.0 * margin,
    ];
    let origin = [x0 - clamp_len - margin, -0.5 * size[1], -0.5 * size[2]];
    let c_bar = (BAR_E / BAR_DENSITY).sqrt();
    let scene = scene(
        "vibrating-bar",
        // ~100 frames per period for a well-resolved zero crossing.
        100.0 * c_bar / (4.0 * length),
        domain(origin, size, dx, [0.0; 3]),
        None,
        vec![tissue(
            [x0 - clamp_len + 0.5 * total, 0.0, 0.0],
            [total, thickness, thickness],
            material(BAR_E, BAR_NU, BAR_DENSITY, 0.0),
        )],
        vec![tool(
            "clamp",
            Shape::Box {
                half_extents: [
                    (0.5 * clamp_len + dx) as f32,
                    thickness as f32,
                    thickness as f32,
                ],
            },
            ContactModel::Sticky,
            vec![key(
                0.0,
                [x0 - 0.5 * clamp_len - dx, 0.0, 0.0],
                [0.0; 3],
                0.0,
            )],
        )],
    );
    (scene, x0, length)
}

/// Starts the bar in its first axial mode (v = v₀ sin(π x / 2L)) and measures the period
/// from the zero crossings of the free half's mean axial velocity.
pub fn vibrating_bar(cells_across: u32) -> BarResult {
    let (scene, _, _) = bar_scene(cells_across);
    bar_run(cells_across, &scene, &mut Meter::default())
}

/// Runs a bar scene from [`bar_scene`] (its solver settings possibly changed).
pub fn bar_run(cells_across: u32, scene: &Scene, meter: &mut Meter) -> BarResult {
    let (_, x0, length) = bar_scene(cells_across);
    let mut world = World::new(scene);
    let c_bar = (BAR_E / BAR_DENSITY).sqrt();
    let analytic_period = 4.0 * length / c_bar;
    let v0 = 1e-3 * c_bar; // strain amplitude 1e-3: linear regime
    let p = world.particles_mut();
    for (x, v) in p.x.iter().zip(p.v.iter_mut()) {
        let s = ((x.x as f64 - x0) / length).clamp(0.0, 1.0);
        v.x = (v0 * (std::f64::consts::FRAC_PI_2 * s).sin()) as f32;
    }
    let probe_velocity = |w: &mut World| -> f64 {
        w.sync_particles();
        let p = w.particles();
        let (sum, n) =
            p.x.iter()
                .zip(&p.v)
                .filter(|(x, _)| x.x as f64 > x0 + 0.5 * length)
                .fold((0.0, 0usize), |(s, n), (_, v)| (s + v.x as f64, n + 1));
        sum / n.max(1) as f64
    };
    // Downward zero crossings of the velocity, interpolated linearly in time.
    let mut crossings = Vec::new();
    // Largest velocity of each cycle ending at a crossing.
    let mut peaks = Vec::new();
    let mut peak: f64 = 0.0;
    let mut prev = (world.time(), probe_velocity(&mut world));
    while world.time() < 2.6 * analytic_period && crossings.len() < 3 {
        meter.step(&mut world).expect("bar scene is stable");
        let now = (world.time(), probe_velocity(&mut world));
        peak = peak.max(now.1);
        if prev.1 > 0.0 && now.1 <= 0.0 {
            crossings.push(prev.0 + (now.0 - prev.0) * prev.1 / (prev.1 - now.1));
            peaks.push(peak);
            peak = 0.0;
        }
        prev = now;
    }
    // The first cycle's peak includes the start, where the probe velocity is highest.
    let amplitude_per_period = match peaks.len() {
        n if n >= 3 => (peaks[n - 1] / peaks[1]).powf(1.0 / (n - 2) as f64),
        _ => f64::NAN,
    };
    let period = match crossings.len() {
        n if n >= 2 => (crossings[n - 1] - crossings[0]) / (n - 1) as f64,
        _ => f64::NAN,
    };
    BarResult {
        cells_across,
        length,
        period,
        analytic_period,
        amplitude_per_period,
    }
}

// ---------------------------------------------------------------------------------------
// Large stretch

/// Young's modulus of the stretched block, Pa.
pub const STRETCH_E: f64 = 10_000.0;
/// Poisson's ratio of the stretched block.
pub const STRETCH_NU: f64 = 0.3;

#[derive(Clone, Debug)]
/// What the large-stretch scene measured.
pub struct StretchResult {
    /// Grid resolution: cells across the block's thickness.
    pub cells_across: u32,
    /// Stretch of the free length (1: none).
    pub stretch: f64,
    /// Mean fixed-grip reaction along +x over the settled last 10 % of the run, N.
    pub force: f64,
    /// Uniaxial Neo-Hookean force P(s)·A₀, N.
    pub analytic: f64,
}

impl StretchResult {
    /// Signed relative force error, (measured − analytic) / analytic.
    pub fn relative_error(&self) -> f64 {
        (self.force - self.analytic) / self.analytic
    }
}

/// Scene: a block 5× longer than thick between two sticky grips; the right grip moves slowly
/// to `stretch` × the free length. Returns the scene, the free length and the duration.
pub fn stretch_scene(cells_across: u32, stretch: f64) -> (Scene, f64, f64) {
    stretch_scene_with(
        cells_across,
        stretch,
        Loading {
            youngs_modulus: STRETCH_E,
            poisson_ratio: STRETCH_NU,
            timing: None,
        },
    )
}

/// [`stretch_scene`] with another material and time scale.
pub fn stretch_scene_with(cells_across: u32, stretch: f64, loading: Loading) -> (Scene, f64, f64) {
    let (e, nu) = (loading.youngs_modulus, loading.poisson_ratio);
    let thickness = 0.004;
    let dx = thickness / cells_across as f64;
    let free = 5.0 * thickness;
    let grip = 3.0 * dx;
    let total = free + 2.0 * grip;
    let margin = 4.0 * dx;
    let travel = (stretch - 1.0) * free;
    let size = [
        total + travel.max(0.0) + 2.0 * margin + 2.0 * dx,
        thickness * 2.0 + 2.0 * margin,
        thickness * 2.0 + 2.0 * margin,
    ];
    let origin = [
        -0.5 * free - grip - margin - dx,
        -0.5 * size[1],
        -0.5 * size[2],
    ];
    let density = 1000.0;
    let c = Lame::from_young_poisson(e, nu).p_wave_speed(density);
    let (duration, frame_rate) = loading
        .timing
        .unwrap_or((40.0 * free / c, 200.0 / (40.0 * free / c)));
    let grip_shape = Shape::Box {
        half_extents: [(0.5 * grip + dx) as f32, thickness as f32, thickness as f32],
    };
    let left = -0.5 * free - 0.5 * grip - dx;
    let right = 0.5 * free + 0.5 * grip + dx;
    let scene = scene(
        "large-stretch",
        frame_rate,
        domain(origin, size, dx, [0.0; 3]),
        None,
        vec![tissue(
            [0.0, 0.0, 0.0],
            [total, thickness, thickness],
            material(e, nu, density, 2.0 * c / free),
        )],
        vec![
            tool(
                "fixed_grip",
                grip_shape,
                ContactModel::Sticky,
                vec![key(0.0, [left, 0.0, 0.0], [0.0; 3], 0.0)],
            ),
            tool(
                "moving_grip",
                grip_shape,
                ContactModel::Sticky,
                vec![
                    key(0.0, [right, 0.0, 0.0], [0.0; 3], 0.0),
                    key(0.8 * duration, [right + travel, 0.0, 0.0], [0.0; 3], 0.0),
                ],
            ),
        ],
    );
    (scene, free, duration)
}

/// Stretches to `stretch` with `method`, lets the block settle, and compares the fixed
/// grip's reaction force with the analytic uniaxial Neo-Hookean force P(s)·A₀.
pub fn large_stretch(method: Method, cells_across: u32, stretch: f64) -> StretchResult {
    let (mut scene, _, _) = stretch_scene(cells_across, stretch);
    scene.solver.method = method;
    stretch_run(cells_across, stretch, &scene, &mut Meter::default())
}

/// Runs a stretch scene from [`stretch_scene`] (its solver settings possibly changed).
pub fn stretch_run(
    cells_across: u32,
    stretch: f64,
    scene: &Scene,
    meter: &mut Meter,
) -> StretchResult {
    // The moving grip arrives at 0.8 × the run (see `stretch_scene_with`).
    let duration = scene.tools[1].keyframes.last().map_or(0.0, |k| k.t) / 0.8;
    let material = &scene.tissues[0].material;
    let thickness = 0.004;
    let mut world = World::new(scene);
    // Average the reaction over the settled tail of the run.
    let (mut sum, mut n) = (0.0, 0);
    while world.time() < duration - 1e-9 {
        let report = meter.step(&mut world).expect("stretch scene is stable");
        if world.time() > 0.9 * duration {
            // The fixed grip is pulled towards +x by a stretched block.
            sum += report.wrenches[0].force.x;
            n += 1;
        }
    }
    let area = thickness * thickness;
    StretchResult {
        cells_across,
        stretch,
        force: sum / n.max(1) as f64,
        analytic: neo_hookean_uniaxial_stress(
            material.youngs_modulus,
            material.poisson_ratio,
            stretch,
        ) * area,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn analytic_formulas() {
        // Small stretch: P ≈ E (s − 1).
        let p = neo_hookean_uniaxial_stress(1000.0, 0.3, 1.001);
        assert!((p / 1.0 - 1.0).abs() < 0.01, "{p}");
        // Incompressible limit: P → μ(s − s⁻²).
        let (e, nu, s) = (3000.0, 0.4999, 1.3);
        let mu = e / (2.0 * (1.0 + nu));
        let p = neo_hookean_uniaxial_stress(e, nu, s);
        assert!((p - mu * (s - 1.0 / (s * s))).abs() / p < 2e-3, "{p}");
        assert!((hertz_force(1.0, 0.0, 1.0, 1.0) - 4.0 / 3.0).abs() < 1e-12);
    }

    #[test]
    fn analytic_scenes_are_valid() {
        for scene in [hertz_scene(4.0).0, bar_scene(4).0, stretch_scene(4, 1.3).0] {
            let problems = crate::config::validate(&scene);
            assert!(problems.is_empty(), "{}: {problems:?}", scene.name);
        }
    }
}
