//! Daylight coefficients (`engine::daylight`) against closed forms.
//!
//! Each Monte-Carlo tolerance is three standard errors of the estimator, computed from the
//! sample count: for a point receiver, `σ/√N` with σ the standard deviation of one window
//! sample's contribution (by fine quadrature over the window here: an upper bound, the
//! stratified estimator does better); for sums over patches, the spread over independent seeds.

mod common;

use std::f64::consts::PI;

use common::{b3, scene, sensor};
use glam::DVec3;
use luxnode::engine::daylight::{
    self, COLUMNS, DaylightRoom, DaylightSettings, GROUND_COLUMN, Glazing, Window,
};
use luxnode::engine::raycast::RayCaster;
use luxnode::engine::{self, Model, PatchSettings, Settings, multisolve};
use luxnode::scene::{MeshBuilder, Scene};
use luxnode::sky::{PATCH_COUNT, SkyFrame, patch, patch_of, sky_direction};

/// North along world +y: the sky frame is the world frame.
fn north_y() -> SkyFrame {
    SkyFrame::new([0.0, 1.0]).expect("a unit north")
}

fn quick_settings(patch_size_m: f64) -> Settings {
    Settings {
        patches: PatchSettings {
            patch_size_m,
            detail_ratio: 0.0,
            min_patch_m: patch_size_m,
            light_ratio: 0.0,
        },
        rays: 300,
        sensor_rays: 2000,
        final_gather_rays: 0,
        ..Settings::default()
    }
}

fn model_of(s: &Scene, patch_size_m: f64) -> Model {
    engine::compute_model(s, &quick_settings(patch_size_m)).expect("a model")
}

fn sensor_points(s: &Scene) -> Vec<(DVec3, DVec3)> {
    s.sensors.iter().map(|s| (s.position_m, s.normal)).collect()
}

/// Mean and standard deviation of one uniform window sample's contribution
/// `A τ cos θ_x cos θ_w / r²` (restricted to directions `keep`), by a midpoint grid.
fn sample_stats(
    w: &Window,
    x: DVec3,
    n: DVec3,
    keep: impl Fn(DVec3) -> bool,
    grid: usize,
) -> (f64, f64) {
    let a = w.area_m2();
    let (mut s1, mut s2) = (0.0, 0.0);
    for i in 0..grid {
        for j in 0..grid {
            let q = w.corner_m
                + w.edge_u_m * ((i as f64 + 0.5) / grid as f64)
                + w.edge_v_m * ((j as f64 + 0.5) / grid as f64);
            let v = q - x;
            let r2 = v.length_squared();
            let d = v / r2.sqrt();
            let (cx, cw) = (n.dot(d), -w.inward.dot(d));
            let f = if cx > 0.0 && cw > 0.0 && keep(d) {
                a * w.transmittance_at(cw) * cx * cw / r2
            } else {
                0.0
            };
            s1 += f;
            s2 += f * f;
        }
    }
    let m = (grid * grid) as f64;
    let mean = s1 / m;
    (mean, (s2 / m - mean * mean).max(0.0).sqrt())
}

/// B-3 by corner superposition: a point at `(px, py)` under a parallel rectangle
/// `[x0, x1] × [y0, y1]` at height `c`.
fn parallel_rect(px: f64, py: f64, x: [f64; 2], y: [f64; 2], c: f64) -> f64 {
    let g = |a: f64, b: f64| a.signum() * b.signum() * b3(a.abs(), b.abs(), c);
    let (x0, x1, y0, y1) = (x[0] - px, x[1] - px, y[0] - py, y[1] - py);
    g(x1, y1) - g(x0, y1) - g(x1, y0) + g(x0, y0)
}

