//! The host's side of an implicit substep on the device (see `super`): Newton, the line
//! search and the active-set rounds decide on the host from the scalar block read back
//! after each submission, as the CPU solver's `solve_velocities` does; the conjugate
//! gradients run on the device in chunks of [`CG_CHUNK`] iterations.

use super::layout::{scalar, GROUP};
use super::{nodes, particles, single, ImplicitStages, CG_CHUNK};
use crate::mpm::frame_plan::FramePlan;
use crate::mpm::gpu::pass::CountingPass;
use crate::mpm::gpu::resources::ARGS_GROUP;
use crate::mpm::gpu::{GpuSolver, Groups};
use crate::mpm::implicit_params::{
    forcing_term, ARMIJO, CONTACT_ROUNDS, ENERGY_ROUNDING, LINE_SEARCH_TRIALS, RESIDUAL_FLOOR,
};
use crate::mpm::{ImplicitParams, SolveCounts};
use std::sync::mpsc;

/// Newton's absolute residual scales (N·s): the floor (a velocity error of 1e-5·dx/dt per
/// node) and the momentum gravity gives the nodes in one step.
struct Scales {
    floor: f64,
    gravity: f64,
}

/// The scalar block read back.
struct Scalars([u32; scalar::WORDS]);

impl Scalars {
    fn word(&self, i: u32) -> u32 {
        self.0[i as usize]
    }

    fn f(&self, i: u32) -> f64 {
        f32::from_bits(self.word(i)) as f64
    }
}

