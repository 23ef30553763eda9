//! Pictures through the ceiling camera: the dense illuminance of every pixel (false colour, desk
//! outlines and means, a colour bar in lux), the reflectance the model uses at every pixel, and
//! the patch mesh as the camera sees it (drawn by plotters, DejaVu Sans).

use std::path::Path;

use glam::DVec3;

use super::{Anchor, Canvas, Colour, Label, WHITE, nice_ceiling, viridis};
use crate::commission::Commissioned;
use crate::engine::Patches;
use crate::engine::dense::{DenseField, DenseImage, DenseSettings, Pixel};
use crate::scene::{Camera, Desk};

/// Why a picture was not drawn.
#[derive(Debug, thiserror::Error)]
pub enum RenderError {
    /// The scene has no camera to look through.
    #[error("the scene has no camera")]
    NoCamera,
    /// The model could not be solved for the state shown.
    #[error("solving the model: {0}")]
    Engine(#[from] crate::engine::EngineError),
    /// The PNG could not be written.
    #[error("writing the picture: {0}")]
    Png(#[from] image::ImageError),
}

/// Pixel coordinates of a world point, if inside the lens's field.
pub fn project(cam: &Camera, p: DVec3) -> Option<(f64, f64)> {
    cam.project_world(p)
}

/// A desk to mark on a camera view: its outline and label lines.
#[derive(Debug, Clone)]
pub struct ViewDesk {
    /// The desk.
    pub desk: Desk,
    /// Label lines.
    pub label: Vec<String>,
}

/// What to draw on a camera view.
#[derive(Debug, Clone)]
pub struct ViewOptions {
    /// Title.
    pub title: String,
    /// A line under the picture.
    pub subtitle: String,
    /// Upscaling of the camera's pixels.
    pub zoom: u32,
}

const TITLE_H: u32 = 40;
const FOOT_H: u32 = 30;
const BAR_W: u32 = 110;
const LEFT: u32 = 10;

fn frame_size(img: &DenseImage, zoom: u32, bar: bool) -> (u32, u32) {
    (
        img.width * zoom + LEFT + if bar { BAR_W } else { 10 },
        img.height * zoom + TITLE_H + FOOT_H,
    )
}

/// A colour bar: top value, unit, colour map.
type Bar<'a> = (f64, &'a str, &'a dyn Fn(f64) -> Colour);

/// Draws a picture with one colour per camera pixel, its title and footnote, the desks, and a
/// colour bar if asked.
fn draw_view(
    img: &DenseImage,
    opts: &ViewOptions,
    colour_of: &dyn Fn(usize) -> Colour,
    desks: Option<(&Camera, &[ViewDesk])>,
    bar: Option<Bar<'_>>,
) -> Canvas {
    let z = opts.zoom.max(1);
    let (w, h) = frame_size(img, z, bar.is_some());
    let mut c = super::with_plotters(w, h, &mut |root, labels| {
        root.fill(&plotters::style::colors::WHITE)?;
        labels.push(Label::new(opts.title.clone(), (f64::from(LEFT), 12.0), 19.0).bold());
        labels.push(Label::new(
            opts.subtitle.clone(),
            (f64::from(LEFT), f64::from(img.height * z + TITLE_H + 8)),
            13.0,
        ));
        if let Some((max, unit, map)) = bar {
            let x = (img.width * z + LEFT + 24) as i32;
            super::draw_colour_bar(
                root,
                (
                    x,
                    TITLE_H as i32 + 10,
                    22,
                    (TITLE_H + img.height * z) as i32 - 10,
                ),
                max,
                unit,
                map,
                labels,
            )?;
        }
        Ok(())
    });
    let wpx = img.width as usize;
    for k in 0..img.pixels.len() {
        let (u, v) = ((k % wpx) as i64, (k / wpx) as i64);
        c.fill(
            i64::from(LEFT) + u * i64::from(z),
            i64::from(TITLE_H) + v * i64::from(z),
            i64::from(z),
            i64::from(z),
            colour_of(k),
        );
    }
    if let Some((cam, desks)) = desks {
        desk_overlay(&mut c, cam, desks, z);
    }
    c
}

fn desk_overlay(c: &mut Canvas, cam: &Camera, desks: &[ViewDesk], z: u32) {
    let zf = f64::from(z);
    // the image's rectangle on the canvas: outlines are clipped to it and labels kept inside
    // it (a desk half out of view would otherwise draw across the title)
    let frame = (
        f64::from(LEFT),
        f64::from(TITLE_H),
        f64::from(LEFT) + f64::from(cam.width) * zf,
        f64::from(TITLE_H) + f64::from(cam.height) * zf,
    );
    let to_px = |p: DVec3| {
        project(cam, p).map(|(u, v)| {
            (
                f64::from(LEFT) + (u + 0.5) * zf,
                f64::from(TITLE_H) + (v + 0.5) * zf,
            )
        })
    };
    for d in desks {
        let k = &d.desk;
        let cs = [
            DVec3::new(k.x_m[0], k.y_m[0], k.z_m),
            DVec3::new(k.x_m[1], k.y_m[0], k.z_m),
            DVec3::new(k.x_m[1], k.y_m[1], k.z_m),
            DVec3::new(k.x_m[0], k.y_m[1], k.z_m),
        ];
        // each edge in 16 pieces: a fisheye images straight edges as curves
        for e in 0..4 {
            let (a, b) = (cs[e], cs[(e + 1) % 4]);
            let steps = if cam.lens.is_fisheye() { 16 } else { 1 };
            for s in 0..steps {
                let p = a.lerp(b, f64::from(s) / f64::from(steps));
                let q = a.lerp(b, f64::from(s + 1) / f64::from(steps));
                if let (Some(p), Some(q)) = (to_px(p), to_px(q))
                    && let Some((p, q)) = clip_segment(p, q, frame)
                {
                    c.line(p, q, 2, WHITE);
                }
            }
        }
        let centre = DVec3::new(
            0.5 * (k.x_m[0] + k.x_m[1]),
            0.5 * (k.y_m[0] + k.y_m[1]),
            k.z_m,
        );
        if let Some((x, y)) = to_px(centre) {
            let n = d.label.len() as f64;
            // the label's block inside the image (17 px a line, 10 px to spare)
            let half = 0.5 * n * 17.0 + 2.0;
            let y = y.clamp(frame.1 + half, (frame.3 - half).max(frame.1 + half));
            for (i, line) in d.label.iter().enumerate() {
                let yy = y + (i as f64 - 0.5 * (n - 1.0)) * 17.0;
                let mut l = Label::new(line.clone(), (x, yy), 14.0)
                    .anchored(Anchor::Middle, Anchor::Middle)
                    .colour(WHITE)
                    .halo([20, 20, 20]);
                if i == 0 {
                    l = l.bold();
                }
                l.draw(c);
            }
        }
    }
}

/// The part of segment `p`-`q` inside the rectangle `(x0, y0, x1, y1)` (Liang and Barsky), or
/// `None` when none of it is.
fn clip_segment(
    p: (f64, f64),
    q: (f64, f64),
    (x0, y0, x1, y1): (f64, f64, f64, f64),
) -> Option<((f64, f64), (f64, f64))> {
    let (dx, dy) = (q.0 - p.0, q.1 - p.1);
    let (mut t0, mut t1) = (0.0f64, 1.0f64);
    for (den, num) in [
        (-dx, p.0 - x0),
        (dx, x1 - p.0),
        (-dy, p.1 - y0),
        (dy, y1 - p.1),
    ] {
        if den == 0.0 {
            if num < 0.0 {
                return None;
            }
        } else {
            let t = num / den;
            if den < 0.0 {
                t0 = t0.max(t);
            } else {
                t1 = t1.min(t);
            }
        }
    }
    (t0 <= t1).then_some((
        (p.0 + t0 * dx, p.1 + t0 * dy),
        (p.0 + t1 * dx, p.1 + t1 * dy),
    ))
}

/// Colour of a pixel that sees no reflecting surface: a luminaire opening white, nothing grey.
fn non_surface(p: &Pixel) -> Colour {
    match p {
        Pixel::Emitter(_) => [255, 255, 255],
        _ => [60, 60, 60],
    }
}

/// The dense illuminance of every pixel in false colour, with desk outlines and labels and a
/// colour bar in lux from 0 to `scale_max_lx` (0: from the picture).
pub fn lux_picture(
    img: &DenseImage,
    lux: &[f64],
    cam: &Camera,
    desks: &[ViewDesk],
    opts: &ViewOptions,
    scale_max_lx: f64,
) -> Canvas {
    let max = if scale_max_lx > 0.0 {
        scale_max_lx
    } else {
        nice_ceiling(
            lux.iter()
                .copied()
                .filter(|v| v.is_finite())
                .fold(1.0, f64::max),
        )
    };
    draw_view(
        img,
        opts,
        &|k| {
            let v = lux.get(k).copied().unwrap_or(f64::NAN);
            if v.is_finite() {
                viridis(v / max)
            } else {
                non_surface(&img.pixels[k])
            }
        },
        Some((cam, desks)),
        Some((max, "lx", &viridis)),
    )
}

/// A grey ramp for reflectances: black at 0, white at 1.
fn grey(t: f64) -> Colour {
    let g = (255.0 * t.clamp(0.0, 1.0)).round() as u8;
    [g, g, g]
}

/// The reflectance the model uses at every pixel (grey, 0 black to 1 white), with the desks.
pub fn reflectance_picture(
    img: &DenseImage,
    patches: &Patches,
    cam: &Camera,
    desks: &[ViewDesk],
    opts: &ViewOptions,
) -> Canvas {
    draw_view(
        img,
        opts,
        &|k| match img.pixels[k] {
            Pixel::Surface(s) => grey(patches.rho[s.patch as usize]),
            Pixel::Emitter(_) => [255, 196, 0],
            _ => [120, 20, 20],
        },
        Some((cam, desks)),
        Some((1.0, "ρ", &grey)),
    )
}

/// The patch mesh as the camera sees it: each patch in a light colour of its surface group,
/// patch edges dark, luminaire openings amber.
pub fn mesh_picture(img: &DenseImage, patches: &Patches, opts: &ViewOptions) -> Canvas {
    let w = img.width as usize;
    let h = img.height as usize;
    draw_view(
        img,
        opts,
        &|k| {
            let Some(p) = img.patch(k) else {
                return [60, 60, 60];
            };
            if matches!(img.pixels[k], Pixel::Emitter(_)) {
                return [255, 196, 0];
            }
            let (u, v) = (k % w, k / w);
            let edge = [(1usize, 0usize), (0, 1)].iter().any(|(du, dv)| {
                let (uu, vv) = (u + du, v + dv);
                uu < w && vv < h && img.patch(vv * w + uu) != Some(p)
            });
            if edge {
                return [30, 30, 30];
            }
            let g = patches.group.get(p as usize).copied().unwrap_or(0) as usize;
            let [r, gg, b] = super::plot::PALETTE[g % super::plot::PALETTE.len()];
            // pastel: halfway to white
            [
                ((u16::from(r) + 255) / 2) as u8,
                ((u16::from(gg) + 255) / 2) as u8,
                ((u16::from(b) + 255) / 2) as u8,
            ]
        },
        None,
        None,
    )
}

/// The commissioning picture of `luxnode commission --report`: the camera view of the all-on
/// dense illuminance with each desk's mean.
pub fn report_png(c: &Commissioned, path: &Path) -> Result<(), RenderError> {
    let Some(cam) = &c.scene.camera else {
        return Err(RenderError::NoCamera);
    };
    let field = DenseField::from_model(&c.model, &c.scene.luminaires, DenseSettings::default())?;
    let img = field.camera_view(cam)?;
    let levels = vec![1.0; c.model.luminaires()];
    let lux = img.lux(&levels)?;
    let desks: Vec<ViewDesk> = c
        .scene
        .desks
        .as_ref()
        .map(|d| {
            d.desks
                .iter()
                .map(|k| {
                    let pts: Vec<crate::engine::dense::SurfacePoint> = d
                        .grid_points
                        .iter()
                        .filter(|(id, _)| *id == k.id)
                        .filter_map(|(_, p)| field.surface_at(p.x, p.y, p.z))
                        .collect();
                    let mean = field
                        .points(&pts)
                        .lux(&levels)
                        .ok()
                        .filter(|v| !v.is_empty())
                        .map(|v| v.iter().sum::<f64>() / v.len() as f64);
                    let mut label = vec![format!("desk {}", k.id)];
                    if let Some(m) = mean {
                        label.push(format!("Ē {m:.0} lx"));
                    }
                    ViewDesk {
                        desk: k.clone(),
                        label,
                    }
                })
                .collect()
        })
        .unwrap_or_default();
    let canvas = lux_picture(
        &img,
        &lux,
        cam,
        &desks,
        &ViewOptions {
            title: format!("{}: illuminance, all luminaires at 100 %", c.scene.name),
            subtitle: "dense illuminance per camera pixel, lx (new installation); luminaire openings white"
                .into(),
            zoom: 2,
        },
        0.0,
    );
    Ok(canvas.save_png(path)?)
}

#[cfg(test)]
mod tests {
    use super::clip_segment;

    #[test]
    fn an_outline_is_clipped_to_the_image_never_across_the_title() {
        let frame = (10.0, 40.0, 650.0, 520.0);
        // a desk edge from inside the image up through the title: cut at the image's top
        let (p, q) = clip_segment((70.0, 100.0), (70.0, 0.0), frame).expect("inside part");
        assert_eq!((p, q), ((70.0, 100.0), (70.0, 40.0)));
        // wholly inside: unchanged; wholly in the title: nothing
        assert_eq!(
            clip_segment((20.0, 50.0), (600.0, 500.0), frame),
            Some(((20.0, 50.0), (600.0, 500.0)))
        );
        assert_eq!(clip_segment((20.0, 5.0), (600.0, 30.0), frame), None);
        // a diagonal across a corner: both ends on the frame
        let (p, q) = clip_segment((0.0, 30.0), (30.0, 60.0), frame).expect("corner");
        assert!(
            (p.0 - 10.0).abs() < 1e-12 && (p.1 - 40.0).abs() < 1e-12,
            "{p:?}"
        );
        assert_eq!(q, (30.0, 60.0));
    }
}
