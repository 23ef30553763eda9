//! Greg Ward's 1990 empty grey room, the radiosity benchmark of the globillum mailing list
//! ("example calculation", 9 Oct 1990; the Radiance test suite's `tests/empty/diffuse/grey`):
//! a 10 × 6 × 3 m room, a 0.5 × 0.5 m Lambertian source of exitance 31.416 W/m² at the centre
//! of the ceiling (reflectance 0), ceiling 0.70, walls 0.50, floor 0.30. The points on the
//! ceiling receive interreflected light only: they test the engine's interreflection alone.
//!
//! References: Ward's published ceiling radiosities (20 points, 3 significant digits, "most
//! within 1 %, a few up to 5 %"), and Radiance at high accuracy at the 60 ceiling points of one
//! quarter (`bench/radiance/ward.py`, `bench/radiance/results/ward_radiance.csv`; Radiance vs
//! Ward: +0.21 % mean). Illuminance at a ceiling point is B / ρ_ceiling. Watts stand for lumens
//! (everything is linear).
mod common;

use std::f64::consts::{FRAC_PI_2, PI};

use common::{luminaire, scene};
use glam::DVec3;
use luxnode::engine::{self, Settings, direct};
use luxnode::lsc::AngularResponse;
use luxnode::scene::{MeshBuilder, Scene, Sensor};

const LX_M: f64 = 10.0;
const LY_M: f64 = 6.0;
const LZ_M: f64 = 3.0;
const RHO_CEILING: f64 = 0.7;
const SOURCE_EXITANCE: f64 = 31.416;

/// Ward's table: ceiling (x m, y m, radiosity W/m²).
const WARD_CEILING: [(f64, f64, f64); 20] = [
    (0.25, 0.25, 0.0113),
    (0.25, 0.75, 0.0131),
    (0.25, 1.25, 0.0140),
    (0.25, 1.75, 0.0149),
    (0.25, 2.25, 0.0151),
    (0.25, 2.75, 0.0155),
    (0.75, 0.25, 0.0131),
    (0.75, 0.75, 0.0150),
    (0.75, 1.25, 0.0162),
    (0.75, 1.75, 0.0168),
    (0.75, 2.25, 0.0173),
    (0.75, 2.75, 0.0177),
    (1.25, 0.25, 0.0147),
    (1.25, 0.75, 0.0166),
    (1.25, 1.25, 0.0177),
    (1.25, 1.75, 0.0185),
    (1.25, 2.25, 0.0189),
    (1.25, 2.75, 0.0191),
    (1.75, 0.25, 0.0163),
    (1.75, 0.75, 0.0184),
];

/// Radiance's ceiling radiosities (x, y, B W/m², standard error W/m²).
fn radiance_ceiling() -> Vec<(f64, f64, f64, f64)> {
    let path = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/bench/radiance/results/ward_radiance.csv"
    );
    let text = std::fs::read_to_string(path).expect("bench/radiance/results/ward_radiance.csv");
    let rows: Vec<(f64, f64, f64, f64)> = text
        .lines()
        .filter(|l| l.starts_with("ceiling,"))
        .map(|l| {
            let f: Vec<f64> = l.split(',').skip(1).map(|v| v.parse().unwrap()).collect();
            (f[0], f[1], f[3], f[4])
        })
        .collect();
    assert_eq!(rows.len(), 60, "60 ceiling points in the Radiance table");
    rows
}

