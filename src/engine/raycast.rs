//! Ray casting against the patches through an obvhs CWBVH. This is the only module that sees
//! BVH primitive indices: it reorders the triangles once into BVH order and maps every hit back
//! to a patch id here, so the rest of the engine speaks patches.
//!
//! Precision: the BVH and the intersection run in f32, in the caster's own frame: centred on
//! the scene and scaled so its bounding-box diagonal is 10⁴ units. That keeps f32 resolution
//! uniform whatever the scene's size or position, and it neutralises obvhs' CWBVH node test,
//! which clamps the entry distance to an absolute 1e-4 units (in metres, a surface closer than
//! 0.1 mm along a ray, such as the wall next to a ray starting in a room's corner, would be
//! culled and the ray would leak out of a closed room). Every self-hit offset and shadow-ray
//! margin is relative to the scene's size ([`RayCaster::eps_m`] = 1e-5 × the diagonal), so a
//! scene in millimetres (converted to metres) or a 100 m hall behaves the same. Hits on a
//! triangle's back face are reported as such (the caller decides what they mean).

use std::time::Duration;

use glam::{DVec3, Vec3A};
use obvhs::BvhBuildParams;
use obvhs::cwbvh::CwBvh;
use obvhs::cwbvh::builder::build_cwbvh_from_tris;
use obvhs::ray::{Ray, RayHit};
use obvhs::triangle::Triangle;

use super::patches::Patches;

/// What a ray met first.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Hit {
    /// The front face of a patch at distance `t_m`.
    Front {
        /// Patch id.
        patch: u32,
        /// Distance, m.
        t_m: f64,
    },
    /// The back face of a patch.
    Back {
        /// Patch id.
        patch: u32,
        /// Distance, m.
        t_m: f64,
    },
    /// Nothing: the ray left the scene.
    Miss,
}

/// A triangle as its first corner and two edges (`v1 − v0`, `v2 − v0`), computed once: the
/// same f32 values Möller–Trumbore forms per test, so a hit's distance is bit for bit the same.
#[derive(Debug, Clone, Copy)]
struct EdgeTriangle {
    v0: Vec3A,
    e1: Vec3A,
    e2: Vec3A,
}

/// A BVH over the patches.
pub struct RayCaster {
    bvh: CwBvh,
    /// Triangles in BVH primitive order, as corner and edges.
    tris: Vec<EdgeTriangle>,
    /// The same triangles as obvhs stores them (for [`RayCaster::trace_obvhs`]).
    obvhs_tris: Vec<Triangle>,
    /// Unnormalised normals in BVH primitive order (for front/back).
    normals: Vec<Vec3A>,
    /// BVH primitive → patch id: the one mapping.
    patch_of: Vec<u32>,
    /// Self-hit offset and shadow-ray margin, m.
    pub eps_m: f64,
    /// World point at the caster frame's origin, m.
    centre_m: DVec3,
    /// Caster units per metre.
    scale: f64,
}

/// obvhs' build parameters. `very_slow_build` (spatial pre-splits, full reinsertion passes)
/// traces the form-factor rays of Ward's room at 0.25 m three times as fast as `fast_build` (0.60
/// against 1.85 CPU-µs per ray, one thread, 393 216 rays; docs/performance.md): rays starting on
/// the walls of a closed room cross far fewer nodes in the better tree. Every one of those hits
/// (patch, face and f32 distance) is the same.
pub const BVH_BUILD: BvhBuildParams = BvhBuildParams::very_slow_build();

/// The scene's bounding-box diagonal in caster units.
const FRAME_DIAGONAL: f64 = 1e4;