/// Howell B-8 with Φ = 90° (Hamilton and Morgan 1952; Tregenza and Sharples, algorithm 3.15):
/// a planar element to a rectangle in a perpendicular plane, the element on the normal to the
/// planes' intersection line through one corner of the rectangle. `a` along the intersection
/// line, `b` away from it, `c` the element's distance from the line.
fn perpendicular_corner(a: f64, b: f64, c: f64) -> f64 {
    let s = b.hypot(c);
    ((a / c).atan() - c / s * (a / s).atan()) / (2.0 * PI)
}

/// A floor point at `(px, py, 0)` to a rectangle on the wall `y = 0`, x in `[x0, x1]`, z in
/// `[z0, z1]`, by corner superposition of [`perpendicular_corner`].
fn perpendicular_rect(px: f64, py: f64, x: [f64; 2], z: [f64; 2]) -> f64 {
    let g = |a: f64, b: f64| a.signum() * perpendicular_corner(a.abs(), b, py);
    let strip = |a: f64| g(a, z[1]) - g(a, z[0]);
    strip(x[1] - px) - strip(x[0] - px)
}

#[test]
fn perpendicular_factor_matches_quadrature() {
    // the derivation's check: ∫ cos θ1 cos θ2 / (π r²) dA over a 1 × 2 m rectangle on y = 0
    let (px, py) = (0.3, 1.2);
    let grid = 800;
    let mut f = 0.0;
    for i in 0..grid {
        for j in 0..grid {
            let x = -0.4 + (i as f64 + 0.5) / grid as f64;
            let z = 0.5 + 2.0 * (j as f64 + 0.5) / grid as f64;
            let v = DVec3::new(x - px, -py, z);
            let r2 = v.length_squared();
            f += (z / r2.sqrt()) * (py / r2.sqrt()) / (PI * r2) * 2.0 / (grid * grid) as f64;
        }
    }
    let closed = perpendicular_rect(px, py, [-0.4, 0.6], [0.5, 2.5]);
    assert!((f - closed).abs() < 1e-5 * closed, "{f} vs {closed}");
}

/// A black floor 10 × 10 m and one sensor; the window needs no geometry.
fn black_floor(sensors: &[DVec3]) -> Scene {
    let mut b = MeshBuilder::new();
    let m = b.material("black", 0.0).expect("a reflectance");
    b.quad(
        [
            DVec3::new(-5.0, -5.0, 0.0),
            DVec3::new(5.0, -5.0, 0.0),
            DVec3::new(5.0, 5.0, 0.0),
            DVec3::new(-5.0, 5.0, 0.0),
        ],
        "floor",
        m,
    );
    let sensors = sensors
        .iter()
        .enumerate()
        .map(|(i, p)| sensor(i as u32, *p))
        .collect();
    scene(b.build(), Vec::new(), sensors)
}

