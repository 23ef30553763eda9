//! The commissioned mesh as PLY (reflectance as grey vertex colour), for any mesh viewer. The
//! pictures for people are in `crate::render` (feature `report`).

use std::io::Write;
use std::path::Path;

use super::Commissioned;

/// Writes the mesh as ASCII PLY (per-vertex grey = reflectance; vertices are not shared).
pub fn write_ply(c: &Commissioned, path: &Path) -> std::io::Result<()> {
    let mesh = &c.scene.mesh;
    let mut w = std::io::BufWriter::new(std::fs::File::create(path)?);
    let n = mesh.triangles.len();
    writeln!(
        w,
        "ply\nformat ascii 1.0\ncomment luxnode commissioned mesh, metres, grey = reflectance\n\
         element vertex {}\nproperty float x\nproperty float y\nproperty float z\n\
         property uchar red\nproperty uchar green\nproperty uchar blue\n\
         element face {n}\nproperty list uchar int vertex_indices\nend_header",
        3 * n
    )?;
    for t in &mesh.triangles {
        let rho = mesh.materials[t.material as usize].rho.get();
        let g = (rho * 255.0).round().clamp(0.0, 255.0) as u8;
        for p in mesh.corners_m(t) {
            writeln!(w, "{:.4} {:.4} {:.4} {g} {g} {g}", p.x, p.y, p.z)?;
        }
    }
    for k in 0..n {
        writeln!(w, "3 {} {} {}", 3 * k, 3 * k + 1, 3 * k + 2)?;
    }
    w.flush()
}