/// Möller–Trumbore with a small barycentric tolerance: a ray through the edge shared by two
/// triangles hits at least one of them (obvhs' own test treats −0.0 as outside, so a ray exactly
/// along a quad's diagonal could slip through both halves). Two-sided; returns the distance or
/// infinity.
#[inline(always)]
fn intersect(t: &EdgeTriangle, ray: &Ray) -> f32 {
    const EDGE_TOLERANCE: f32 = 1e-6;
    let (e1, e2) = (t.e1, t.e2);
    let p = ray.direction.cross(e2);
    let det = e1.dot(p);
    if det == 0.0 {
        return f32::INFINITY;
    }
    let inv = 1.0 / det;
    let s = ray.origin - t.v0;
    let u = s.dot(p) * inv;
    if !(-EDGE_TOLERANCE..=1.0 + EDGE_TOLERANCE).contains(&u) {
        return f32::INFINITY;
    }
    let q = s.cross(e1);
    let v = ray.direction.dot(q) * inv;
    if v < -EDGE_TOLERANCE || u + v > 1.0 + EDGE_TOLERANCE {
        return f32::INFINITY;
    }
    let dist = e2.dot(q) * inv;
    if dist >= ray.tmin && dist <= ray.tmax {
        dist
    } else {
        f32::INFINITY
    }
}

fn v3(p: DVec3) -> Vec3A {
    Vec3A::new(p.x as f32, p.y as f32, p.z as f32)
}

/// A ray direction for obvhs: in f32, with every zero component +0.0.
///
/// obvhs' CWBVH node test picks each axis's near and far slab by `direction < 0.0`, but takes
/// the slab distances from `safe_inverse(direction)`, whose sign for a zero component is the
/// sign *bit* (`signum(−0.0) = −1`). A −0.0 component (a wall normal `(1, 0, −0)` from a cross
/// product, or a tiny negative f64 that rounds to −0.0 in f32) so gets the near and far planes
/// swapped: every node whose slab contains the ray's origin on that axis is missed, and the ray
/// leaves the scene through a closed room (the same defect as tinybvh's, fixed there in PR 282).
/// +0.0 is consistent on both sides.
fn direction_f32(d: DVec3) -> Vec3A {
    let c = |x: f64| {
        let x = x as f32;
        if x == 0.0 { 0.0 } else { x }
    };
    Vec3A::new(c(d.x), c(d.y), c(d.z))
}

impl RayCaster {
    /// A world point in the caster frame.
    fn to_frame(&self, p: DVec3) -> Vec3A {
        v3((p - self.centre_m) * self.scale)
    }
}

impl RayCaster {
    /// Builds the BVH over all patches with obvhs' `very_slow_build` parameters (see
    /// [`BVH_BUILD`]).
    pub fn new(patches: &Patches) -> Self {
        Self::with_params(patches, BVH_BUILD)
    }

    /// Builds the BVH over all patches with obvhs build parameters `params`.
    pub fn with_params(patches: &Patches, params: BvhBuildParams) -> Self {
        let mut lo = DVec3::splat(f64::INFINITY);
        let mut hi = DVec3::splat(f64::NEG_INFINITY);
        for t in &patches.corners_m {
            for p in t {
                lo = lo.min(*p);
                hi = hi.max(*p);
            }
        }
        let diag = (hi - lo).length();
        let (eps_m, centre_m, scale) = if diag.is_finite() && diag > 0.0 {
            (1e-5 * diag, (lo + hi) * 0.5, FRAME_DIAGONAL / diag)
        } else {
            (1e-6, DVec3::ZERO, 1.0)
        };
        let to_frame = |p: DVec3| v3((p - centre_m) * scale);
        let input: Vec<Triangle> = patches
            .corners_m
            .iter()
            .map(|t| Triangle {
                v0: to_frame(t[0]),
                v1: to_frame(t[1]),
                v2: to_frame(t[2]),
            })
            .collect();
        let mut build_time = Duration::ZERO;
        let bvh = build_cwbvh_from_tris(&input, params, &mut build_time);
        let patch_of = bvh.primitive_indices.clone();
        let obvhs_tris: Vec<Triangle> = patch_of.iter().map(|&i| input[i as usize]).collect();
        let tris: Vec<EdgeTriangle> = obvhs_tris
            .iter()
            .map(|t| EdgeTriangle {
                v0: t.v0,
                e1: t.v1 - t.v0,
                e2: t.v2 - t.v0,
            })
            .collect();
        let normals = tris.iter().map(|t| t.e1.cross(t.e2)).collect();
        Self {
            bvh,
            tris,
            obvhs_tris,
            normals,
            patch_of,
            eps_m,
            centre_m,
            scale,
        }
    }