#[test]
fn uniform_sky_through_a_skylight_is_tau_pi_f() {
    let tau = 0.8;
    // a 1.2 × 0.9 m skylight 2.2 m above the sensor, facing down; sensor off its centre
    let w = Window {
        corner_m: DVec3::new(-0.5, -0.3, 3.0),
        edge_u_m: DVec3::new(0.0, 0.9, 0.0),
        edge_v_m: DVec3::new(1.2, 0.0, 0.0),
        inward: DVec3::NEG_Z,
        transmittance: tau,
        glazing: Glazing::Constant,
    };
    let p = DVec3::new(0.05, 0.1, 0.8);
    let s = black_floor(&[p]);
    let model = model_of(&s, 1.0);
    let caster = RayCaster::new(&model.patches);
    let pts = sensor_points(&s);
    let windows = [w];
    let room = DaylightRoom::of_model(&model, &caster, &pts, &windows, north_y());
    let settings = DaylightSettings {
        sensor_samples: 4096,
        ..DaylightSettings::default()
    };
    let direct = room.direct_sky(&settings).expect("direct sky");
    let row = direct.sensor.row(0);
    let uniform = [1.0; PATCH_COUNT];
    let e = direct.sensor.illuminance_lx(&uniform, 0.0)[0];
    let f = parallel_rect(p.x, p.y, [-0.5, 0.7], [-0.3, 0.6], 3.0 - p.z);
    let exact = tau * PI * f;
    let (mean, sigma) = sample_stats(&w, p, DVec3::Z, |_| true, 600);
    let tol = 3.0 * sigma / 4096f64.sqrt() + 1e-6 * exact; // f32 storage
    println!("skylight: E {e:.6} exact {exact:.6} (quadrature {mean:.6}) tol {tol:.2e}");
    assert!((e - exact).abs() < tol, "{e} vs {exact} ± {tol}");
    // the sum of the columns is the all-patch result, and nothing comes from below
    let sum: f64 = row[..PATCH_COUNT].iter().map(|v| f64::from(*v)).sum();
    assert!((sum - e).abs() < 1e-6 * e);
    assert_eq!(row[GROUND_COLUMN], 0.0);
    // the zenith cap (altitude > 84°) lies wholly inside the skylight seen from a point under
    // its middle: its coefficient is τ × its projected solid angle
    let under = DVec3::new(0.1, 0.15, 0.8);
    let cap = patch(144).expect("the cap");
    let s2 = black_floor(&[under]);
    let model2 = model_of(&s2, 1.0);
    let caster2 = RayCaster::new(&model2.patches);
    let pts2 = sensor_points(&s2);
    let room2 = DaylightRoom::of_model(&model2, &caster2, &pts2, &windows, north_y());
    let d2 = room2.direct_sky(&settings).expect("direct sky");
    let e_cap = f64::from(d2.sensor.row(0)[144]);
    let exact_cap = tau * cap.projected_solid_angle_sr;
    let in_cap = |d: DVec3| d.z > (84f64).to_radians().sin();
    let (_, sigma_cap) = sample_stats(&w, under, DVec3::Z, in_cap, 600);
    let tol_cap = 3.0 * sigma_cap / 4096f64.sqrt();
    println!("cap: {e_cap:.6} exact {exact_cap:.6} tol {tol_cap:.2e}");
    assert!(
        (e_cap - exact_cap).abs() < tol_cap,
        "{e_cap} vs {exact_cap}"
    );
    // the horizon band cannot be seen through a skylight from below it
    assert!(d2.sensor.row(0)[..30].iter().all(|v| *v == 0.0));
}

/// A south window on the wall y = 0 (outward −y), x in [0, 4], z in [0.5, 3.5].
fn south_window(tau: f64, glazing: Glazing) -> Window {
    Window {
        corner_m: DVec3::new(0.0, 0.0, 0.5),
        edge_u_m: DVec3::new(4.0, 0.0, 0.0),
        edge_v_m: DVec3::new(0.0, 0.0, 3.0),
        inward: DVec3::Y,
        transmittance: tau,
        glazing,
    }
}

