//! Hemisphere ray sets for form factors and sensor gathering: **Isocell** (Masset et al. 2011,
//! physics.md §3.1) and plain cosine-weighted Monte Carlo as the baseline.
//!
//! Both produce cosine-distributed directions (pdf `cos θ / π`), so a patch-to-patch form factor
//! is simply hits / N and a sensor reading weights each ray by `s(θ) / cos θ`.
//!
//! Isocell partitions the unit disc into `N = N0 n²` cells of equal area (`N0 = 3` central
//! cells, `n = ⌈√(N_target / N0)⌉` rings, ring `i` holding `N0 (2i − 1)` cells) and takes one
//! point per cell; projecting the disc point up to the hemisphere (Nusselt analogue) makes the
//! equal-area cells equal-projected-solid-angle cells. "1000 rays" becomes 1083. The point of a
//! cell sits at the radius where cos θ equals its ring's mean (not the ring's area midpoint,
//! which overestimates integrands that fade toward grazing: see `ring_radius`) and at its
//! angular midpoint; each ring's angular phase
//! is fixed (golden-angle steps), so the set is deterministic.

use glam::DVec3;

use crate::rng::SplitMix64;

/// Which ray set.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum RaySetKind {
    /// Isocell (stratified, deterministic).
    Isocell,
    /// Cosine-weighted Monte Carlo with a seed.
    MonteCarlo {
        /// Seed of the generator.
        seed: u64,
    },
}

/// Directions in a local frame (z = surface normal), cosine distributed, unit length.
#[derive(Debug, Clone)]
pub struct RaySet {
    /// Unit directions, local frame, z ≥ 0.
    pub dirs: Vec<DVec3>,
}

/// Golden angle, radians: ring phases that never align.
const GOLDEN_ANGLE_RAD: f64 = 2.399_963_229_728_653;

/// Number of rays Isocell uses for a target count (`N0 = 3`): 1000 → 1083.
pub fn isocell_count(target: usize) -> usize {
    let n = isocell_rings(target);
    3 * n * n
}

fn isocell_rings(target: usize) -> usize {
    ((target.max(1) as f64 / 3.0).sqrt().ceil() as usize).max(1)
}

impl RaySet {
    /// A ray set of (about) `target` rays.
    pub fn new(kind: RaySetKind, target: usize) -> Self {
        match kind {
            RaySetKind::Isocell => Self::isocell(target),
            RaySetKind::MonteCarlo { seed } => Self::monte_carlo(target.max(1), seed),
        }
    }

    /// The Isocell set for `target` rays (`N0 = 3`).
    pub fn isocell(target: usize) -> Self {
        let n0 = 3usize;
        let n = isocell_rings(target);
        let mut dirs = Vec::with_capacity(n0 * n * n);
        for i in 1..=n {
            let cells = n0 * (2 * i - 1);
            let fi = i as f64;
            let r = ring_radius(i, n);
            let phase = GOLDEN_ANGLE_RAD * fi;
            let dtheta = std::f64::consts::TAU / cells as f64;
            for k in 0..cells {
                let theta = phase + (k as f64 + 0.5) * dtheta;
                dirs.push(disc_to_hemisphere(r * theta.cos(), r * theta.sin()));
            }
        }
        Self { dirs }
    }

    /// `n` cosine-weighted random directions (uniform points on the disc, projected up).
    pub fn monte_carlo(n: usize, seed: u64) -> Self {
        let mut rng = SplitMix64::new(seed);
        let dirs = (0..n)
            .map(|_| {
                let r = rng.next_f64().sqrt();
                let phi = std::f64::consts::TAU * rng.next_f64();
                disc_to_hemisphere(r * phi.cos(), r * phi.sin())
            })
            .collect();
        Self { dirs }
    }

    /// Number of rays.
    pub fn len(&self) -> usize {
        self.dirs.len()
    }

    /// True when empty.
    pub fn is_empty(&self) -> bool {
        self.dirs.is_empty()
    }
}

