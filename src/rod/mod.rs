//! The suture thread: a position-based Cosserat rod (seed 001 §III, Kugelstadt & Schömer 2016)
//! solved with XPBD compliance, all constraints at once by a direct block-tridiagonal solve,
//! so that its stiffness comes from the material and does not change with the iteration count.
//!
//! `material` turns moduli and radius into the rod's stiffnesses, `state` holds the centreline
//! points and one frame quaternion per segment, `constraints` linearises stretch-shear and
//! bend-twist, `direct` solves them together along the chain each iteration, `solver` runs
//! the substeps, `environment` adds the table, tools and grasps a frame meets and
//! `self_contact` keeps the thread from passing through itself, and `crossing` scales back the
//! length restoration after the contacts wherever it would pull a strand through another.
//! The thread in a scene (grasps, outputs, knots) is [`crate::world::thread_body`].
//!
//! # The rod
//!
//! - **Material** ([`ThreadMaterial`]): radius, Young's and shear modulus, density; EA, κGA,
//!   EI, GJ derived from them. [`ThreadMaterial::nylon_3_0`] is USP 3-0 nylon (EA ≈ 119 N,
//!   EI ≈ 3.8e-7 N·m²).
//! - **Constraints**: stretch-shear, C = (pⱼ₊₁ − pⱼ)/l − d3 with compliance 1/(EA·l) along d3
//!   and 1/(κGA·l) across it, so one constraint carries the length and the shear; bend-twist,
//!   C = Im(q̄ⱼqⱼ₊₁ ∓ Ω⁰) with compliance l̄/4·(EI, EI, GJ)⁻¹, the rest Darboux sign chosen per
//!   joint so that q and −q are the same frame. Jacobians are checked against finite
//!   differences.
//! - **Direct solve** (`direct`, Deul et al. 2018): every iteration solves
//!   (J·W·Jᵀ + α̃)·Δλ = −C − α̃λ for all constraints at once. Segment j's stretch-shear and
//!   joint j's bend-twist form a 6-row group that shares unknowns only with groups j ± 1, so
//!   the system is block tridiagonal (6×6 blocks) and block elimination solves it in O(n), in
//!   f64 (the diagonal spans inverse inertias of 1e14–1e17 against bending compliances/h² of
//!   1e6–1e8). Gauss–Seidel projections left a 2 cm cantilever drooping 1.8 cm instead of
//!   24 µm.
//! - **Held points**: any number of points may have inverse mass 0 (pinned ends, grasps),
//!   adjacent or not. The diagonal blocks are formed as the products J·W·Jᵀ (the frame part as
//!   wq·\[d3\]×\[d3\]×ᵀ, not wq·(I − d3·d3ᵀ), which differs by wq·(|d3|² − 1)·I ≈ 5e12 × 1e-7) and
//!   d3 is normalised in f64, so the system stays positive definite under rounding: a piece of
//!   chain held at both ends has only its axial compliance (~1e5) as pivot.
//! - **Tension**: `Rod::tension[j]` is segment j's axial force in newtons from the
//!   stretch-shear multipliers (−λ·t/(l·h²)).
//! - **Substeps and iterations** ([`solver::RodSolverSettings`]): 1 substep per 60 Hz frame
//!   out of contact, at least 4 while the thread can touch something (a table, a tool, or
//!   itself); 2 iterations each. Out of contact the second iteration is a chord step reusing
//!   the first's factorisation with the constraints evaluated afresh (a fifth of the cost);
//!   if the largest stretch-shear residual |C + α̃λ| is then above 5e-4, full Newton solves
//!   follow, up to 8. In contact every iteration factorises afresh and up to 4 solve → contact
//!   rounds run.
//!
//! # What a frame meets
//!
//! [`RodSolver::step_frame_in`] steps a thread among what one frame holds (a
//! [`RodEnvironment`]: the table, tools as their SDFs at the frame's start and end poses,
//! attachments for grasped points, the domain walls, self-contact) and returns a
//! [`RodFrameReport`] (contacts per substep, the largest strain).
//! - **Tool contact is continuous**: each point's path over the substep is taken in the tool's
//!   frame and sphere-traced against the shape grown by the thread radius; where it enters,
//!   the point must end outside the tangent plane there, so a 0.3 mm needle wire moving 4 mm a
//!   substep (1 m/s) cannot pass through. Segment interiors are sampled every thread diameter
//!   for tools thinner than a segment.
//! - **Friction** is position based (Macklin et al. 2014; seed 001's appendix): the contact
//!   point's slip relative to the surface over the substep is removed while below μ·d (d the
//!   penetration just corrected: static) and shortened by μ·d otherwise (kinetic).
//! - **Self-contact**: [`self_contact`], with the exact crossing test of [`crossing`].
//! - **Length in contact** (`RodSolver::restore_length`): a substep in which any contact
//!   moved a point ends with direct solves from zero stretch-shear multipliers (the bend-twist
//!   ones kept: solved from zero a compliant bend-twist constraint finds its whole multiplier
//!   again and the bending impulse is applied twice), up to 4, until the stretch residual is
//!   ≤ 5e-4; then tool contacts once more, and self-contact pairs that passed through each
//!   other or came closer than 0.95 diameters. Why: the contacts projected after each solve
//!   lengthen the segments they push, and the rounds' own multipliers cannot take that back
//!   (table friction returns each point to where the solve moved it from, every round adds the
//!   same Δλ, and a solve that keeps λ leaves the strain −α̃λ of a tension that is not there).
//!   The points are free in these solves: holding the touching points along their normals made
//!   a pile of coils worse, since nearly every point there is held in two or three directions.
//!   Projecting every contact again after the solves stretched the pile; projecting none let
//!   a thin wire lose the thread through it. The tension reported is the sum of both solves'
//!   multipliers.
//!
//! # Verification
//!
//! `cargo test --release --test thread -- --nocapture`: a 2 cm cantilever under its own weight
//! against qL⁴/8EI (tip error 19 %, 9.7 %, 4.9 % at 10, 20, 40 segments: first order); a hanging
//! thread's strain per segment within 1e-3 of (weight below)/EA; a 1 N pull stretching every
//! segment to F/EA = 0.84 % within 1e-5; a thread pinned at both ends sagging on the catenary
//! (6.0e-3, 1.9e-3, 8.9e-4 at 10, 20, 40 segments); an end moment bending a cantilever into the
//! arc of radius EI/M; Euler buckling through the beam-column's amplified deflection; a thread
//! resting on the table, stopping at the Coulomb distance, carried by a moving plate, pushed by
//! a 0.3 mm wire at 1 m/s without passing through, dragged through another strand and dropped
//! in coils without passing through itself.
//!
//! `stress` runs a `thread` group (`stress --only thread`, not in `--reduced`): a thread pulled
//! at 1 m/s across the table, a loop whose tails are pulled apart at 1 m/s, and 5 coils (200
//! segments) dropped onto the table; a case passes when it stays finite, no two segments come
//! closer than 0.9 diameter and no strain exceeds 1 %:
//!
//! | case | stable | min separation (diameters) | max strain | self contacts |
//! |---|---|---|---|---|
//! | pull 1 m/s | yes | 7.411 | 3.24e-5 | 0 |
//! | loop tightened 1 m/s | yes | 1.124 | 1.75e-5 | 10 |
//! | coils dropped | yes | 0.946 | 5.34e-3 | 24354 |
//!
//! # Cost
//!
//! `dvrk-tissue-sim bench thread --frames 120` (a free swing; the rod solver runs on the
//! calling thread alone, so `cpu ms/frame` is that thread's CPU time, which other processes do
//! not inflate):
//!
//! | segments | cpu ms/frame | elongation |
//! |---|---|---|
//! | 40 | 0.021 | 1.07e-6 |
//! | 100 | 0.056 | 9.54e-7 |
//! | 400 | 0.209 | 2.38e-6 |
//! | 1000 | 0.538 | 1.28e-5 |
//!
//! Linear in segments (0.54 µs per segment per frame), within the targets of 0.05 ms for 40
//! segments and 1 ms for 1000. What made it: the 6×6 block algebra written out on row-major
//! arrays (nalgebra's generic Cholesky solves had taken two thirds of a profile), the chord
//! second iteration, and one substep out of contact.
//!
//! In contact the cost is the knot's: `bench thread`'s last row steps `config/knot.toml`
//! headless (225 segments, 100 substeps of 3 iterations a frame, the table, two grippers and
//! self-contact in every substep): 17.15 s simulated in 48.3 s of one core, a real-time
//! factor of 0.36, the knot tied (determinant 3), largest strain 4.05e-3, no frame held
//! back. The self-contact broad phase sweeps one sorted key per segment instead of hashing
//! each swept box into every cell it covers and sorting those (`self_contact`): the same
//! pairs in the same order, so the same run to the bit, in 48.7 s of CPU against 60.5 s
//! (`/usr/bin/time run --headless --scene config/knot.toml`, the binaries before and after
//! in one sitting; real-time factor 0.283 → 0.352). What is left is the direct solve: 4.54
//! factorisations a substep (the table's last column, counted as they are done: 3 set
//! iterations, 0.54 extra ones for the residual, 1.0 restoring the length), 55 % of a
//! profile, and the tools' SDF queries (8 %). Chord steps for the rounds after the first
//! (no factorisation) ran the script in 38.2 s with the knot still tied, but let the thread
//! stretch 4.5 % in a frame (against 0.4 %): not taken. Measured again on an AMD EPYC,
//! alternated with the shipped build: 49.4 and 50.3 s against 56.2 and 57.0 s, largest
//! strain 4.46e-2 against 4.05e-3; with chord steps only where the stretch residual was
//! already within 1e-3, 59.8 s and 2.93e-2: the stale Jacobians (directors the contacts
//! turned), not the residual's size, stretch the thread. The
//! elimination's Schur complements and forward sweep skip the coupling blocks' exact zeros
//! (`direct`: the same sums in the same order, to the bit): `bench thread` with the builds
//! before and after alternated twice on a 2-core Intel Xeon, the knot row 46.4 and 46.6 s
//! against 44.7 and 44.5 s, 1000 segments 0.423 and 0.429 against 0.406 and 0.403 ms a
//! frame, every other figure of the tables the same. The blocks factorised as L·D·Lᵀ
//! instead of L·Lᵀ (no square root on the elimination's chain of pivots, where `perf`
//! put 17 % of the knot row): on an AMD EPYC, the builds alternated in one sitting, the
//! knot row 54.8 against 49.3 s of one core (real-time factor 0.31 → 0.35), the first 4 s
//! 9.1 and 9.2 s against 8.0 and 8.0 s, 1000 segments 0.514 against 0.449 ms a frame; the
//! knot tied in both. Not taken: the rounding it changes moved `config/suture.toml`'s
//! throw (`tests/suture.rs`), whose pull then closed the wound from 0.98 to 0.72 mm
//! instead of to 0.53 mm. Fewer substeps (`bench thread --knot-scene` on copies of the
//! file): at 75 a frame the largest strain is 2.58e-2, at 50 2.29e-1 with four frames held
//! back, at 32 2.73 (the knot still tied); 2 iterations instead of 3 cost as much (the
//! residual asks for the third) and strain 4.38e-2. Real time needs fewer substeps than 100
//! a frame, which `config/knot.toml` explains.
//!
//! Not yet: a contact force report back to the tools. A GPU rod would need a parallel
//! block-tridiagonal solve (cyclic reduction, or one thread per rod); at a few hundred segments
//! the launch latency would exceed the CPU's work, so it pays only for many threads at once.

pub mod constraints;
pub mod crossing;
pub mod direct;
pub mod environment;
pub mod knot;
pub mod material;
pub mod self_contact;
pub mod solver;
pub mod state;

pub use environment::{RodAttachment, RodCollider, RodEnvironment, RodFrameReport};
pub use material::ThreadMaterial;
pub use solver::RodSolver;
pub use state::{Binding, Rod};