#[test]
fn vertical_window_onto_a_floor_point_is_tau_pi_f() {
    let tau = 0.7;
    let w = south_window(tau, Glazing::Constant);
    // floor points at 1 m and, deep in the room, 5 m from the window
    let near = DVec3::new(2.0, 1.0, 0.0);
    let deep = DVec3::new(1.3, 5.0, 0.0);
    let s = black_floor(&[near + DVec3::Z * 1e-9, deep + DVec3::Z * 1e-9]);
    let model = model_of(&s, 1.0);
    let caster = RayCaster::new(&model.patches);
    let pts = sensor_points(&s);
    let windows = [w];
    let room = DaylightRoom::of_model(&model, &caster, &pts, &windows, north_y());
    let n = 4096;
    let settings = DaylightSettings {
        sensor_samples: n,
        ..DaylightSettings::default()
    };
    let direct = room.direct_sky(&settings).expect("direct sky");
    let uniform = [1.0; PATCH_COUNT];
    let e = direct.sensor.illuminance_lx(&uniform, 0.0);
    for (k, p) in [near, deep].iter().enumerate() {
        let exact = tau * PI * perpendicular_rect(p.x, p.y, [0.0, 4.0], [0.5, 3.5]);
        let (_, sigma) = sample_stats(&w, *p, DVec3::Z, |_| true, 600);
        let tol = 3.0 * sigma / (n as f64).sqrt() + 1e-6 * exact;
        println!(
            "vertical window, floor point {k}: E {:.6} exact {exact:.6} tol {tol:.2e}",
            e[k]
        );
        assert!((e[k] - exact).abs() < tol, "{} vs {exact} ± {tol}", e[k]);
        let row = direct.sensor.row(k);
        // the window is above the floor: no ground; no northern patch through a south window
        assert_eq!(row[GROUND_COLUMN], 0.0);
        for (j, v) in row[..PATCH_COUNT].iter().enumerate() {
            let pj = patch(j).expect("a patch");
            let north = pj.azimuth_max_rad <= PI / 2.0 && pj.azimuth_min_rad >= -PI / 2.0;
            if north || j == 144 && k == 1 {
                assert_eq!(*v, 0.0, "patch {j} seen through a south window");
            }
        }
    }
    // a Tregenza patch wholly inside the window seen from the near point (band 36-48° due
    // south): τ × its projected solid angle, cos θ_x being the altitude's sine on the floor
    let south = patch_of(sky_direction(42f64.to_radians(), PI)).expect("a patch");
    let pj = patch(south).expect("a patch");
    let exact = tau * pj.projected_solid_angle_sr;
    let got = f64::from(direct.sensor.row(0)[south]);
    let in_patch = |d: DVec3| patch_of(d.to_array()) == Some(south);
    let (_, sigma) = sample_stats(&w, near, DVec3::Z, in_patch, 600);
    let tol = 3.0 * sigma / (n as f64).sqrt();
    println!("patch {south}: {got:.6} exact {exact:.6} tol {tol:.2e}");
    assert!((got - exact).abs() < tol, "{got} vs {exact} ± {tol}");
}

/// A closed 5 × 4 × 3 m grey room with a black glazing strip (x over the whole south wall,
/// z in [1, 2]) standing for the window.
fn box_with_window(rho: f64, sensors: &[DVec3]) -> (Scene, Window) {
    let mut b = MeshBuilder::new();
    let grey = b.material("grey", rho).expect("a reflectance");
    let glass = b.material("glazing", 0.0).expect("a reflectance");
    b.room(DVec3::new(5.0, 4.0, 3.0), grey, &["wall_s"]);
    let p = DVec3::new;
    for (z0, z1, name, m) in [
        (0.0, 1.0, "wall_s", grey),
        (1.0, 2.0, "window_0", glass),
        (2.0, 3.0, "wall_s", grey),
    ] {
        b.quad(
            [p(0., 0., z0), p(0., 0., z1), p(5., 0., z1), p(5., 0., z0)],
            name,
            m,
        );
    }
    let sensors = sensors
        .iter()
        .enumerate()
        .map(|(i, q)| sensor(i as u32, *q))
        .collect();
    let w = Window {
        corner_m: p(0.0, 0.0, 1.0),
        edge_u_m: p(5.0, 0.0, 0.0),
        edge_v_m: p(0.0, 0.0, 1.0),
        inward: DVec3::Y,
        transmittance: 0.75,
        glazing: Glazing::Constant,
    };
    (scene(b.build(), Vec::new(), sensors), w)
}