/// The radius of ring `i`'s points (of `n` rings, ring `i` spanning r² ∈ [(i−1)², i²] / n²):
/// where `cos θ = √(1 − r²)` equals its mean over the ring (in area, the measure the cells
/// share). The ring's area midpoint makes the set exact for integrands linear in r² = sin² θ
/// but overestimates any integrand that fades like cos θ toward grazing (concave in r² near
/// the rim); this point is exact for integrands linear in cos θ, and differs from the area
/// midpoint only to second order away from the rim.
fn ring_radius(i: usize, n: usize) -> f64 {
    let nn = (n * n) as f64;
    let (a, b) = (((i - 1) * (i - 1)) as f64 / nn, (i * i) as f64 / nn);
    // mean of √(1 − s) over s ∈ [a, b]
    let mean_cos = 2.0 / 3.0 * ((1.0 - a).powf(1.5) - (1.0 - b).max(0.0).powf(1.5)) / (b - a);
    (1.0 - mean_cos * mean_cos).max(0.0).sqrt()
}

/// A point of the unit disc lifted to the hemisphere above it (Nusselt analogue).
fn disc_to_hemisphere(x: f64, y: f64) -> DVec3 {
    let z = (1.0 - x * x - y * y).max(0.0).sqrt();
    DVec3::new(x, y, z)
}

/// An orthonormal frame (tangent, bitangent, normal) for a unit normal, turned about the normal
/// by `azimuth_rad` (per-patch decorrelation of a fixed ray set).
pub fn frame(normal: DVec3, azimuth_rad: f64) -> [DVec3; 3] {
    let helper = if normal.x.abs() < 0.9 {
        DVec3::X
    } else {
        DVec3::Y
    };
    let t0 = normal.cross(helper).normalize();
    let b0 = normal.cross(t0);
    let (s, c) = azimuth_rad.sin_cos();
    let t = t0 * c + b0 * s;
    let b = normal.cross(t);
    [t, b, normal]
}

/// A local direction in a frame from [`frame`].
pub fn to_world(f: &[DVec3; 3], d: DVec3) -> DVec3 {
    f[0] * d.x + f[1] * d.y + f[2] * d.z
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn isocell_counts() {
        assert_eq!(isocell_count(1000), 1083);
        assert_eq!(RaySet::isocell(1000).len(), 1083);
        assert_eq!(isocell_count(100), 108);
        assert_eq!(isocell_count(10000), 10092);
        assert_eq!(isocell_count(3), 3);
    }

    #[test]
    fn isocell_is_cosine_distributed() {
        // E[cos θ] under pdf cos θ/π over the hemisphere is 2/3; E[cos² θ] = 1/2.
        let s = RaySet::isocell(1083);
        let n = s.len() as f64;
        let m1: f64 = s.dirs.iter().map(|d| d.z).sum::<f64>() / n;
        let m2: f64 = s.dirs.iter().map(|d| d.z * d.z).sum::<f64>() / n;
        // one point per equal-area cell at the radius where cos θ is the ring's mean: E[cos θ]
        // is exact, E[cos² θ] carries the cells' discretisation (second order)
        assert!((m1 - 2.0 / 3.0).abs() < 1e-12, "{m1}");
        assert!((m2 - 0.5).abs() < 1e-3, "{m2}");
        assert!(
            s.dirs
                .iter()
                .all(|d| (d.length() - 1.0).abs() < 1e-12 && d.z >= 0.0)
        );
        // equal-area cells: the mean of x and y vanishes
        let mx: f64 = s.dirs.iter().map(|d| d.x).sum::<f64>() / n;
        assert!(mx.abs() < 1e-3);
    }

    #[test]
    fn frames_are_orthonormal() {
        for n in [
            DVec3::Z,
            DVec3::NEG_X,
            DVec3::new(0.3, -0.5, 0.8).normalize(),
        ] {
            let f = frame(n, 1.234);
            assert!((f[0].dot(f[1])).abs() < 1e-12);
            assert!((f[0].cross(f[1]) - n).length() < 1e-12);
        }
    }
}
