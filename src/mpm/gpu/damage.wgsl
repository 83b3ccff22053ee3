// Tearing (damage.rs): the volumetric–deviatoric split of the stress, the crack-band
// softening law and the degraded stress, line for line the CPU's math. A particle's damage
// d ∈ [0, 1] lives in its position's w (`Particle.x.w`, 0 for a scene without toughness);
// a material's damage onset energy Y₀ = G_c/(2·dx) (J/m³) in `Material.onset`, 0 when it
// cannot tear: P2G then takes the plain stress and never reads d.

// ψ⁺'s stress and ψ⁻'s (Kirchhoff, Pa) and ψ⁺ (J/m³) (damage.rs `Split`).
struct Split {
    tension: mat3x3<f32>,
    compression: mat3x3<f32>,
    tensile_energy: f32,
}

fn damage_split(mat: Material, f: mat3x3<f32>) -> Split {
    let id = mat3x3<f32>(vec3<f32>(1.0, 0.0, 0.0), vec3<f32>(0.0, 1.0, 0.0), vec3<f32>(0.0, 0.0, 1.0));
    var shear: mat3x3<f32>;
    var shear_energy: f32;
    var volume_stress: f32;
    var volume_energy: f32;
    var dilated: bool;
    if (mat.model == NEO_HOOKEAN) {
        // Neo-Hookean: ψ_μ = μ/2 (tr b − 3) − μ ln J, ψ_λ = λ/2 (ln J)².
        let j = max(determinant(f), J_MIN);
        let ln_j = log(j);
        let b = f * transpose(f);
        shear = (b - id) * mat.mu;
        shear_energy = 0.5 * mat.mu * (b[0].x + b[1].y + b[2].z - 3.0) - mat.mu * ln_j;
        volume_stress = mat.lambda * ln_j;
        volume_energy = 0.5 * mat.lambda * ln_j * ln_j;
        dilated = j > 1.0;
    } else {
        // Fixed-corotated: ψ_μ = μ‖F − R‖², ψ_λ = λ/2 (J − 1)².
        let j = determinant(f);
        let r = rotation_of(f);
        let fr = f - r;
        shear = (fr * transpose(f)) * (2.0 * mat.mu);
        shear_energy = mat.mu * (dot(fr[0], fr[0]) + dot(fr[1], fr[1]) + dot(fr[2], fr[2]));
        volume_stress = mat.lambda * (j - 1.0) * j;
        volume_energy = 0.5 * mat.lambda * (j - 1.0) * (j - 1.0);
        dilated = j > 1.0;
    }
    let volume = id * volume_stress;
    let zero = mat3x3<f32>(vec3<f32>(0.0), vec3<f32>(0.0), vec3<f32>(0.0));
    if (dilated) {
        return Split(shear + volume, zero, shear_energy + volume_energy);
    }
    return Split(shear, volume, shear_energy);
}

// d(Y) = 1 − exp(−(Y − Y₀)/Y₀) above the onset Y₀ (damage.rs `softening`).
fn damage_softening(tensile_energy: f32, onset: f32) -> f32 {
    if (tensile_energy <= onset) {
        return 0.0;
    }
    return 1.0 - exp(-(tensile_energy - onset) / onset);
}

// The degraded stress (1 − d) τ⁺ + τ⁻ with the particle's damage advanced (never down) and,
// once torn through (d ≥ TORN), its deformation reduced to its volume compression
// F ← min(J, 1)^⅓·I (damage.rs `degraded_stress`).
struct Degraded {
    tau: mat3x3<f32>,
    d: f32,
    f: mat3x3<f32>,
}

fn degraded_stress(mat: Material, f: mat3x3<f32>, d: f32) -> Degraded {
    if (d >= TORN) {
        let j = clamp(determinant(f), J_MIN, 1.0);
        let s = pow(j, 1.0 / 3.0);
        let kept = mat3x3<f32>(vec3<f32>(s, 0.0, 0.0), vec3<f32>(0.0, s, 0.0), vec3<f32>(0.0, 0.0, s));
        return Degraded(damage_split(mat, kept).compression, 1.0, kept);
    }
    let parts = damage_split(mat, f);
    let d_new = max(d, damage_softening(parts.tensile_energy, mat.onset));
    return Degraded(parts.tension * (1.0 - d_new) + parts.compression, d_new, f);
}