#[test]
fn closed_box_with_a_window_balances_flux() {
    let rho = 0.6;
    let (s, w) = box_with_window(rho, &[DVec3::new(2.5, 2.0, 0.8)]);
    let model = model_of(&s, 0.5);
    let caster = RayCaster::new(&model.patches);
    let pts = sensor_points(&s);
    let windows = [w];
    let room = DaylightRoom::of_model(&model, &caster, &pts, &windows, north_y());
    let p = &model.patches;
    // sky and ground of 1 cd/m²: the flux through the window is τ π L A_w
    let exact_in = w.transmittance * PI * w.area_m2();
    let mut fluxes = Vec::new();
    for seed in 0..4u64 {
        let settings = DaylightSettings {
            patch_samples: 64,
            sensor_samples: 256,
            seed,
            ..DaylightSettings::default()
        };
        let direct = room.direct_sky(&settings).expect("direct sky");
        let e_dir: Vec<f64> = (0..p.len())
            .map(|i| direct.patch.row(i).iter().map(|v| f64::from(*v)).sum())
            .collect();
        let flux_in: f64 = e_dir.iter().zip(&p.area_m2).map(|(e, a)| e * a).sum();
        // through the interreflections: absorbed (by the grey walls, and leaving through the
        // black glazing) = entering
        let solved = multisolve::solve_all(
            &model.ff.f,
            &p.rho,
            std::slice::from_ref(&e_dir),
            model.settings.solve,
        )
        .expect("a solve");
        let b = &solved[0].0;
        let absorbed: f64 = (0..p.len())
            .map(|i| {
                let e = e_dir[i]
                    + model
                        .ff
                        .f
                        .row(i)
                        .map(|(j, f)| f * b[j as usize])
                        .sum::<f64>();
                p.area_m2[i] * (1.0 - p.rho[i]) * e
            })
            .sum();
        println!(
            "seed {seed}: flux in {flux_in:.5} lm (exact {exact_in:.5}), absorbed {absorbed:.5}"
        );
        assert!(
            (absorbed - flux_in).abs() < 1e-6 * flux_in,
            "{absorbed} vs {flux_in}"
        );
        fluxes.push(flux_in);
    }
    let k = fluxes.len() as f64;
    let mean = fluxes.iter().sum::<f64>() / k;
    let sd = (fluxes.iter().map(|f| (f - mean).powi(2)).sum::<f64>() / (k - 1.0)).sqrt();
    // the mean of four seeds: within three of its standard errors (and a floor for f32)
    let tol = 3.0 * sd / k.sqrt() + 1e-6 * exact_in;
    println!("flux in: mean {mean:.5} exact {exact_in:.5} sd {sd:.2e} tol {tol:.2e}");
    assert!(
        (mean - exact_in).abs() < tol,
        "{mean} vs {exact_in} ± {tol}"
    );
}

