//! What comes back from the device: the per-frame statistics words and the end-of-frame
//! extract (positions, deformation gradients while asked for), through two staging buffers
//! used in turn, and the blocking full download of the particles.

use super::grid_update::IMPULSE_WORDS;
use super::pack::{self, GpuParticle};
use crate::mpm::frame_plan::FrameStats;
use crate::mpm::guard::{GuardEvent, GuardKind};
use crate::mpm::stiffening::StiffeningBounds;
use crate::mpm::{Particles, Vec3, MAX_TOOLS};
use std::sync::mpsc;

/// Word indices of the per-frame statistics buffer (atomic u32 words; f32 stored as bits).
pub mod word {
    /// Substep + 1 of the first guard event, 0 when none.
    pub const GUARD: usize = 0;
    /// Lowest offending particle of that substep.
    pub const GUARD_PARTICLE: usize = 1;
    /// f32 bits (non-negative, so u32 order is f32 order).
    pub const MAX_SPEED: usize = 2;
    pub const CLAMPED: usize = 3;
    /// Substeps started.
    pub const SUBSTEPS: usize = 4;
    /// Blocks with tool contact in this substep.
    pub const CONTACT_BLOCKS: usize = 5;
    /// [`GUARD_NON_FINITE`] or [`GUARD_RUNAWAY`].
    pub const GUARD_KIND: usize = 6;
    pub const GUARD_SPEED: usize = 7;
    /// 3 words.
    pub const GUARD_POS: usize = 8;
    /// MAX_TOOLS × IMPULSE_WORDS (see `IMPULSE_WORDS`).
    pub const IMPULSE: usize = 16;
    /// Total Lagrangian MPM's stiffening bounds at the frame's end (f32 bits, positive):
    /// over the free particles, then over each gripper's (MAX_TOOLS words).
    pub const TL_BOUND: usize = IMPULSE + MAX_TOOLS * IMPULSE_WORDS;

    /// The values of the `GUARD_KIND` word: a particle's state went non-finite, or its speed
    /// passed the guard's.
    pub const GUARD_NON_FINITE: usize = 0;
    pub const GUARD_RUNAWAY: usize = 1;

    use super::{IMPULSE_WORDS, MAX_TOOLS};

    /// Names (without the `S_` the shaders prefix) and indices, for the shader prelude.
    pub const ALL: [(&str, usize); 11] = [
        ("GUARD", GUARD),
        ("GUARD_PARTICLE", GUARD_PARTICLE),
        ("MAX_SPEED", MAX_SPEED),
        ("CLAMPED", CLAMPED),
        ("SUBSTEPS", SUBSTEPS),
        ("CONTACT_BLOCKS", CONTACT_BLOCKS),
        ("GUARD_KIND", GUARD_KIND),
        ("GUARD_SPEED", GUARD_SPEED),
        ("GUARD_POS", GUARD_POS),
        ("IMPULSE", IMPULSE),
        ("TL_BOUND", TL_BOUND),
    ];
}

pub const STATS_WORDS: usize = word::TL_BOUND + 1 + MAX_TOOLS;
pub const STATS_BYTES: u64 = 1024;
/// Bytes per particle of the end-of-frame extract: a position and three F columns, vec4 each.
pub const EXTRACT_BYTES: usize = 64;
/// Bytes per particle the extract holds on top of [`EXTRACT_BYTES`] in a scene that cuts: its
/// crack, a vec4.
pub const CRACK_BYTES: usize = 16;

/// Bytes per particle of the extract of a solver that cuts or does not.
pub fn extract_bytes_per_particle(cutting: bool) -> usize {
    EXTRACT_BYTES + if cutting { CRACK_BYTES } else { 0 }
}

const _: () = assert!(word::GUARD_POS + 3 <= word::IMPULSE);
const _: () = assert!(STATS_WORDS * 4 <= STATS_BYTES as usize);

/// The statistics words a frame starts from.
pub fn stats_at_frame_start() -> [u32; STATS_WORDS] {
    let mut init = [0u32; STATS_WORDS];
    init[word::GUARD_PARTICLE] = u32::MAX;
    init
}

/// The readback ring: frame k reads back through `staging[k % 2]`.
pub struct Readback {
    staging: [wgpu::Buffer; 2],
    /// Whether the extract holds the cracks after the positions (a scene with a slicer).
    cutting: bool,
    frame: u64,
    /// The frame submitted and not collected yet.
    pending: Option<PendingFrame>,
    /// The stiffening bounds the last frame collected ended with (total Lagrangian MPM).
    pub stiffening: StiffeningBounds,
}