impl GpuSolver {
    /// Records `f` into a compute pass bound to substep `s` and the implicit group, submits
    /// it and, with `read`, returns the scalar block after it.
    fn implicit_pass(
        &self,
        s: u32,
        read: bool,
        f: impl FnOnce(&mut CountingPass, &ImplicitStages, &Groups),
    ) -> Option<Scalars> {
        let im = self.implicit.as_ref().expect("implicit stages");
        let device = &self.ctx.device;
        let mut encoder = device.create_command_encoder(&wgpu::CommandEncoderDescriptor {
            label: Some("implicit"),
        });
        {
            let groups = self.groups();
            let mut pass =
                CountingPass::new(encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                    label: Some("implicit"),
                    timestamp_writes: None,
                }));
            self.res.bind_step(&mut pass, s);
            pass.set_bind_group(GROUP, &im.bind_group, &[]);
            f(&mut pass, im, &groups);
        }
        if read {
            encoder.copy_buffer_to_buffer(&im.scalars, 0, &im.staging, 0, None);
        }
        self.ctx.queue.submit([encoder.finish()]);
        if !read {
            return None;
        }
        let (tx, rx) = mpsc::channel();
        im.staging
            .slice(..)
            .map_async(wgpu::MapMode::Read, move |r| {
                let _ = tx.send(r);
            });
        device
            .poll(wgpu::PollType::wait_indefinitely())
            .expect("GPU device lost during the implicit solve");
        rx.recv()
            .expect("map callback ran")
            .expect("implicit scalar readback failed");
        let mut words = [0u32; scalar::WORDS];
        words.copy_from_slice(bytemuck::cast_slice(
            &im.staging.slice(..).get_mapped_range(),
        ));
        im.staging.unmap();
        Some(Scalars(words))
    }

    /// Writes scalar word `i` (host-set: α, the CG target, the epoch, the cap).
    fn write_scalar(&self, i: u32, bits: u32) {
        let im = self.implicit.as_ref().expect("implicit stages");
        self.ctx
            .queue
            .write_buffer(&im.scalars, (i * 4) as u64, bytemuck::bytes_of(&bits));
    }

    /// Φ at v or the trial; infinite where a particle would be crushed.
    fn implicit_energy(&self, s: u32, trial: bool) -> f64 {
        self.write_scalar(scalar::CRUSH, 0);
        let sc = self
            .implicit_pass(s, true, |pass, im, g| im.record_energy(pass, trial, g))
            .expect("read back");
        if sc.word(scalar::CRUSH) != 0 {
            return f64::INFINITY;
        }
        sc.f(scalar::SLOT_ELASTIC) + sc.f(scalar::SLOT_KINETIC)
    }

    /// Φ and ‖∇Φ‖ at v (with `hessian` the stiffness and preconditioner too).
    fn implicit_evaluate(&self, s: u32, hessian: bool) -> (f64, f64) {
        let sc = self
            .implicit_pass(s, true, |pass, im, g| im.record_evaluate(pass, hessian, g))
            .expect("read back");
        (
            sc.f(scalar::SLOT_ELASTIC) + sc.f(scalar::SLOT_KINETIC),
            sc.f(scalar::SLOT_KINETIC + 1).max(0.0).sqrt(),
        )
    }

    /// One implicit substep of `dt` under `gravity`, recorded and submitted in pieces
    /// (module docs); scenes that cut are refused at construction, so P2G is momentum and
    /// mass alone.
    fn implicit_substep(&mut self, s: u32, dt: f32, gravity: f32) -> SolveCounts {
        let params = self.implicit.as_ref().expect("implicit stages").params;
        let epoch = self.implicit.as_ref().map_or(0, |im| im.epoch);
        self.write_scalar(scalar::EPOCH, epoch);
        self.write_scalar(scalar::CAP, params.cg_iterations);
        self.write_scalar(scalar::CRUSH, 0);
        // Block list, clear, P2G, the nodes' start (and Σm²); Φ of the carried velocities.
        let sc = self
            .implicit_pass(s, true, |pass, im, g| {
                pass.set_bind_group(ARGS_GROUP, &self.res.args_group, &[]);
                self.sparse.record(pass, g);
                pass.set_bind_group(GROUP, &im.bind_group, &[]);
                let p = &im.pipelines;
                nodes(pass, &p.p2g_clear, g);
                particles(pass, &p.p2g_bound, g);
                particles(pass, &p.p2g, g);
                nodes(pass, &p.prepare, g);
                single(pass, &p.sum_mass);
                im.record_energy(pass, false, g);
            })
            .expect("read back");
        let mass_norm = sc.f(scalar::SLOT_MASS).max(0.0).sqrt();
        let carried = if sc.word(scalar::CRUSH) != 0 {
            f64::INFINITY
        } else {
            sc.f(scalar::SLOT_ELASTIC) + sc.f(scalar::SLOT_KINETIC)
        };
        // Warm start: the lowest Φ of v*, rest and v* plus the last elastic change.
        let rest = self.implicit_energy(s, true);
        let mut best = carried;
        if rest < carried {
            self.implicit_pass(s, false, |pass, im, g| nodes(pass, &im.pipelines.accept, g));
            best = rest;
        }
        if epoch > 0 {
            self.implicit_pass(s, false, |pass, im, g| {
                nodes(pass, &im.pipelines.trial_correction, g)
            });
            if self.implicit_energy(s, true) < best {
                self.implicit_pass(s, false, |pass, im, g| nodes(pass, &im.pipelines.accept, g));
            }
        }
        let scales = Scales {
            floor: RESIDUAL_FLOOR * mass_norm * (self.layout.dx / dt) as f64,
            gravity: (gravity * dt) as f64 * mass_norm,
        };
        let counts = self.implicit_newton(s, &params, scales);
        self.implicit_pass(s, false, |pass, im, g| {
            nodes(pass, &im.pipelines.finish, g);
            self.grid_update.record_implicit(pass, g);
            self.g2p.record(pass, g);
            self.grid_update.record_reduce(pass);
        });
        if let Some(im) = self.implicit.as_mut() {
            im.epoch += 1;
        }
        counts
    }

    /// Newton's method on the grid velocities (cpu `solve_velocities`): Newton on the
    /// active set, then the nodes the solution moves into a tool, the table or a wall join
    /// it and Newton resumes, at most `CONTACT_ROUNDS` times.
    fn implicit_newton(&mut self, s: u32, params: &ImplicitParams, scales: Scales) -> SolveCounts {
        let mut counts = SolveCounts::default();
        let mut first_norm = None;
        let mut residuals = Vec::new();
        let (mut energy, mut norm) = self.implicit_evaluate(s, true);
        for round in 0..=CONTACT_ROUNDS {
            let mut newton = 0;
            let mut previous: Option<(f64, f64)> = None;
            loop {
                residuals.push(norm);
                let reference = first_norm.get_or_insert(norm).max(scales.gravity);
                let goal = (params.newton_tolerance as f64 * reference).max(scales.floor);
                if norm <= goal || newton >= params.newton_iterations {
                    break;
                }
                let eta = forcing_term(norm, previous, goal, params.cg_tolerance as f64);
                previous = Some((norm, eta));
                counts.cg += self.implicit_cg(s, eta * norm);
                newton += 1;
                let at_rounding = match self.implicit_line_search(s, energy) {
                    Some((e, at_rounding)) if e.is_finite() => at_rounding,
                    _ => break,
                };
                let more = !at_rounding && newton < params.newton_iterations;
                (energy, norm) = self.implicit_evaluate(s, more);
                if at_rounding {
                    residuals.push(norm);
                    break;
                }
            }
            counts.newton += newton;
            if round == CONTACT_ROUNDS {
                break;
            }
            let activated = self.implicit_activate(s);
            counts.activated += activated;
            if activated == 0 {
                break;
            }
            (energy, norm) = self.implicit_evaluate(s, true);
        }
        if let Some(im) = self.implicit.as_mut() {
            im.residuals = residuals;
        }
        counts
    }

    /// Grows the active set at the iterate (cpu `activate_constraints`); returns how many
    /// nodes gained a constraint.
    fn implicit_activate(&self, s: u32) -> u32 {
        self.write_scalar(scalar::ACTIVATED, 0);
        self.implicit_pass(s, true, |pass, im, g| {
            nodes(pass, &im.pipelines.activate, g)
        })
        .expect("read back")
        .word(scalar::ACTIVATED)
    }

    /// Preconditioned CG until ‖r‖ ≤ `target` or the cap; returns its iterations.
    fn implicit_cg(&self, s: u32, target: f64) -> u32 {
        self.write_scalar(scalar::TARGET, (target as f32).to_bits());
        self.implicit_pass(s, false, |pass, im, g| {
            let p = &im.pipelines;
            nodes(pass, &p.cg_init, g);
            single(pass, &p.sum_rz0);
            single(pass, &p.cg_start);
        });
        loop {
            let sc = self
                .implicit_pass(s, true, |pass, im, g| {
                    for _ in 0..CG_CHUNK {
                        im.record_cg_iteration(pass, g);
                    }
                })
                .expect("read back");
            if sc.word(scalar::DONE) != 0 {
                return sc.word(scalar::ITER);
            }
        }
    }

    /// Backtracking along the Newton step (cpu `line_search`).
    fn implicit_line_search(&self, s: u32, energy: f64) -> Option<(f64, bool)> {
        let slope = self
            .implicit_pass(s, true, |pass, im, g| {
                nodes(pass, &im.pipelines.slope, g);
                single(pass, &im.pipelines.sum_slope);
            })
            .expect("read back")
            .f(scalar::SLOT_SLOPE);
        let noise = ENERGY_ROUNDING * energy.abs();
        let trial_at = |alpha: f32| {
            self.write_scalar(scalar::ALPHA, alpha.to_bits());
            self.implicit_pass(s, false, |pass, im, g| {
                nodes(pass, &im.pipelines.trial_step, g)
            });
            self.implicit_energy(s, true)
        };
        let accept = || {
            self.implicit_pass(s, false, |pass, im, g| nodes(pass, &im.pipelines.accept, g));
        };
        if -0.5 * slope <= noise {
            let trial_energy = trial_at(1.0);
            if !trial_energy.is_finite() {
                return None;
            }
            accept();
            return Some((trial_energy, true));
        }
        let mut alpha = 1.0f32;
        let mut trial_energy = f64::NAN;
        for _ in 0..LINE_SEARCH_TRIALS {
            trial_energy = trial_at(alpha);
            if trial_energy <= energy + ARMIJO * alpha as f64 * slope + noise {
                break;
            }
            alpha *= 0.5;
        }
        accept();
        Some((trial_energy, false))
    }
}