#[test]
fn coefficients_through_interreflection_superpose() {
    let rho = 0.5;
    let sensors = [DVec3::new(2.5, 2.0, 0.8), DVec3::new(1.0, 3.5, 0.8)];
    let (s, w) = box_with_window(rho, &sensors);
    let model = model_of(&s, 0.5);
    let caster = RayCaster::new(&model.patches);
    let pts = sensor_points(&s);
    let windows = [w];
    let room = DaylightRoom::of_model(&model, &caster, &pts, &windows, north_y());
    let settings = DaylightSettings {
        patch_samples: 16,
        sensor_samples: 1024,
        ..DaylightSettings::default()
    };
    let direct = room.direct_sky(&settings).expect("direct sky");
    let importance = room.importance().expect("importance");
    let d = room
        .coefficients(&direct, &importance)
        .expect("coefficients");
    assert_eq!(d.rows(), 2);
    assert_eq!(d.bytes(), 2 * COLUMNS * 4);
    // a non-uniform sky: the sum of the columns equals one solve with the summed source
    let sky: [f64; PATCH_COUNT] = std::array::from_fn(|j| 1.0 + (j % 7) as f64);
    let ground = 0.3;
    let by_columns = d.illuminance_lx(&sky, ground);
    let p = &model.patches;
    let e: Vec<f64> = (0..p.len())
        .map(|i| {
            let r = direct.patch.row(i);
            sky.iter()
                .zip(r)
                .map(|(l, v)| l * f64::from(*v))
                .sum::<f64>()
                + ground * f64::from(r[GROUND_COLUMN])
        })
        .collect();
    let solved =
        multisolve::solve_all(&model.ff.f, &p.rho, &[e], model.settings.solve).expect("a solve");
    let direct_sensor = direct.sensor.illuminance_lx(&sky, ground);
    for (si, v) in by_columns.iter().enumerate() {
        let once = direct_sensor[si]
            + model
                .gather
                .row(si)
                .map(|(j, g)| g * solved[0].0[j as usize])
                .sum::<f64>();
        println!("sensor {si}: by columns {v:.5} lx, one solve {once:.5} lx");
        assert!((v - once).abs() < 1e-5 * once, "{v} vs {once}");
        // interreflection adds light: more than the direct part
        assert!(*v > direct_sensor[si]);
    }
    // the sun through the importance equals a forward solve of its direct patch irradiance
    let sun = DVec3::from_array(sky_direction(35f64.to_radians(), 200f64.to_radians()));
    let by_importance = room
        .sun_coefficients(&[sun], &settings, &importance)
        .expect("sun");
    let direct_sun = room.direct_sun(sun, &settings).expect("direct sun");
    assert!(direct_sun.patch_lx.iter().any(|e| *e > 0.0));
    let solved = multisolve::solve_all(
        &model.ff.f,
        &p.rho,
        std::slice::from_ref(&direct_sun.patch_lx),
        model.settings.solve,
    )
    .expect("a solve");
    for (si, v) in by_importance[0].iter().enumerate() {
        let once = direct_sun.sensor_lx[si]
            + model
                .gather
                .row(si)
                .map(|(j, g)| g * solved[0].0[j as usize])
                .sum::<f64>();
        println!("sun, sensor {si}: by importance {v:.6} lx/lx, forward solve {once:.6} lx/lx");
        assert!((v - once).abs() < 1e-6 * once, "{v} vs {once}");
    }
}