/// A submitted frame whose readback is under way.
struct PendingFrame {
    /// Staging buffer its statistics and extract are copied into.
    slot: usize,
    /// Bytes of the extract after the statistics.
    extract_bytes: usize,
    /// Answered once the staging buffer is mapped.
    mapped: mpsc::Receiver<Result<(), wgpu::BufferAsyncError>>,
}

/// Copies recorded into a frame's encoder, to be mapped once it is submitted.
pub struct RecordedCopies {
    slot: usize,
    extract_bytes: usize,
}

impl Readback {
    pub fn new(device: &wgpu::Device, n: usize, cutting: bool) -> Self {
        let staging = [0, 1].map(|i| {
            device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(if i == 0 { "readback 0" } else { "readback 1" }),
                size: STATS_BYTES + (n * extract_bytes_per_particle(cutting)).max(16) as u64,
                usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            })
        });
        Readback {
            staging,
            cutting,
            frame: 0,
            pending: None,
            stiffening: StiffeningBounds::default(),
        }
    }

    pub fn in_flight(&self) -> bool {
        self.pending.is_some()
    }

    /// Records the copies of the frame's statistics and extract (positions, the cracks in a
    /// scene that cuts, and the deformation gradients with `deformation`) into the next
    /// staging buffer.
    pub fn record(
        &mut self,
        encoder: &mut wgpu::CommandEncoder,
        stats: &wgpu::Buffer,
        extract: &wgpu::Buffer,
        n: usize,
        deformation: bool,
    ) -> RecordedCopies {
        let slot = (self.frame % 2) as usize;
        self.frame += 1;
        let staging = &self.staging[slot];
        encoder.copy_buffer_to_buffer(stats, 0, staging, 0, STATS_BYTES);
        let extract_bytes = if deformation {
            n * extract_bytes_per_particle(self.cutting)
        } else if self.cutting {
            n * (16 + CRACK_BYTES)
        } else {
            n * 16
        };
        if n > 0 {
            encoder.copy_buffer_to_buffer(extract, 0, staging, STATS_BYTES, extract_bytes as u64);
        }
        RecordedCopies {
            slot,
            extract_bytes,
        }
    }

    /// Asks for the staging buffer of a submitted frame to be mapped, without waiting.
    pub fn request(&mut self, copies: RecordedCopies) {
        let (tx, mapped) = mpsc::channel();
        self.staging[copies.slot].map_async(wgpu::MapMode::Read, .., move |r| {
            let _ = tx.send(r);
        });
        self.pending = Some(PendingFrame {
            slot: copies.slot,
            extract_bytes: copies.extract_bytes,
            mapped,
        });
    }

    /// Waits for the frame in flight, copies its positions (and deformation gradients
    /// when read back) into `host` and returns its statistics.
    ///
    /// # Panics
    /// When no frame was submitted, or the device is lost.
    pub fn collect(&mut self, device: &wgpu::Device, host: &mut Particles) -> FrameStats {
        let pending = self
            .pending
            .take()
            .expect("collect_frame called with no frame in flight");
        device
            .poll(wgpu::PollType::wait_indefinitely())
            .expect("GPU device lost while waiting for a frame");
        pending
            .mapped
            .recv()
            .expect("map callback ran")
            .expect("GPU readback mapping failed");
        let staging = &self.staging[pending.slot];
        let bytes = staging.get_mapped_range(..);
        let n = host.len();
        let extract_bytes = pending.extract_bytes;
        let words: &[u32] = bytemuck::cast_slice(&bytes[..STATS_BYTES as usize]);
        let extract: &[[f32; 4]] = bytemuck::cast_slice(
            &bytes[STATS_BYTES as usize..STATS_BYTES as usize + extract_bytes],
        );
        let (positions, rest) = extract.split_at(n.min(extract.len()));
        for (x, p) in host.x.iter_mut().zip(positions) {
            *x = Vec3::new(p[0], p[1], p[2]);
        }
        // A scene with toughness: each position's w is the particle's damage.
        for (d, p) in host.damage.iter_mut().zip(positions) {
            *d = p[3];
        }
        let gradients = if self.cutting {
            let (cracks, gradients) = rest.split_at(n.min(rest.len()));
            unpack_cracks(cracks, host);
            gradients
        } else {
            rest
        };
        for (f, cols) in host.f.iter_mut().zip(gradients.chunks_exact(3)) {
            *f = pack::unpack_mat3(cols);
        }
        let stats = parse_stats(words);
        let bound = |k: usize| f32::from_bits(words[word::TL_BOUND + k]);
        self.stiffening = StiffeningBounds {
            free: bound(0).max(1.0),
            held: std::array::from_fn(|t| bound(t + 1)),
        };
        drop(bytes);
        staging.unmap();
        stats
    }
}