    /// A ray origin just in front of a surface point (along its unit normal).
    pub fn offset(&self, p: DVec3, normal: DVec3) -> DVec3 {
        p + normal * self.eps_m
    }

    /// The first surface along a unit direction from `origin`.
    pub fn closest(&self, origin: DVec3, dir: DVec3) -> Hit {
        let ray = self.frame_ray(origin, dir);
        self.hit(self.trace(&ray), &ray)
    }

    /// The ray from `origin` along a unit direction, in the caster's frame (f32), unbounded.
    #[inline]
    pub fn frame_ray(&self, origin: DVec3, dir: DVec3) -> Ray {
        debug_assert!(
            (dir.length() - 1.0).abs() < 1e-6,
            "ray directions are unit vectors"
        );
        Ray::new(
            self.to_frame(origin),
            direction_f32(dir),
            0.0,
            f32::INFINITY,
        )
    }

    /// BVH traversal alone: the closest primitive (BVH order) and its distance (caster units).
    #[inline]
    pub fn trace(&self, ray: &Ray) -> Option<(u32, f32)> {
        let mut hit = RayHit::none();
        self.bvh
            .ray_traverse(*ray, &mut hit, |r, id| intersect(&self.tris[id], r))
            .then_some((hit.primitive_id, hit.t))
    }

    /// The BVH's own rate: the same traversal with obvhs' own triangle test (two-sided, no
    /// edge tolerance): for the micro benchmark, not for form factors.
    pub fn trace_obvhs(&self, ray: &Ray) -> Option<(u32, f32)> {
        let mut hit = RayHit::none();
        self.bvh
            .ray_traverse(*ray, &mut hit, |r, id| self.obvhs_tris[id].intersect(r))
            .then_some((hit.primitive_id, hit.t))
    }

    /// A traced primitive as a patch hit: the patch lookup and the face test.
    #[inline]
    pub fn hit(&self, traced: Option<(u32, f32)>, ray: &Ray) -> Hit {
        let Some((prim, t)) = traced else {
            return Hit::Miss;
        };
        let prim = prim as usize;
        let patch = self.patch_of[prim];
        let t_m = f64::from(t) / self.scale;
        if self.normals[prim].dot(ray.direction) < 0.0 {
            Hit::Front { patch, t_m }
        } else {
            Hit::Back { patch, t_m }
        }
    }