#[test]
fn sun_patch_falls_where_geometry_says() {
    // black room, window x in [1, 3], z in [1, 2] on the south wall; sun due south at 40°
    let alt = 40f64.to_radians();
    let sun = DVec3::from_array(sky_direction(alt, PI));
    let lit = DVec3::new(2.0, 1.8, 0.01);
    let shade_far = DVec3::new(2.0, 3.0, 0.01);
    let shade_sill = DVec3::new(2.0, 1.0, 0.01);
    let shade_side = DVec3::new(0.5, 1.8, 0.01);
    let behind_block = DVec3::new(3.6, 1.8, 0.01);
    let mut b = MeshBuilder::new();
    let black = b.material("black", 0.0).expect("a reflectance");
    b.room(DVec3::new(5.0, 4.0, 3.0), black, &["wall_s"]);
    let p = DVec3::new;
    b.quad(
        [p(0., 0., 0.), p(0., 0., 3.), p(5., 0., 3.), p(5., 0., 0.)],
        "wall_s",
        black,
    );
    // a block in the beam to one floor point: x in [3.5, 3.7] only when the window is wider
    b.solid_box(p(3.2, 0.9, 0.5), p(4.0, 1.1, 0.9), "block", black);
    let sensors = [lit, shade_far, shade_sill, shade_side, behind_block];
    let s = scene(
        b.build(),
        Vec::new(),
        sensors
            .iter()
            .enumerate()
            .map(|(i, q)| sensor(i as u32, *q))
            .collect(),
    );
    let model = model_of(&s, 0.25);
    let caster = RayCaster::new(&model.patches);
    let pts = sensor_points(&s);
    let w = Window {
        corner_m: p(1.0, 0.0, 1.0),
        edge_u_m: p(2.0, 0.0, 0.0),
        edge_v_m: p(0.0, 0.0, 1.0),
        inward: DVec3::Y,
        transmittance: 0.8,
        glazing: Glazing::ClearGlass,
    };
    let wide = Window {
        corner_m: p(1.0, 0.0, 1.0),
        edge_u_m: p(3.0, 0.0, 0.0),
        ..w
    };
    let settings = DaylightSettings::default();
    let expected = 0.8 * daylight::clear_glass_relative(alt.cos()) * alt.sin();
    for (windows, name) in [([w], "2 m window"), ([wide], "3 m window")] {
        let room = DaylightRoom::of_model(&model, &caster, &pts, &windows, north_y());
        let d = room.direct_sun(sun, &settings).expect("direct sun");
        println!("{name}: {:?} (lit: {expected:.6})", d.sensor_lx);
        assert!(
            (d.sensor_lx[0] - expected).abs() < 1e-12,
            "{}",
            d.sensor_lx[0]
        );
        assert_eq!(
            &d.sensor_lx[1..],
            &[0.0; 4],
            "outside the sun patch or blocked"
        );
        // the floor's patches: wholly inside the sunlit rectangle get the lit value, wholly
        // outside get nothing
        let (y0, y1) = (1.0 / alt.tan(), 2.0 / alt.tan());
        let x1 = if name.starts_with('2') { 3.0 } else { 3.2 };
        let mut checked = (0, 0);
        for i in 0..model.patches.len() {
            let c = model.patches.corners_m[i];
            if model.patches.normal[i].z < 0.9 || c.iter().any(|q| q.z.abs() > 1e-9) {
                continue;
            }
            let inside = c
                .iter()
                .all(|q| (1.0..=x1).contains(&q.x) && (y0..=y1).contains(&q.y));
            let outside = c.iter().all(|q| q.y > y1 || q.y < y0 - 1.0)
                || c.iter().all(|q| q.x < 1.0 || q.x > 4.0);
            if inside {
                assert!((d.patch_lx[i] - expected).abs() < 1e-12, "patch {i}");
                checked.0 += 1;
            } else if outside {
                assert_eq!(d.patch_lx[i], 0.0, "patch {i}");
                checked.1 += 1;
            }
        }
        assert!(checked.0 > 10 && checked.1 > 10, "{checked:?}");
    }
}

/// An office-sized room (6 × 4 × 3 m, ρ 0.5 walls, 0.2 floor), two desks, four luminaires,
/// eight desk sensors and a 4 × 1.5 m south window.
fn office(patch_size_m: f64) -> (Scene, Settings, Window) {
    let p = DVec3::new;
    let mut b = MeshBuilder::new();
    let wall = b.material("wall", 0.5).expect("a reflectance");
    let floor = b.material("floor", 0.2).expect("a reflectance");
    let desk = b.material("desk", 0.4).expect("a reflectance");
    let glass = b.material("glazing", 0.08).expect("a reflectance");
    b.room(p(6.0, 4.0, 3.0), wall, &["wall_s", "floor"]);
    b.quad(
        [p(0., 0., 0.), p(6., 0., 0.), p(6., 4., 0.), p(0., 4., 0.)],
        "floor",
        floor,
    );
    for (x0, x1, z0, z1, name, m) in [
        (0.0, 6.0, 0.0, 0.9, "wall_s", wall),
        (0.0, 6.0, 2.4, 3.0, "wall_s", wall),
        (0.0, 1.0, 0.9, 2.4, "wall_s", wall),
        (5.0, 6.0, 0.9, 2.4, "wall_s", wall),
        (1.0, 5.0, 0.9, 2.4, "window_0", glass),
    ] {
        b.quad(
            [p(x0, 0., z0), p(x0, 0., z1), p(x1, 0., z1), p(x1, 0., z0)],
            name,
            m,
        );
    }
    b.solid_box(p(0.8, 1.0, 0.0), p(2.8, 1.8, 0.75), "desk_1", desk);
    b.solid_box(p(3.2, 1.0, 0.0), p(5.2, 1.8, 0.75), "desk_2", desk);
    let lums = (0..4)
        .map(|k| {
            let pos = p(1.5 + 3.0 * (k % 2) as f64, 1.0 + 2.0 * (k / 2) as f64, 2.95);
            common::luminaire(k, pos, [0.6, 0.6], false, |g: f64| {
                1000.0 * g.cos().max(0.0)
            })
        })
        .collect();
    let sensors = [
        (1.2, 1.2, 0.751),
        (2.4, 1.6, 0.751),
        (3.6, 1.2, 0.751),
        (4.8, 1.6, 0.751),
        (1.0, 3.0, 0.8),
        (3.0, 3.0, 0.8),
        (5.0, 3.0, 0.8),
        (3.0, 0.5, 0.8),
    ]
    .iter()
    .enumerate()
    .map(|(i, (x, y, z))| sensor(i as u32, p(*x, *y, *z)))
    .collect();
    let settings = Settings {
        patches: PatchSettings {
            patch_size_m,
            ..PatchSettings::default()
        },
        ..Settings::default()
    };
    let w = Window {
        corner_m: p(1.0, 0.0, 0.9),
        edge_u_m: p(4.0, 0.0, 0.0),
        edge_v_m: p(0.0, 0.0, 1.5),
        inward: DVec3::Y,
        transmittance: 0.7,
        glazing: Glazing::ClearGlass,
    };
    (scene(b.build(), lums, sensors), settings, w)
}

