//! Small builders for scenes made in code (tests, benchmarks and the analytic scenes), so
//! that they run through exactly the same `World` as scene files do; and the scenes that
//! tests and benchmarks share.

use crate::config::{Domain, Hold, Keyframe, Material, Scene, Solver, Table, Tissue, Tool};
use crate::mpm::material::MaterialModel;
use crate::tools::{ContactModel, Shape};

/// A domain with lower corner `origin` and extent `size` (m), grid spacing `dx` (m) and `gravity`
/// (m/s²).
pub fn domain(origin: [f64; 3], size: [f64; 3], dx: f64, gravity: [f64; 3]) -> Domain {
    Domain {
        origin,
        size,
        dx,
        gravity,
    }
}

/// A Neo-Hookean material: Young's modulus `e` (Pa), Poisson's ratio `nu`, `density` (kg/m³) and
/// `damping` (1/s); no tearing.
pub fn material(e: f64, nu: f64, density: f64, damping: f64) -> Material {
    Material {
        model: MaterialModel::NeoHookean,
        youngs_modulus: e,
        poisson_ratio: nu,
        density,
        damping,
        toughness: None,
    }
}

/// A block named `tissue` centred at `center` with extent `size` (m), 2 particles per cell axis.
pub fn tissue(center: [f64; 3], size: [f64; 3], material: Material) -> Tissue {
    Tissue {
        name: "tissue".into(),
        center,
        size,
        particles_per_axis: 2,
        material,
    }
}

/// A frictionless table at `height` (m) that the tissue's bottom is bonded to.
pub fn bonded_table(height: f64) -> Table {
    Table {
        height,
        hold: Hold::Bonded,
        friction: 0.0,
    }
}

/// Keyframe at time `t`, position `p`, orientation roll/pitch/yaw (deg), jaw (deg).
pub fn key(t: f64, p: [f64; 3], rpy_deg: [f64; 3], jaw_deg: f64) -> Keyframe {
    Keyframe {
        t,
        position: p,
        rpy_deg,
        jaw_deg,
    }
}

/// A tool with default jaw gains, moved along `keyframes`.
pub fn tool(name: &str, shape: Shape, contact: ContactModel, keyframes: Vec<Keyframe>) -> Tool {
    Tool {
        name: name.into(),
        shape,
        contact,
        jaw: Default::default(),
        keyframes,
    }
}

/// A scene with default solver, outputs and sleep settings, and no threads, arms or teleoperation.
pub fn scene(
    name: &str,
    frame_rate_hz: f64,
    domain: Domain,
    table: Option<Table>,
    tissues: Vec<Tissue>,
    tools: Vec<Tool>,
) -> Scene {
    Scene {
        name: name.into(),
        frame_rate_hz,
        settle_s: super::scene::default_settle_s(),
        domain,
        solver: Solver::default(),
        table,
        tissues,
        wound: None,
        threads: Vec::new(),
        tools,
        arms: Vec::new(),
        teleop: Vec::new(),
        outputs: Default::default(),
        sleep: Default::default(),
        camera: None,
    }
}

/// Grasp and lift: a 6 mm block resting on a table with friction, a gripper pointing down
/// whose 2 mm jaws (two cells at dx = 1 mm) open at 70°, stay open until `open_until`, close
/// to 25° by `closed_at`, then lift by `lift` metres by `lifted_at` (seconds).
pub fn grasp_scene(open_until: f64, closed_at: f64, lifted_at: f64, lift: f64) -> Scene {
    let gripper = Shape::Gripper {
        jaw_length: 0.01,
        jaw_width: 0.006,
        jaw_thickness: 0.002,
    };
    let rpy = [180.0, 0.0, 90.0];
    let pivot = [0.0, 0.0, 0.0135];
    let raised = [0.0, 0.0, 0.0135 + lift];
    let mut s = scene(
        "grasp",
        60.0,
        domain(
            [-0.016, -0.016, 0.0],
            [0.032, 0.032, 0.048],
            0.001,
            [0.0, 0.0, -9.81],
        ),
        Some(Table {
            height: 0.002,
            hold: Hold::Resting,
            friction: 0.3,
        }),
        vec![tissue(
            [0.0, 0.0, 0.005],
            [0.006, 0.006, 0.006],
            material(5000.0, 0.4, 1000.0, 2.0),
        )],
        vec![tool(
            "gripper",
            gripper,
            ContactModel::Coulomb {
                friction: 2.0,
                drag: 0.0,
            },
            vec![
                key(0.0, pivot, rpy, 70.0),
                key(open_until, pivot, rpy, 70.0),
                key(closed_at, pivot, rpy, 25.0),
                key(lifted_at, raised, rpy, 25.0),
            ],
        )],
    );
    s.solver.max_substeps_per_frame = 400;
    s
}

/// The seed-000 benchmark scene: a 0.1 m domain on a 64³ grid, a 24×25×5-cell block with
/// 8 particles per cell (24,000 particles), liver-like Neo-Hookean material, gripper lift.
pub fn seed000_scene() -> Scene {
    let dx = 0.1 / 64.0;
    let size = [24.0 * dx, 25.0 * dx, 5.0 * dx];
    let table = 4.0 * dx;
    let top = table + size[2];
    let gripper = Shape::Gripper {
        jaw_length: 0.01,
        jaw_width: 0.005,
        jaw_thickness: 0.0032,
    };
    let x = 0.5 * size[0] - 0.004;
    let rpy = [180.0, 0.0, 90.0];
    let frames = vec![
        key(0.0, [x, 0.0, top + 0.004], rpy, 60.0),
        key(0.1, [x, 0.0, top + 0.006], rpy, 60.0),
        key(0.2, [x, 0.0, top + 0.006], rpy, 5.0),
        key(1.0, [x, 0.0, top + 0.03], rpy, 5.0),
    ];
    scene(
        "seed000-retraction",
        40.0,
        domain([-0.05, -0.05, 0.0], [0.1, 0.1, 0.1], dx, [0.0, 0.0, -9.81]),
        Some(bonded_table(table)),
        vec![tissue(
            [0.0, 0.0, table + 0.5 * size[2]],
            size,
            material(5000.0, 0.4, 1000.0, 2.0),
        )],
        vec![tool(
            "gripper",
            gripper,
            ContactModel::Coulomb {
                friction: 2.0,
                drag: 0.0,
            },
            frames,
        )],
    )
}
