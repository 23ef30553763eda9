//! Building geometry in code: the built-in demo office and the closed-form test rooms.

use glam::DVec3;

use super::{Material, Mesh, Triangle};
use crate::units::{Reflectance, ReflectanceError};

/// Appends materials, groups and quads to a [`Mesh`].
#[derive(Debug, Default)]
pub struct MeshBuilder {
    mesh: Mesh,
}

impl MeshBuilder {
    /// An empty mesh.
    pub fn new() -> Self {
        Self::default()
    }

    /// Adds a material; its index for [`MeshBuilder::quad`].
    pub fn material(&mut self, name: &str, rho: f64) -> Result<u32, ReflectanceError> {
        let rho = Reflectance::new(rho)?;
        self.mesh.materials.push(Material {
            name: name.to_owned(),
            rho,
        });
        Ok((self.mesh.materials.len() - 1) as u32)
    }

    fn group(&mut self, name: &str) -> u32 {
        if let Some(i) = self.mesh.groups.iter().position(|g| g == name) {
            return i as u32;
        }
        self.mesh.groups.push(name.to_owned());
        (self.mesh.groups.len() - 1) as u32
    }

    /// A planar quad a → b → c → d, counter-clockwise seen from its front.
    pub fn quad(&mut self, corners: [DVec3; 4], group: &str, material: u32) -> &mut Self {
        let group = self.group(group);
        let base = self.mesh.positions_m.len() as u32;
        self.mesh.positions_m.extend_from_slice(&corners);
        for v in [[base, base + 1, base + 2], [base, base + 2, base + 3]] {
            self.mesh.triangles.push(Triangle { v, group, material });
        }
        self
    }

    /// A closed box with outward faces; the bottom face is left out when it stands on z = 0.
    pub fn solid_box(&mut self, lo: DVec3, hi: DVec3, group: &str, material: u32) -> &mut Self {
        let p = DVec3::new;
        let (x0, y0, z0, x1, y1, z1) = (lo.x, lo.y, lo.z, hi.x, hi.y, hi.z);
        self.quad(
            [p(x0, y0, z1), p(x1, y0, z1), p(x1, y1, z1), p(x0, y1, z1)],
            group,
            material,
        );
        self.quad(
            [p(x0, y0, z0), p(x1, y0, z0), p(x1, y0, z1), p(x0, y0, z1)],
            group,
            material,
        );
        self.quad(
            [p(x1, y1, z0), p(x0, y1, z0), p(x0, y1, z1), p(x1, y1, z1)],
            group,
            material,
        );
        self.quad(
            [p(x0, y1, z0), p(x0, y0, z0), p(x0, y0, z1), p(x0, y1, z1)],
            group,
            material,
        );
        self.quad(
            [p(x1, y0, z0), p(x1, y1, z0), p(x1, y1, z1), p(x1, y0, z1)],
            group,
            material,
        );
        if z0.abs() > 1e-9 {
            self.quad(
                [p(x0, y1, z0), p(x1, y1, z0), p(x1, y0, z0), p(x0, y0, z0)],
                group,
                material,
            );
        }
        self
    }

    /// The six faces of a room `[0, size]` facing inwards, named floor, ceiling, wall_s,
    /// wall_n, wall_w, wall_e; `skip` leaves faces out by name (an open room).
    pub fn room(&mut self, size: DVec3, material: u32, skip: &[&str]) -> &mut Self {
        let p = DVec3::new;
        let (lx, ly, lz) = (size.x, size.y, size.z);
        let faces = [
            (
                "floor",
                [p(0., 0., 0.), p(lx, 0., 0.), p(lx, ly, 0.), p(0., ly, 0.)],
            ),
            (
                "ceiling",
                [p(0., ly, lz), p(lx, ly, lz), p(lx, 0., lz), p(0., 0., lz)],
            ),
            (
                "wall_s",
                [p(0., 0., 0.), p(0., 0., lz), p(lx, 0., lz), p(lx, 0., 0.)],
            ),
            (
                "wall_n",
                [p(lx, ly, 0.), p(lx, ly, lz), p(0., ly, lz), p(0., ly, 0.)],
            ),
            (
                "wall_w",
                [p(0., ly, 0.), p(0., ly, lz), p(0., 0., lz), p(0., 0., 0.)],
            ),
            (
                "wall_e",
                [p(lx, 0., 0.), p(lx, 0., lz), p(lx, ly, lz), p(lx, ly, 0.)],
            ),
        ];
        for (name, q) in faces {
            if !skip.contains(&name) {
                self.quad(q, name, material);
            }
        }
        self
    }

    /// The mesh.
    pub fn build(self) -> Mesh {
        self.mesh
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn room_faces_point_inwards_and_boxes_outwards() {
        let mut b = MeshBuilder::new();
        let m = b.material("grey", 0.5).unwrap();
        b.room(DVec3::new(4.0, 3.0, 2.5), m, &[]);
        b.solid_box(
            DVec3::new(1.0, 1.0, 0.0),
            DVec3::new(2.0, 2.0, 0.7),
            "box",
            m,
        );
        let mesh = b.build();
        let centre = DVec3::new(2.0, 1.5, 1.25);
        let box_centre = DVec3::new(1.5, 1.5, 0.35);
        for t in &mesh.triangles {
            let c = mesh.corners_m(t).iter().sum::<DVec3>() / 3.0;
            let n = mesh.normal(t);
            if mesh.groups[t.group as usize] == "box" {
                assert!(n.dot(c - box_centre) > 0.0);
            } else {
                assert!(n.dot(centre - c) > 0.0);
            }
        }
        assert!(b_is_err());
    }

    fn b_is_err() -> bool {
        MeshBuilder::new().material("white", 1.0).is_err()
    }
}