/// Blocking download of every particle field of `particles` into `host`.
pub fn download_particles(
    device: &wgpu::Device,
    queue: &wgpu::Queue,
    particles: &wgpu::Buffer,
    host: &mut Particles,
) {
    let size = (host.len() * std::mem::size_of::<GpuParticle>()) as u64;
    let staging = device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("particle download"),
        size,
        usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    });
    let mut encoder =
        device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: None });
    encoder.copy_buffer_to_buffer(particles, 0, &staging, 0, size);
    queue.submit([encoder.finish()]);
    let bytes = map_read(device, &staging);
    pack::unpack_particles(bytemuck::cast_slice(&bytes), host);
    drop(bytes);
    staging.unmap();
}

/// The cracks (vec4 each) into `host.crack`, which then holds one per particle.
pub fn unpack_cracks(src: &[[f32; 4]], host: &mut Particles) {
    host.crack.resize(host.len(), Vec3::zeros());
    for (c, g) in host.crack.iter_mut().zip(src) {
        *c = Vec3::new(g[0], g[1], g[2]);
    }
}

/// Blocking download of the cracks in `cracks` into `host.crack`.
pub fn download_cracks(
    device: &wgpu::Device,
    queue: &wgpu::Queue,
    cracks: &wgpu::Buffer,
    host: &mut Particles,
) {
    let size = (host.len() * CRACK_BYTES) as u64;
    let staging = device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("crack download"),
        size,
        usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    });
    let mut encoder =
        device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: None });
    encoder.copy_buffer_to_buffer(cracks, 0, &staging, 0, size);
    queue.submit([encoder.finish()]);
    let bytes = map_read(device, &staging);
    unpack_cracks(bytemuck::cast_slice(&bytes), host);
    drop(bytes);
    staging.unmap();
}

/// Maps `buffer` for reading once the queue's work is done.
pub(super) fn map_read(device: &wgpu::Device, buffer: &wgpu::Buffer) -> wgpu::BufferView {
    let (tx, rx) = mpsc::channel();
    buffer.map_async(wgpu::MapMode::Read, .., move |r| {
        let _ = tx.send(r);
    });
    device
        .poll(wgpu::PollType::wait_indefinitely())
        .expect("GPU device lost while waiting for a frame");
    rx.recv()
        .expect("map callback ran")
        .expect("GPU readback mapping failed");
    buffer.get_mapped_range(..)
}

fn parse_stats(w: &[u32]) -> FrameStats {
    let mut out = FrameStats {
        max_speed: f32::from_bits(w[word::MAX_SPEED]),
        clamped_particles: w[word::CLAMPED],
        substeps_done: w[word::SUBSTEPS],
        ..Default::default()
    };
    for (t, imp) in out.tool_impulses.iter_mut().enumerate() {
        let f = |k: usize| f32::from_bits(w[word::IMPULSE + t * IMPULSE_WORDS + k]) as f64;
        imp.linear = nalgebra::Vector3::new(f(0), f(1), f(2));
        imp.angular = nalgebra::Vector3::new(f(3), f(4), f(5));
        imp.contact_nodes = f(6).round() as u32;
        imp.jaw_opening = f(7);
        imp.grip.required = nalgebra::Vector3::new(f(8), f(9), f(10));
        imp.grip.mass = f(11);
        imp.grip.mass_lever = f(12);
        imp.contact_mass = f(13);
        imp.contact_inertia = f(14);
    }
    if w[word::GUARD] != 0 {
        out.substeps_done = w[word::GUARD] - 1;
        let non_finite = w[word::GUARD_KIND] == word::GUARD_NON_FINITE as u32;
        out.guard = Some(GuardEvent {
            kind: if non_finite {
                GuardKind::NonFinite
            } else {
                GuardKind::Runaway
            },
            particle: w[word::GUARD_PARTICLE],
            position: Vec3::new(
                f32::from_bits(w[word::GUARD_POS]),
                f32::from_bits(w[word::GUARD_POS + 1]),
                f32::from_bits(w[word::GUARD_POS + 2]),
            ),
            speed: if non_finite {
                f32::NAN
            } else {
                f32::from_bits(w[word::GUARD_SPEED])
            },
        });
    }
    out
}
