//! Explicit time-step bound (CFL).
//!
//! MLS-MPM is explicit: information must not cross more than a fraction `cfl` of a cell per
//! step, whether it travels as an elastic wave (P-wave speed √((λ+2μ)/ρ)) or with the
//! material itself. `dt ≤ cfl · dx / max(c_p, |v|max)`.

/// Largest stable substep (s).
pub fn stable_dt(cfl: f64, dx: f64, wave_speed: f64, max_particle_speed: f64) -> f64 {
    cfl * dx / wave_speed.max(max_particle_speed).max(1e-9)
}

/// Longest step over which material moving at `speed` and accelerated by `gravity` (m/s²)
/// travels at most `cfl · dx`: |v|·dt + ½|g|·dt² ≤ cfl·dx. The bound of an integrator
/// stable at any step (implicit), whose step only advection limits: gravity's share keeps
/// the first Newton iterate, which falls freely, from crushing the cells above a fixed
/// support.
pub fn advection_dt(cfl: f64, dx: f64, speed: f64, gravity: f64) -> f64 {
    let reach = cfl * dx;
    if gravity <= 1e-12 {
        return reach / speed.max(1e-9);
    }
    (-speed + (speed * speed + 2.0 * gravity * reach).sqrt()) / gravity
}

/// Splits `remaining` seconds into equal substeps no longer than `dt_limit`; returns the
/// substep length. Equal substeps avoid a sliver step at the end of each frame.
pub fn even_substep(remaining: f64, dt_limit: f64) -> f64 {
    let n = (remaining / dt_limit - 1e-9).ceil().max(1.0);
    remaining / n
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cfl_bound_matches_reference_numbers() {
        // Liver, E 5.4 kPa, ν 0.45, ρ 1060, dx 1 mm, C 0.5 → c_p ≈ 4.4 m/s, dt ≈ 114 µs.
        let lame = crate::mpm::Lame::from_young_poisson(5400.0, 0.45);
        let c = lame.p_wave_speed(1060.0);
        assert!((c - 4.4).abs() < 0.05, "c_p = {c}");
        let dt = stable_dt(0.5, 1e-3, c, 0.0);
        assert!((dt - 114e-6).abs() < 2e-6, "dt = {dt}");
        // Fast material motion takes over from the wave speed.
        assert!(stable_dt(0.5, 1e-3, c, 20.0) < dt / 4.0);
    }

    #[test]
    fn advection_bound_covers_speed_and_free_fall() {
        // No gravity: the plain CFL bound on speed.
        assert!((advection_dt(0.5, 1e-3, 0.1, 0.0) - stable_dt(0.5, 1e-3, 0.0, 0.1)).abs() < 1e-12);
        // At rest under gravity: ½ g dt² = cfl dx.
        let dt = advection_dt(0.5, 2e-3, 0.0, 9.81);
        assert!((0.5 * 9.81 * dt * dt - 1e-3).abs() < 1e-12, "{dt}");
        // Both: the distance travelled is exactly the reach.
        let dt = advection_dt(0.5, 2e-3, 0.2, 9.81);
        assert!((0.2 * dt + 0.5 * 9.81 * dt * dt - 1e-3).abs() < 1e-12);
    }

    #[test]
    fn even_substeps_never_exceed_the_limit() {
        for (remaining, limit) in [
            (1.0 / 60.0, 114e-6),
            (0.01, 0.01),
            (0.01, 0.003),
            (0.02, 0.5),
        ] {
            let dt = even_substep(remaining, limit);
            assert!(dt <= limit * (1.0 + 1e-9));
            let n = remaining / dt;
            assert!((n - n.round()).abs() < 1e-6, "{remaining}/{dt} not whole");
        }
    }
}
