//! Where the time per ray goes in the form-factor stage: a micro benchmark on a sample of
//! patches, one thread, each sub-stage timed alone over the same rays (`luxnode bench
//! scaling` prints it beside the stage times).
//!
//! Sub-stages, per ray: generation (origin on the patch, direction turned into the patch's
//! frame, both into the caster's f32 frame), BVH traversal with the caster's triangle test, the
//! hit's patch lookup and face test, and accumulation into the row. The BVH's own rate is the
//! same traversal with obvhs' own triangle test on the same rays; the whole stage is the
//! form-factor code itself ([`super::formfactor::compute`]'s per-patch work) on those patches.

use std::hint::black_box;
use std::time::Instant;

use obvhs::ray::Ray;

use super::formfactor::{Tally, cast_patch, for_each_ray};
use super::patches::Patches;
use super::raycast::{Hit, RayCaster};
use super::rayset::RaySet;

/// Microseconds per ray of each sub-stage (one thread).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct RayProfile {
    /// Patches sampled.
    pub patches: usize,
    /// Rays traced per sub-stage.
    pub rays: usize,
    /// Ray generation.
    pub generation_us: f64,
    /// BVH traversal with the caster's triangle test.
    pub traversal_us: f64,
    /// The hit's patch lookup and face test.
    pub lookup_us: f64,
    /// Accumulation into the rows.
    pub accumulation_us: f64,
    /// The whole per-patch stage (generation to row), as the form-factor stage runs it.
    pub stage_us: f64,
    /// The BVH's own rate: obvhs' traversal with its own triangle test, same rays.
    pub bvh_own_us: f64,
}

/// Times each sub-stage on `sample` patches spread evenly over the patch list.
pub fn profile(
    patches: &Patches,
    caster: &RayCaster,
    rays: &RaySet,
    seed: u64,
    sample: usize,
) -> RayProfile {
    let n = patches.len();
    let ids: Vec<usize> = (0..sample.min(n))
        .map(|k| k * n / sample.min(n).max(1))
        .filter(|&i| patches.area_m2[i] > 0.0)
        .collect();
    let per_ray = |t: Instant, count: usize| t.elapsed().as_secs_f64() * 1e6 / count.max(1) as f64;

    let t = Instant::now();
    let mut frame_rays: Vec<Ray> = Vec::with_capacity(ids.len() * rays.len());
    for &i in &ids {
        for_each_ray(patches, caster, rays, seed, i, |r| frame_rays.push(*r));
    }
    let generation_us = per_ray(t, frame_rays.len());
    let m = frame_rays.len();

    let t = Instant::now();
    let own = frame_rays
        .iter()
        .filter(|r| caster.trace_obvhs(r).is_some());
    black_box(own.count());
    let bvh_own_us = per_ray(t, m);

    let t = Instant::now();
    let traced: Vec<Option<(u32, f32)>> = frame_rays.iter().map(|r| caster.trace(r)).collect();
    let traversal_us = per_ray(t, m);

    let t = Instant::now();
    let hits: Vec<Hit> = traced
        .iter()
        .zip(&frame_rays)
        .map(|(h, r)| caster.hit(*h, r))
        .collect();
    let lookup_us = per_ray(t, m);

    let mut counts = vec![0u32; n];
    let t = Instant::now();
    for (&i, patch_hits) in ids.iter().zip(hits.chunks(rays.len().max(1))) {
        let mut tally = Tally::new(i, &mut counts);
        for h in patch_hits {
            tally.add(*h);
        }
        black_box(tally.finish(rays.len()).hits.len());
    }
    let accumulation_us = per_ray(t, m);

    let t = Instant::now();
    for &i in &ids {
        black_box(
            cast_patch(patches, caster, rays, seed, i, &mut counts)
                .hits
                .len(),
        );
    }
    let stage_us = per_ray(t, m);

    RayProfile {
        patches: ids.len(),
        rays: m,
        generation_us,
        traversal_us,
        lookup_us,
        accumulation_us,
        stage_us,
        bvh_own_us,
    }
}