/// Ward's room with ceiling sensors (facing down) at `points`.
fn ward_scene(points: &[(f64, f64)]) -> Scene {
    let p = DVec3::new;
    let mut b = MeshBuilder::new();
    let ceiling = b.material("ceiling", RHO_CEILING).unwrap();
    let wall = b.material("wall", 0.5).unwrap();
    let floor = b.material("floor", 0.3).unwrap();
    let black = b.material("source", 0.0).unwrap();
    let (lx, ly, lz) = (LX_M, LY_M, LZ_M);
    b.quad(
        [p(0., 0., 0.), p(lx, 0., 0.), p(lx, ly, 0.), p(0., ly, 0.)],
        "floor",
        floor,
    );
    b.quad(
        [p(0., 0., 0.), p(0., 0., lz), p(lx, 0., lz), p(lx, 0., 0.)],
        "wall_s",
        wall,
    );
    b.quad(
        [p(lx, ly, 0.), p(lx, ly, lz), p(0., ly, lz), p(0., ly, 0.)],
        "wall_n",
        wall,
    );
    b.quad(
        [p(0., ly, 0.), p(0., ly, lz), p(0., 0., lz), p(0., 0., 0.)],
        "wall_w",
        wall,
    );
    b.quad(
        [p(lx, 0., 0.), p(lx, 0., lz), p(lx, ly, lz), p(lx, ly, 0.)],
        "wall_e",
        wall,
    );
    // the ceiling around the source's 0.5 m square, facing down
    let (x0, x1, y0, y1) = (4.75, 5.25, 2.75, 3.25);
    let down =
        |a: f64, b: f64, c: f64, d: f64| [p(a, d, lz), p(b, d, lz), p(b, c, lz), p(a, c, lz)];
    b.quad(down(0., x0, 0., ly), "ceiling", ceiling);
    b.quad(down(x1, lx, 0., ly), "ceiling", ceiling);
    b.quad(down(x0, x1, 0., y0), "ceiling", ceiling);
    b.quad(down(x0, x1, y1, ly), "ceiling", ceiling);
    b.quad(down(x0, x1, y0, y1), "luminaire_1", black);
    // Lambertian: I(γ) = L A cos γ, L = M / π
    let i0_cd = SOURCE_EXITANCE / PI * 0.25;
    let l = luminaire(1, p(5.0, 3.0, lz), [0.5, 0.5], false, move |g: f64| {
        if g < FRAC_PI_2 { i0_cd * g.cos() } else { 0.0 }
    });
    let sensors = points
        .iter()
        .enumerate()
        .map(|(k, &(x, y))| Sensor {
            id: k as u32 + 1,
            position_m: p(x, y, lz),
            normal: DVec3::NEG_Z,
            note: String::new(),
            response: AngularResponse::Cosine,
        })
        .collect();
    scene(b.build(), vec![l], sensors)
}

/// (mean |error|, mean signed error) of `lux` against `reference_lx`, relative.
fn errors(lux: &[f64], reference_lx: &[f64]) -> (f64, f64) {
    let n = lux.len() as f64;
    let rel: Vec<f64> = lux
        .iter()
        .zip(reference_lx)
        .map(|(a, b)| (a - b) / b)
        .collect();
    (
        rel.iter().map(|e| e.abs()).sum::<f64>() / n,
        rel.iter().sum::<f64>() / n,
    )
}

fn settings_from_env() -> Settings {
    let mut s = Settings::default();
    let get = |k: &str| std::env::var(k).ok().and_then(|v| v.parse::<f64>().ok());
    if let Some(v) = get("WARD_RAYS") {
        s.rays = v as usize;
    }
    if let Some(v) = get("WARD_PATCH") {
        s.patches.patch_size_m = v;
    }
    if let Some(v) = get("WARD_FG") {
        s.final_gather_rays = v as usize;
    }
    if let Some(v) = get("WARD_SEED") {
        s.seed = v as u64;
    }
    s
}

