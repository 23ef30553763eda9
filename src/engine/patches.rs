//! Patches: the mesh subdivided into the elements radiosity solves for (constant exitance per
//! patch). "Model only what the scene requires": each input triangle is split by recursive
//! longest-edge bisection until its longest edge is below a target that depends on where it is:
//!
//! `target = clamp(detail_ratio × d / f, min_patch_m, patch_size_m)`
//!
//! for the sensor that needs it most, where `d` is the distance from the sensor to the triangle
//! and `f = √(cos θ_s cos θ_p)` how squarely sensor and triangle face each other (0 when the
//! sensor cannot see it: the desk top a sensor lies on needs no refinement). A patch seen from a
//! sensor then subtends at most about `detail_ratio` radians of projected angle, while surfaces
//! far from every sensor, or out of its view, stay coarse. The engine adds a second criterion
//! through `split_more`: where direct light changes fast (a surface close to a luminaire that
//! shines on it), patches are at most `light_ratio` times their distance to it. Black surfaces
//! (ρ = 0, e.g. luminaire openings) reflect nothing a sensor could gather, so only the base
//! size and the light criterion apply to them. An extra predicate (the engine's light-gradient test) can split further. Black
//! surfaces (ρ = 0, e.g. luminaire openings) never reflect, so they stay one patch each.

use glam::DVec3;

use crate::scene::Mesh;

/// How finely to subdivide.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PatchSettings {
    /// Largest patch edge anywhere, m.
    pub patch_size_m: f64,
    /// Largest patch edge over its distance to the nearest point of interest (radians, about);
    /// 0 turns the refinement off (uniform patches).
    pub detail_ratio: f64,
    /// Smallest patch edge the refinement goes to, m.
    pub min_patch_m: f64,
    /// Largest patch edge over its distance to a luminaire that lights it (where direct light
    /// changes fast); 0 turns this refinement off.
    pub light_ratio: f64,
}

impl Default for PatchSettings {
    fn default() -> Self {
        Self {
            patch_size_m: 1.0,
            detail_ratio: 0.5,
            min_patch_m: 0.0625,
            light_ratio: 1.0,
        }
    }
}

/// Most patches a model is built with: a 4 MiB flash image holds some 20 000, and commissioning
/// 200 000 takes hours on a node. [`subdivide`] stops past it (the engine then refuses).
pub const MAX_PATCHES: usize = 200_000;

/// At least this many patches come from `mesh` at a largest patch edge of `size_m` (a triangle
/// whose longest edge is at most `L` has at most `√3/4 L²` of area), before any refinement.
pub fn fewest_patches(mesh: &Mesh, size_m: f64) -> f64 {
    let most_area = 3f64.sqrt() / 4.0 * size_m * size_m;
    mesh.triangles
        .iter()
        .filter(|t| !mesh.is_degenerate(t))
        .map(|t| (mesh.area_m2(t) / most_area).ceil().max(1.0))
        .sum()
}

/// The patches of a scene.
#[derive(Debug, Clone, Default)]
pub struct Patches {
    /// Corners, m, counter-clockwise seen from the front.
    pub corners_m: Vec<[DVec3; 3]>,
    /// Unit normals.
    pub normal: Vec<DVec3>,
    /// Areas, m².
    pub area_m2: Vec<f64>,
    /// Diffuse reflectances.
    pub rho: Vec<f64>,
    /// Group label index (into the mesh's groups).
    pub group: Vec<u32>,
    /// The input triangle each patch came from.
    pub source_triangle: Vec<u32>,
}

impl Patches {
    /// Number of patches.
    pub fn len(&self) -> usize {
        self.area_m2.len()
    }

    /// True when there are none.
    pub fn is_empty(&self) -> bool {
        self.area_m2.is_empty()
    }

    /// Centroid of a patch, m.
    pub fn centroid_m(&self, i: usize) -> DVec3 {
        let [a, b, c] = self.corners_m[i];
        (a + b + c) / 3.0
    }

    /// A point of the patch from unit-square coordinates (u, v) ∈ [0, 1)², uniform in area.
    pub fn point_m(&self, i: usize, u: f64, v: f64) -> DVec3 {
        let [a, b, c] = self.corners_m[i];
        let su = u.sqrt();
        a * (1.0 - su) + b * (su * (1.0 - v)) + c * (su * v)
    }

    fn push(&mut self, corners: [DVec3; 3], rho: f64, group: u32, source: u32) {
        let cross = (corners[1] - corners[0]).cross(corners[2] - corners[0]);
        self.corners_m.push(corners);
        self.normal.push(cross.normalize_or_zero());
        self.area_m2.push(0.5 * cross.length());
        self.rho.push(rho);
        self.group.push(group);
        self.source_triangle.push(source);
    }
}

