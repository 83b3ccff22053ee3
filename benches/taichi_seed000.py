"""Taichi's CPU MLS-MPM on the seed-000 scene size, for `bench throughput`'s peer row.

The same step as this crate's MLS-MPM (seed 000 eqs. 1-10; Taichi's own mpm3d example with
a Neo-Hookean Kirchhoff stress): quadratic B-splines, APIC with the MLS force in P2G, grid
velocity with gravity, a moving sphere with Coulomb friction (mu = 2), a bonded table and
slip walls, G2P with F updated by (I + dt C). Scene: a 24 x 25 x 5-cell block at 8
particles a cell (24,000 particles), dx = 0.1/64 m on a dense 64^3 grid, E = 5 kPa,
nu = 0.4, 1000 kg/m^3, dt at CFL 0.9 of the P-wave speed. Prints particle-substeps per
second after a warm-up (the kernels' compilation excluded).

    python3 -m venv /tmp/ti && /tmp/ti/bin/pip install taichi==1.7.4
    /tmp/ti/bin/python benches/taichi_seed000.py --threads 2
"""

import argparse
import math
import time

import taichi as ti

parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
parser.add_argument("--threads", type=int, default=0, help="CPU threads (0: all cores)")
parser.add_argument("--substeps", type=int, default=2000, help="timed substeps")
args = parser.parse_args()
init = {"arch": ti.cpu, "default_fp": ti.f32}
if args.threads > 0:
    init["cpu_max_num_threads"] = args.threads
ti.init(**init)

n_grid = 64
dx = 0.1 / n_grid
inv_dx = 1.0 / dx
block_cells = (24, 25, 5)
table_nodes = 4
n_particles = 8 * block_cells[0] * block_cells[1] * block_cells[2]
E, nu, rho = 5000.0, 0.4, 1000.0
mu0, lam0 = E / (2 * (1 + nu)), E * nu / ((1 + nu) * (1 - 2 * nu))
p_vol = (0.5 * dx) ** 3
p_mass = rho * p_vol
dt = 0.9 * dx / math.sqrt((lam0 + 2 * mu0) / rho)
gravity = -9.81
friction = 2.0
sphere_radius = 0.005
walls = 3

x = ti.Vector.field(3, float, n_particles)
v = ti.Vector.field(3, float, n_particles)
C = ti.Matrix.field(3, 3, float, n_particles)
F = ti.Matrix.field(3, 3, float, n_particles)
grid_v = ti.Vector.field(3, float, (n_grid,) * 3)
grid_m = ti.field(float, (n_grid,) * 3)
sphere = ti.Vector.field(3, float, ())
sphere_v = ti.Vector.field(3, float, ())


@ti.kernel
def init_block():
    for p in x:
        cell = p // 8
        k = p % 8
        i = cell % block_cells[0]
        j = (cell // block_cells[0]) % block_cells[1]
        l = cell // (block_cells[0] * block_cells[1])
        offset = ti.Vector([k % 2, (k // 2) % 2, k // 4]) * 0.5 + 0.25
        origin = ti.Vector([20.0, 20.0, float(table_nodes)])
        x[p] = (origin + ti.Vector([i, j, l]) + offset) * dx
        v[p] = ti.Vector.zero(float, 3)
        F[p] = ti.Matrix.identity(float, 3)
        C[p] = ti.Matrix.zero(float, 3, 3)


@ti.kernel
def substep():
    for I in ti.grouped(grid_m):
        grid_v[I] = ti.Vector.zero(float, 3)
        grid_m[I] = 0.0
    for p in x:
        Xp = x[p] * inv_dx
        base = int(Xp - 0.5)
        fx = Xp - base
        w = [0.5 * (1.5 - fx) ** 2, 0.75 - (fx - 1) ** 2, 0.5 * (fx - 0.5) ** 2]
        J = F[p].determinant()
        # Neo-Hookean Kirchhoff stress: mu (F F^T - I) + lambda ln(J) I.
        tau = mu0 * (F[p] @ F[p].transpose() - ti.Matrix.identity(float, 3)) + lam0 * ti.log(
            J
        ) * ti.Matrix.identity(float, 3)
        stress = -dt * p_vol * 4 * inv_dx * inv_dx * tau
        affine = stress + p_mass * C[p]
        for offset in ti.static(ti.grouped(ti.ndrange(3, 3, 3))):
            dpos = (offset - fx) * dx
            weight = w[offset[0]][0] * w[offset[1]][1] * w[offset[2]][2]
            grid_v[base + offset] += weight * (p_mass * v[p] + affine @ dpos)
            grid_m[base + offset] += weight * p_mass
    for I in ti.grouped(grid_m):
        if grid_m[I] > 0:
            vel = grid_v[I] / grid_m[I]
            vel.z += dt * gravity
            pos = I * dx
            d = pos - sphere[None]
            dist = d.norm()
            if dist < sphere_radius:
                n = d / ti.max(dist, 1e-12)
                rel = vel - sphere_v[None]
                vn = rel.dot(n)
                if vn < 0:
                    vt = rel - vn * n
                    vt_norm = vt.norm()
                    scale = ti.max(0.0, 1.0 + friction * vn / ti.max(vt_norm, 1e-12))
                    vel = sphere_v[None] + vt * scale
            if I.z < table_nodes:
                vel = ti.Vector.zero(float, 3)
            for a in ti.static(range(3)):
                if I[a] < walls and vel[a] < 0:
                    vel[a] = 0.0
                if I[a] >= n_grid - walls and vel[a] > 0:
                    vel[a] = 0.0
            grid_v[I] = vel
    for p in x:
        Xp = x[p] * inv_dx
        base = int(Xp - 0.5)
        fx = Xp - base
        w = [0.5 * (1.5 - fx) ** 2, 0.75 - (fx - 1) ** 2, 0.5 * (fx - 0.5) ** 2]
        new_v = ti.Vector.zero(float, 3)
        new_C = ti.Matrix.zero(float, 3, 3)
        for offset in ti.static(ti.grouped(ti.ndrange(3, 3, 3))):
            dpos = offset - fx
            weight = w[offset[0]][0] * w[offset[1]][1] * w[offset[2]][2]
            g_v = grid_v[base + offset]
            new_v += weight * g_v
            new_C += 4 * inv_dx * weight * g_v.outer_product(dpos)
        v[p] = new_v
        C[p] = new_C
        x[p] += dt * new_v
        F[p] = (ti.Matrix.identity(float, 3) + dt * new_C) @ F[p]


def run(substeps):
    for _ in range(substeps):
        sphere[None] += dt * sphere_v[None]
        substep()
    ti.sync()


init_block()
top = (table_nodes + block_cells[2]) * dx
sphere[None] = [(20 + 12) * dx, (20 + 12.5) * dx, top + sphere_radius - 0.001]
sphere_v[None] = [0.0, 0.0, 0.01]
run(50)
start = time.perf_counter()
run(args.substeps)
wall = time.perf_counter() - start
positions = x.to_numpy()
if not (positions == positions).all() or abs(positions).max() > 0.1:
    raise SystemExit("the simulation left the domain or went non-finite: no figure")
rate = n_particles * args.substeps / wall
version = ".".join(str(part) for part in ti.__version__)
print(
    f"| taichi {version} cpu | {args.threads or 'all'} threads | {n_particles} particles "
    f"| {n_grid}^3 grid | {args.substeps} substeps | {wall:.3f} s | {rate / 1e6:.2f} M particle-substeps/s |"
)