    /// True when nothing lies on the segment from `from` to `to` (both ends excluded by the
    /// relative margin: `from` should already be offset from its surface, and `to` may lie on
    /// an emitting surface such as a luminaire opening).
    pub fn unoccluded(&self, from: DVec3, to: DVec3) -> bool {
        let v = to - from;
        let d = v.length();
        if d.is_nan() || d <= self.eps_m {
            return true;
        }
        let tmax = ((d - self.eps_m) * self.scale) as f32;
        let ray = Ray::new(self.to_frame(from), direction_f32(v / d), 0.0, tmax);
        self.bvh
            .ray_traverse_miss(ray, |r, id| intersect(&self.tris[id], r))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn two_squares() -> Patches {
        // floor (z = 0, facing up) and ceiling (z = 1, facing down), 1 × 1 m each
        let p = DVec3::new;
        let mut patches = Patches::default();
        let quads = [
            [p(0., 0., 0.), p(1., 0., 0.), p(1., 1., 0.), p(0., 1., 0.)],
            [p(0., 1., 1.), p(1., 1., 1.), p(1., 0., 1.), p(0., 0., 1.)],
        ];
        for q in quads {
            for t in [[q[0], q[1], q[2]], [q[0], q[2], q[3]]] {
                let cross = (t[1] - t[0]).cross(t[2] - t[0]);
                patches.corners_m.push(t);
                patches.normal.push(cross.normalize());
                patches.area_m2.push(0.5 * cross.length());
                patches.rho.push(0.5);
                patches.group.push(0);
                patches.source_triangle.push(0);
            }
        }
        patches
    }

    #[test]
    fn hits_map_back_to_patches_with_faces() {
        let patches = two_squares();
        let rc = RayCaster::new(&patches);
        match rc.closest(DVec3::new(0.7, 0.2, 0.001), DVec3::Z) {
            Hit::Front { patch, t_m } => {
                assert!(patch == 2 || patch == 3);
                assert!((t_m - 0.999).abs() < 1e-5);
                let c = patches.centroid_m(patch as usize);
                assert!((c.z - 1.0).abs() < 1e-12);
            }
            other => panic!("{other:?}"),
        }
        // exactly through the diagonal shared by the two triangles of a quad: no leak
        assert!(matches!(
            rc.closest(DVec3::new(0.5, 0.5, 2.0), DVec3::NEG_Z),
            Hit::Back { .. }
        ));
        for k in 1..100 {
            let x = f64::from(k) / 100.0;
            let on_diagonal = DVec3::new(x, 1.0 - x, 0.5);
            assert!(
                rc.closest(on_diagonal, DVec3::Z) != Hit::Miss,
                "leak at {x}"
            );
        }
        assert_eq!(rc.closest(DVec3::new(5.0, 5.0, 0.5), DVec3::Z), Hit::Miss);
        assert!(!rc.unoccluded(DVec3::new(0.5, 0.5, 0.5), DVec3::new(0.5, 0.5, 1.5)));
        // a segment ending on a surface is not blocked by that surface
        assert!(rc.unoccluded(DVec3::new(0.5, 0.5, 0.5), DVec3::new(0.5, 0.5, 1.0)));
    }

    #[test]
    fn negative_zero_direction_components_do_not_leak() {
        // A ray along a wall normal computed by a cross product, (1, 0, −0): obvhs' CWBVH picked
        // the wrong slab planes for the −0.0 axis and every such ray left the scene.
        let p = DVec3::new;
        let mut patches = two_squares();
        // a wall at x = 0 facing +x, and a panel 5 mm in front of it, facing +x too
        for (x, rho) in [(0.0, 0.5), (0.005, 0.8)] {
            for t in [
                [p(x, 0., 0.), p(x, 1., 0.), p(x, 1., 1.)],
                [p(x, 0., 0.), p(x, 1., 1.), p(x, 0., 1.)],
            ] {
                let cross = (t[1] - t[0]).cross(t[2] - t[0]);
                patches.corners_m.push(t);
                patches.normal.push(cross.normalize());
                patches.area_m2.push(0.5 * cross.length());
                patches.rho.push(rho);
                patches.group.push(1);
                patches.source_triangle.push(1);
            }
        }
        let rc = RayCaster::new(&patches);
        let panel = |h: Hit| match h {
            Hit::Back { patch, t_m } => {
                assert!(patch >= 6, "{h:?}");
                assert!((t_m - 0.004).abs() < 1e-5, "{h:?}");
            }
            other => panic!("{other:?}"),
        };
        let origin = p(0.001, 0.37, 0.61);
        for dir in [
            p(1.0, 0.0, 0.0),
            p(1.0, -0.0, 0.0),
            p(1.0, 0.0, -0.0),
            p(1.0, -0.0, -0.0),
            p(1.0, -1e-60, 1e-60), // −0.0 once in f32
        ] {
            panel(rc.closest(origin, dir));
            assert!(!rc.unoccluded(origin, origin + dir));
        }
        // and up from the floor with (−0, 0, 1), a desk's normal from a cross product
        match rc.closest(p(0.5, 0.5, 0.001), p(-0.0, 0.0, 1.0)) {
            Hit::Front { patch, .. } => assert!(patch == 2 || patch == 3),
            other => panic!("{other:?}"),
        }
    }
}