#[test]
fn ward_grey_room_ceiling() {
    let radiance = radiance_ceiling();
    let points: Vec<(f64, f64)> = radiance.iter().map(|r| (r.0, r.1)).collect();
    let sc = ward_scene(&points);
    let model = engine::compute_model(&sc, &settings_from_env()).unwrap();
    let lux = model.sensor_lux(&[1.0]).unwrap();
    let rad_lx: Vec<f64> = radiance.iter().map(|r| r.2 / RHO_CEILING).collect();
    let (mut ward_lux, mut ward_lx) = (Vec::new(), Vec::new());
    println!("   x     y   | Ward B   Radiance B | luxnode B | vs Ward | vs Radiance");
    for (k, r) in radiance.iter().enumerate() {
        let b = lux[k] * RHO_CEILING;
        let ward = WARD_CEILING
            .iter()
            .find(|w| (w.0 - r.0).abs() < 1e-9 && (w.1 - r.1).abs() < 1e-9);
        let vs_ward = ward.map_or(String::new(), |w| {
            ward_lux.push(lux[k]);
            ward_lx.push(w.2 / RHO_CEILING);
            format!("{:+6.2} %", 100.0 * (b - w.2) / w.2)
        });
        println!(
            "{:5.2} {:5.2} | {:7} {:.6} | {:.6} | {:>8} | {:+6.2} %",
            r.0,
            r.1,
            ward.map_or(String::new(), |w| format!("{:.4}", w.2)),
            r.2,
            b,
            vs_ward,
            100.0 * (b - r.2) / r.2
        );
    }
    let (w_abs, w_signed) = errors(&ward_lux, &ward_lx);
    let (r_abs, r_signed) = errors(&lux, &rad_lx);
    println!(
        "against Ward's table (20 points): mean |error| {:.2} %, mean signed {:+.2} %",
        100.0 * w_abs,
        100.0 * w_signed
    );
    println!(
        "against Radiance (60 points): mean |error| {:.2} %, mean signed {:+.2} %",
        100.0 * r_abs,
        100.0 * r_signed
    );
    // Before the fix: 2.95 % mean |error| and +2.95 % bias against Ward's table. Now (default
    // settings, seed 1): 0.71 % and +0.68 % against Ward, whose 3-digit values sit 0.21 % below
    // Radiance on average; 0.27 % and +0.25 % against Radiance. Issue 13's targets: mean |error|
    // <= 1 % and |bias| <= 0.5 %: met against Radiance; against Ward's rounded table the bias
    // is 0.68 % (docs/accuracy.md).
    assert!(w_abs <= 0.01, "Ward: mean |error| {w_abs}");
    assert!(
        w_signed.abs() <= 0.008,
        "Ward: mean signed error {w_signed}"
    );
    assert!(r_abs <= 0.004, "Radiance: mean |error| {r_abs}");
    assert!(
        r_signed.abs() <= 0.004,
        "Radiance: mean signed error {r_signed}"
    );
}

/// Direct illuminance on the floor, wall or ceiling plane at `y` (unit normal `n`) from Ward's
/// source, by 16 × 16 Lambertian sub-squares (L = M / π; the far field of each is exact to
/// (0.031 m / d)²).
fn source_direct_w_m2(y: DVec3, n: DVec3) -> f64 {
    let l = SOURCE_EXITANCE / PI;
    let k = 16;
    let da = (0.5 / k as f64).powi(2);
    let mut e = 0.0;
    for i in 0..k {
        for j in 0..k {
            let q = DVec3::new(
                4.75 + (i as f64 + 0.5) * 0.5 / k as f64,
                2.75 + (j as f64 + 0.5) * 0.5 / k as f64,
                LZ_M,
            );
            let v = q - y;
            let d2 = v.length_squared();
            let d = d2.sqrt();
            let cos_source = (v.z / d).max(0.0);
            let cos_receiver = (n.dot(v) / d).max(0.0);
            e += l * cos_source * cos_receiver / d2 * da;
        }
    }
    e
}

/// The first bounce at a ceiling point by midpoint quadrature over floor and walls (cells of
/// `h` m): `E1(x) = Σ ρ(y) E_dir(y) / π · cos θ_x cos θ_y / d² · h²`. Also returns the flux the
/// quadrature puts on floor and walls (the source's, 7.854 W, when it is fine enough).
fn first_bounce_quadrature(points: &[(f64, f64)], h: f64) -> (Vec<f64>, f64) {
    // (origin, u axis, v axis, extents, normal, rho)
    let planes = [
        (DVec3::ZERO, DVec3::X, DVec3::Y, (LX_M, LY_M), DVec3::Z, 0.3),
        (DVec3::ZERO, DVec3::X, DVec3::Z, (LX_M, LZ_M), DVec3::Y, 0.5),
        (
            DVec3::new(0., LY_M, 0.),
            DVec3::X,
            DVec3::Z,
            (LX_M, LZ_M),
            DVec3::NEG_Y,
            0.5,
        ),
        (DVec3::ZERO, DVec3::Y, DVec3::Z, (LY_M, LZ_M), DVec3::X, 0.5),
        (
            DVec3::new(LX_M, 0., 0.),
            DVec3::Y,
            DVec3::Z,
            (LY_M, LZ_M),
            DVec3::NEG_X,
            0.5,
        ),
    ];
    let mut out = vec![0.0; points.len()];
    let mut flux = 0.0;
    for (o, u, v, (a, b), n, rho) in planes {
        let (nu, nv) = ((a / h).round() as usize, (b / h).round() as usize);
        for i in 0..nu {
            for j in 0..nv {
                let y = o + u * ((i as f64 + 0.5) * h) + v * ((j as f64 + 0.5) * h);
                let e = source_direct_w_m2(y, n);
                flux += e * h * h;
                let b_y = rho * e;
                for (k, &(px, py)) in points.iter().enumerate() {
                    let w = y - DVec3::new(px, py, LZ_M);
                    let d2 = w.length_squared();
                    let d = d2.sqrt();
                    let cx = (-w.z / d).max(0.0);
                    let cy = (-n.dot(w) / d).max(0.0);
                    out[k] += b_y / PI * cx * cy / d2 * h * h;
                }
            }
        }
    }
    (out, flux)
}