fn longest_edge(t: &[DVec3; 3]) -> (usize, f64) {
    let mut best = (0, 0.0);
    for k in 0..3 {
        let l = (t[(k + 1) % 3] - t[k]).length();
        if l > best.1 {
            best = (k, l);
        }
    }
    best
}

/// A point of interest: a sensor's position and the unit normal of its receiving surface.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Viewpoint {
    /// Position, m.
    pub position_m: DVec3,
    /// Unit normal.
    pub normal: DVec3,
}

/// Subdivides `mesh` into patches. `interest` are the points of interest (the sensors);
/// `split_more` may ask for more splitting of a triangle (it is only asked while the triangle
/// is above `min_patch_m`).
pub fn subdivide(
    mesh: &Mesh,
    settings: &PatchSettings,
    interest: &[Viewpoint],
    split_more: &mut dyn FnMut(&[DVec3; 3]) -> bool,
) -> Patches {
    let size = settings.patch_size_m.max(1e-9);
    let min = settings.min_patch_m.clamp(1e-9, size);
    let target = |t: &[DVec3; 3]| -> f64 {
        if settings.detail_ratio <= 0.0 {
            return size;
        }
        let c = (t[0] + t[1] + t[2]) / 3.0;
        let n_t = (t[1] - t[0]).cross(t[2] - t[0]).normalize_or_zero();
        let radius = t.iter().map(|p| (*p - c).length()).fold(0.0, f64::max);
        let mut best = size;
        for s in interest {
            // how squarely the sensor and the triangle face each other, at its corners and centre
            let facing = [t[0], t[1], t[2], c]
                .iter()
                .map(|p| {
                    let v = *p - s.position_m;
                    let d = v.length();
                    if d <= 0.0 {
                        return 1.0;
                    }
                    let cos_s = s.normal.dot(v) / d;
                    let cos_p = -n_t.dot(v) / d;
                    if cos_s > 0.0 && cos_p > 0.0 {
                        (cos_s * cos_p).sqrt()
                    } else {
                        0.0
                    }
                })
                .fold(0.0, f64::max);
            if facing <= 0.0 {
                continue;
            }
            let d = ((s.position_m - c).length() - radius).max(0.0);
            best = best.min(settings.detail_ratio * d / facing);
        }
        best.clamp(min, size)
    };
    let mut out = Patches::default();
    let mut stack: Vec<[DVec3; 3]> = Vec::new();
    for (ti, t) in mesh.triangles.iter().enumerate() {
        // no area, no light: a degenerate triangle has no normal to cast rays along
        if mesh.is_degenerate(t) {
            continue;
        }
        let rho = mesh.materials[t.material as usize].rho.get();
        let corners = mesh.corners_m(t);
        stack.push(corners);
        while let Some(tri) = stack.pop() {
            let (k, len) = longest_edge(&tri);
            // a black patch sends nothing to a sensor: only its own illuminance needs resolving
            let view_target = if rho > 0.0 { target(&tri) } else { size };
            let split = len > view_target || (len > min && split_more(&tri));
            // never split below the resolution of the coordinates (slivers of slivers)
            let split = split && len > 1e-9 * (1.0 + tri[0].abs().max_element());
            if !split {
                out.push(tri, rho, t.group, ti as u32);
                if out.len() > MAX_PATCHES {
                    return out;
                }
                continue;
            }
            let (a, b, c) = (tri[k], tri[(k + 1) % 3], tri[(k + 2) % 3]);
            let m = (a + b) * 0.5;
            // both halves keep the parent's orientation
            stack.push([a, m, c]);
            stack.push([m, b, c]);
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::{Material, Triangle};
    use crate::units::Reflectance;

    fn square(size: f64, rho: f64) -> Mesh {
        let p = DVec3::new;
        Mesh {
            positions_m: vec![
                p(0., 0., 0.),
                p(size, 0., 0.),
                p(size, size, 0.),
                p(0., size, 0.),
            ],
            triangles: vec![
                Triangle {
                    v: [0, 1, 2],
                    group: 0,
                    material: 0,
                },
                Triangle {
                    v: [0, 2, 3],
                    group: 0,
                    material: 0,
                },
            ],
            groups: vec!["floor".into()],
            materials: vec![Material {
                name: "m".into(),
                rho: Reflectance::new(rho).unwrap(),
            }],
        }
    }

    // issue 34: the work estimate's lower bound holds for any triangle and patch size (the
    // engine refuses a setting on it before subdividing)
    proptest::proptest! {
        #[test]
        fn no_subdivision_makes_fewer_patches_than_the_estimate(
            corners in proptest::collection::vec(-10.0f64..10.0, 9),
            size_m in 0.05f64..4.0,
        ) {
            let p = |k: usize| DVec3::new(corners[3 * k], corners[3 * k + 1], corners[3 * k + 2]);
            let mut m = square(1.0, 0.5);
            m.positions_m = vec![p(0), p(1), p(2)];
            m.triangles.truncate(1);
            let settings = PatchSettings {
                patch_size_m: size_m,
                detail_ratio: 0.0,
                min_patch_m: size_m,
                light_ratio: 0.0,
            };
            let made = subdivide(&m, &settings, &[], &mut |_| false).len();
            let fewest = fewest_patches(&m, size_m);
            proptest::prop_assert!(made as f64 >= fewest, "{made} patches, estimate {fewest}");
        }
    }

    #[test]
    fn uniform_subdivision_keeps_area_and_orientation() {
        let m = square(4.0, 0.5);
        let s = PatchSettings {
            patch_size_m: 0.5,
            detail_ratio: 0.0,
            min_patch_m: 0.1,
            light_ratio: 0.0,
        };
        let p = subdivide(&m, &s, &[], &mut |_| false);
        let area: f64 = p.area_m2.iter().sum();
        assert!((area - 16.0).abs() < 1e-9);
        assert!(p.normal.iter().all(|n| (*n - DVec3::Z).length() < 1e-12));
        assert!(p.corners_m.iter().all(|t| longest_edge(t).1 <= 0.5 + 1e-12));
        // right isosceles halves: 16 m² / (0.5 × 0.354²) ≈ 256 patches
        assert_eq!(p.len(), 256);
    }

    #[test]
    fn refinement_is_local_to_points_of_interest() {
        let m = square(8.0, 0.5);
        let s = PatchSettings {
            patch_size_m: 1.0,
            detail_ratio: 0.5,
            min_patch_m: 0.1,
            light_ratio: 0.0,
        };
        let sensor = DVec3::new(1.0, 1.0, 0.5);
        let view = Viewpoint {
            position_m: sensor,
            normal: DVec3::NEG_Z,
        };
        let p = subdivide(&m, &s, &[view], &mut |_| false);
        let foot = DVec3::new(1.0, 1.0, 0.0);
        let near = (0..p.len())
            .filter(|&i| (p.centroid_m(i) - foot).length() < 0.3)
            .map(|i| longest_edge(&p.corners_m[i]).1)
            .fold(0.0, f64::max);
        let far = (0..p.len())
            .filter(|&i| (p.centroid_m(i) - sensor).length() > 6.0)
            .map(|i| longest_edge(&p.corners_m[i]).1)
            .fold(f64::INFINITY, f64::min);
        assert!(near < 0.3 && far > 0.7, "near {near}, far {far}");
        let area: f64 = p.area_m2.iter().sum();
        assert!((area - 64.0).abs() < 1e-9);
        // a sensor that faces away (or lies in the plane) refines nothing
        let up = Viewpoint {
            position_m: sensor,
            normal: DVec3::Z,
        };
        let q = subdivide(&m, &s, &[up], &mut |_| false);
        let uniform = subdivide(
            &m,
            &PatchSettings {
                detail_ratio: 0.0,
                ..s
            },
            &[],
            &mut |_| false,
        );
        assert_eq!(q.len(), uniform.len());
    }

    #[test]
    fn black_surfaces_ignore_sensors() {
        let m = square(4.0, 0.0);
        let s = PatchSettings {
            patch_size_m: 8.0,
            detail_ratio: 0.5,
            min_patch_m: 0.1,
            light_ratio: 0.0,
        };
        let view = Viewpoint {
            position_m: DVec3::new(1.0, 1.0, 0.5),
            normal: DVec3::NEG_Z,
        };
        assert_eq!(subdivide(&m, &s, &[view], &mut |_| false).len(), 2);
        assert!(subdivide(&m, &s, &[view], &mut |_| true).len() > 2);
    }

    #[test]
    fn area_sampling_stays_inside() {
        let m = square(1.0, 0.5);
        let p = subdivide(&m, &PatchSettings::default(), &[], &mut |_| false);
        assert!(!p.is_empty());
        for i in 0..p.len() {
            let [a, b, c] = p.corners_m[i];
            for (u, v) in [(0.0, 0.0), (0.999, 0.999), (0.5, 0.5), (0.25, 0.9)] {
                let q = p.point_m(i, u, v);
                // barycentric check
                let n = (b - a).cross(c - a);
                let w0 = (b - q).cross(c - q).dot(n) / n.length_squared();
                let w1 = (c - q).cross(a - q).dot(n) / n.length_squared();
                assert!(w0 >= -1e-12 && w1 >= -1e-12 && w0 + w1 <= 1.0 + 1e-12);
            }
        }
    }
}