/// The cost of the daylight coefficients against commissioning, office-sized rooms. Run with
/// `cargo test --test daylight cost -- --ignored --nocapture` (timings, not a check).
#[test]
#[ignore]
fn cost_of_daylight_coefficients() {
    use std::time::Instant;
    for patch_size_m in [0.5, 0.3] {
        let (s, settings, w) = office(patch_size_m);
        let t0 = Instant::now();
        let model = engine::compute_model(&s, &settings).expect("a model");
        let commission = t0.elapsed().as_secs_f64();
        let caster = RayCaster::new(&model.patches);
        let pts = sensor_points(&s);
        let windows = [w];
        let room = DaylightRoom::of_model(&model, &caster, &pts, &windows, north_y());
        println!(
            "{} patches, {} sensors: commissioning {commission:.2} s",
            model.patches.len(),
            pts.len()
        );
        for (patch_samples, sensor_samples) in [(16, 1024), (64, 4096)] {
            let ds = DaylightSettings {
                patch_samples,
                sensor_samples,
                ..DaylightSettings::default()
            };
            let t1 = Instant::now();
            let direct = room.direct_sky(&ds).expect("direct sky");
            let t_direct = t1.elapsed().as_secs_f64();
            let importance = room.importance().expect("importance");
            let t_importance = t1.elapsed().as_secs_f64() - t_direct;
            let d = room
                .coefficients(&direct, &importance)
                .expect("coefficients");
            let t_all = t1.elapsed().as_secs_f64();
            let suns: Vec<DVec3> = (0..24)
                .map(|k| {
                    let az = PI / 2.0 + PI * k as f64 / 23.0;
                    DVec3::from_array(sky_direction(30f64.to_radians(), az))
                })
                .collect();
            let t2 = Instant::now();
            let sun = room.sun_coefficients(&suns, &ds, &importance).expect("sun");
            let t_sun = t2.elapsed().as_secs_f64();
            println!(
                "  {patch_samples}/{sensor_samples} samples per patch/sensor: direct {t_direct:.2} s, \
                 importance {t_importance:.2} s, total {t_all:.2} s (+{:.0} % of commissioning); \
                 D {} B, importance {} B (f32); patch matrix {} B (not stored); \
                 24 suns {t_sun:.2} s ({} B as f32)",
                100.0 * t_all / commission,
                d.bytes(),
                importance.bytes(),
                direct.patch.bytes(),
                sun.len() * pts.len() * 4
            );
        }
    }
}