#[test]
fn ward_first_bounce_against_quadrature() {
    // The final gather's first bounce (exact direct light at its hit points) at four ceiling
    // points against an independent quadrature. Before the fix it read 3.7-3.9 % high at every
    // point (the opening's sample points leaned toward the room's origin corner).
    let points = [(0.25, 0.25), (0.25, 0.75), (1.25, 1.25), (1.75, 0.75)];
    let (quad, flux) = first_bounce_quadrature(&points, 0.05);
    assert!(
        (flux - SOURCE_EXITANCE * 0.25).abs() < 2e-3 * flux,
        "quadrature: {flux} W on the floor and walls"
    );
    let sc = ward_scene(&points);
    for (fg_rays, bound) in [(10_000, 0.003), (1000, 0.01)] {
        let s = Settings {
            final_gather_rays: fg_rays,
            ..Settings::default()
        };
        let m = engine::compute_model(&sc, &s).unwrap();
        for (k, q) in quad.iter().enumerate() {
            let fb = m.first_bounce_sensor_lx[k][0];
            println!(
                "{fg_rays} rays, ({}, {}): first bounce {fb:.6}, quadrature {q:.6}, {:+.2} %",
                points[k].0,
                points[k].1,
                100.0 * (fb - q) / q
            );
            assert!((fb - q).abs() <= bound * q, "{fb} vs {q}");
        }
    }
}

#[test]
fn centred_opening_points_put_the_source_where_it_is() {
    // The far field of a 0.5 m Lambertian square at a floor point 5.6 m aside and 3 m below:
    // closed form πL F (Howell B-3 by corner superposition), against the engine's direct light
    // with few opening points.
    let sc = ward_scene(&[]);
    let l = &sc.luminaires[0];
    let caster = engine::raycast::RayCaster::new(&engine::patches::subdivide(
        &sc.mesh,
        &engine::PatchSettings::default(),
        &[],
        &mut |_| false,
    ));
    let x = DVec3::new(0.25, 0.25, 0.0);
    let b3 = |a: f64, b: f64| common::b3(a, b, LZ_M);
    // the corner rectangles from x's foot: [4.75, 5.25] x [2.75, 3.25] seen from (0.25, 0.25)
    let f = b3(5.0, 3.0) - b3(4.5, 3.0) - b3(5.0, 2.5) + b3(4.5, 2.5);
    let exact = SOURCE_EXITANCE * f;
    for m in [2usize, 4, 5, 8, 16, 64] {
        let pts = direct::centred_opening_points(l, m);
        let centroid = pts.iter().copied().sum::<DVec3>() / pts.len() as f64;
        assert!((centroid - l.position_m).length() < 1e-12, "m = {m}");
        let e = direct::illuminance_lx(l, &pts, x, DVec3::Z, direct::Receiver::Surface, &caster);
        let old = direct::illuminance_lx(
            l,
            &direct::opening_points(l, m),
            x,
            DVec3::Z,
            direct::Receiver::Surface,
            &caster,
        );
        println!(
            "{m} points: centred {:+.3} %, plain R2 {:+.3} %",
            100.0 * (e - exact) / exact,
            100.0 * (old - exact) / exact
        );
        assert!((e - exact).abs() < 0.004 * exact, "m = {m}: {e} vs {exact}");
    }
}
