//! A scene summary for people: what was read, in units.

use std::fmt;

use super::Scene;

/// Display adapter: `println!("{}", scene.summary())`.
pub struct SceneSummary<'a> {
    pub(super) scene: &'a Scene,
}

impl fmt::Display for SceneSummary<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let s = self.scene;
        let m = &s.mesh;
        let (lo, hi) = m.bounds_m();
        let size = hi - lo;
        let total_area: f64 = m.triangles.iter().map(|t| m.area_m2(t)).sum();
        writeln!(f, "scene {}", s.name)?;
        writeln!(
            f,
            "  geometry: {} triangles ({} zero-area dropped), {} vertices, {:.2} x {:.2} x {:.2} m, \
             {:.2} m² of surface",
            m.triangles.len(),
            s.obj_report.zero_area_dropped,
            m.positions_m.len(),
            size.x,
            size.y,
            size.z,
            total_area
        )?;

        writeln!(f, "  area per label:")?;
        let areas = m.area_per_group_m2();
        for (g, name) in m.groups.iter().enumerate() {
            let mut mats: Vec<String> = Vec::new();
            for t in m.triangles.iter().filter(|t| t.group as usize == g) {
                let mat = &m.materials[t.material as usize];
                let label = format!("{} (rho {})", mat.name, mat.rho);
                if !mats.contains(&label) {
                    mats.push(label);
                }
            }
            writeln!(
                f,
                "    {:<16} {:>8.3} m²  {}",
                name,
                areas[g],
                mats.join(", ")
            )?;
        }

        writeln!(f, "  luminaires: {}", s.luminaires.len())?;
        if !s.luminaires.is_empty() {
            writeln!(
                f,
                "    {:>4}  {:>22}  {:>10}  {:>10}  {:>10}  photometry",
                "id", "position (m)", "file (lm)", "flux (lm)", "max (cd)"
            )?;
        }
        for l in &s.luminaires {
            let (max_cd, c, g) = l.photometry.max_intensity();
            let file = l
                .photometry_path
                .file_name()
                .map(|n| n.to_string_lossy().into_owned())
                .unwrap_or_default();
            writeln!(
                f,
                "    {:>4}  ({:>6.3},{:>6.3},{:>6.3})  {:>10.1}  {:>10.1}  {:>10.1}  {} ({}, {}, peak at C{} γ{})",
                l.id,
                l.position_m.x,
                l.position_m.y,
                l.position_m.z,
                l.file_flux_lm,
                l.flux_lm,
                max_cd,
                file,
                l.photometry.format(),
                l.photometry.symmetry().name(),
                c,
                g
            )?;
        }

        writeln!(f, "  sensors: {}", s.sensors.len())?;
        for x in &s.sensors {
            writeln!(
                f,
                "    {:>4}  ({:>6.3},{:>6.3},{:>6.3})  normal ({:.2},{:.2},{:.2})  {}  {}",
                x.id,
                x.position_m.x,
                x.position_m.y,
                x.position_m.z,
                x.normal.x,
                x.normal.y,
                x.normal.z,
                x.response,
                x.note
            )?;
        }

        match &s.desks {
            Some(d) => writeln!(
                f,
                "  desks: {} ({} grid points at {} m)",
                d.desks.len(),
                d.grid_points.len(),
                d.grid_step_m
            )?,
            None => writeln!(f, "  desks: none (no desks.json)")?,
        }
        match &s.camera {
            Some(c) => writeln!(
                f,
                "  camera: {}x{} px at ({:.2},{:.2},{:.2}), horizontal field of view {:.1}°",
                c.width,
                c.height,
                c.position_m.x,
                c.position_m.y,
                c.position_m.z,
                2.0 * (0.5 * c.width as f64 / c.fx).atan().to_degrees()
            )?,
            None => writeln!(f, "  camera: none (no camera.json)")?,
        }
        if s.warnings.is_empty() {
            writeln!(f, "  warnings: none")?;
        } else {
            writeln!(f, "  warnings: {}", s.warnings.len())?;
            for w in &s.warnings {
                writeln!(f, "    - {w}")?;
            }
        }
        Ok(())
    }
}
