//! Small builders for scenes made in code (benchmarks and accuracy scenes), so that they
//! run through exactly the same `World` as scene files do.

use crate::config::{Domain, Hold, Keyframe, Material, Scene, Solver, Table, Tissue, Tool};
use crate::mpm::material::MaterialModel;
use crate::tools::{ContactModel, Shape};

pub fn domain(origin: [f64; 3], size: [f64; 3], dx: f64, gravity: [f64; 3]) -> Domain {
    Domain {
        origin,
        size,
        dx,
        gravity,
    }
}

pub fn material(e: f64, nu: f64, density: f64, damping: f64) -> Material {
    Material {
        model: MaterialModel::NeoHookean,
        youngs_modulus: e,
        poisson_ratio: nu,
        density,
        damping,
    }
}

pub fn tissue(center: [f64; 3], size: [f64; 3], material: Material) -> Tissue {
    Tissue {
        name: "tissue".into(),
        center,
        size,
        particles_per_axis: 2,
        material,
    }
}

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

pub fn tool(name: &str, shape: Shape, contact: ContactModel, keyframes: Vec<Keyframe>) -> Tool {
    Tool {
        name: name.into(),
        shape,
        contact,
        keyframes,
    }
}

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
        domain,
        solver: Solver::default(),
        table,
        tissues,
        tools,
        arms: Vec::new(),
        teleop: None,
        outputs: Default::default(),
    }
}