impl GpuSolver {
    /// A frame of implicit substeps: the frame-start copy, each substep in its submissions,
    /// then the frame's end and readback as the explicit solver's.
    pub(in crate::mpm::gpu) fn submit_implicit_frame(&mut self, plan: &FramePlan) {
        let device = &self.ctx.device;
        let mut encoder = device.create_command_encoder(&wgpu::CommandEncoderDescriptor {
            label: Some("frame start"),
        });
        self.record_frame_start(&mut encoder, plan.part);
        self.ctx.queue.submit([encoder.finish()]);
        let mut solve = SolveCounts::default();
        for s in 0..plan.substeps {
            solve.add(self.implicit_substep(s, plan.dt, plan.gravity.norm()));
        }
        self.frame_solve = solve;
        let mut encoder = self
            .ctx
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("frame end"),
            });
        {
            let groups = self.groups();
            let mut pass =
                CountingPass::new(encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                    label: Some("frame end"),
                    timestamp_writes: None,
                }));
            if plan.part.last {
                self.res.bind_step(&mut pass, 0);
                self.g2p.record_frame_end(&mut pass, &groups);
            }
        }
        self.submit_with_readback(encoder, plan.part.last);
    }

    /// ‖∇Φ‖ over the free components at each Newton iterate of the last implicit substep
    /// (N·s), the first the warm start's; empty for the explicit methods.
    pub fn implicit_residuals(&self) -> &[f64] {
        self.implicit.as_ref().map_or(&[], |im| &im.residuals)
    }
}
