//! The fuzz targets' bodies (fuzz/bodies.rs) on stable: every target runs on every input of its
//! committed corpus (fuzz/corpus/<target>/) and on deterministic mutations of them (bit flips,
//! boundary bytes, truncation, duplication, splices), so each decoder is exercised in every
//! test run even where the nightly toolchain for coverage-guided fuzzing (scripts/fuzz.sh) is
//! missing. A panic anywhere fails the test and names the target and the input's origin.

#[path = "../fuzz/bodies.rs"]
mod bodies;

use std::path::Path;

/// Mutations per corpus input (each target runs its seeds plus this many variants of each).
const MUTATIONS: usize = 300;

struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }
    fn below(&mut self, n: usize) -> usize {
        (self.next() % n.max(1) as u64) as usize
    }
}

fn mutate(seed: &[u8], other: &[u8], rng: &mut Rng) -> Vec<u8> {
    let mut v = seed.to_vec();
    for _ in 0..1 + rng.below(4) {
        match rng.below(6) {
            0 if !v.is_empty() => {
                let i = rng.below(v.len());
                v[i] ^= 1 << rng.below(8);
            }
            1 if !v.is_empty() => {
                let i = rng.below(v.len());
                v[i] = [0, 1, 0x7F, 0x80, 0xFF, b'9', b'-', b'.'][rng.below(8)];
            }
            2 => v.truncate(rng.below(v.len() + 1)),
            3 if !v.is_empty() => {
                let (a, b) = (rng.below(v.len()), rng.below(v.len()));
                let (a, b) = (a.min(b), a.max(b));
                let chunk = v[a..b].to_vec();
                v.splice(b..b, chunk);
            }
            4 if !other.is_empty() => {
                let i = rng.below(v.len() + 1);
                let j = rng.below(other.len());
                v.truncate(i);
                v.extend_from_slice(&other[j..]);
            }
            _ => {
                let i = rng.below(v.len() + 1);
                v.insert(i, rng.next() as u8);
            }
        }
    }
    v
}

#[test]
fn every_fuzz_target_runs_on_its_corpus_and_mutations() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("fuzz/corpus");
    let mut summary = Vec::new();
    for (name, body) in bodies::TARGETS {
        let dir = root.join(name);
        let mut seeds: Vec<(String, Vec<u8>)> = std::fs::read_dir(&dir)
            .unwrap_or_else(|e| panic!("{name}: no corpus at {}: {e}", dir.display()))
            .map(|e| {
                let p = e.unwrap().path();
                (p.display().to_string(), std::fs::read(&p).unwrap())
            })
            .collect();
        seeds.sort();
        assert!(!seeds.is_empty(), "{name}: empty corpus");
        let mut rng = Rng(0x5EED ^ name.len() as u64);
        let mut runs = 0usize;
        for (k, (origin, seed)) in seeds.iter().enumerate() {
            let r = std::panic::catch_unwind(|| body(seed));
            assert!(r.is_ok(), "{name} panicked on {origin}");
            runs += 1;
            let other = &seeds[(k + 1) % seeds.len()].1;
            for m in 0..MUTATIONS {
                let input = mutate(seed, other, &mut rng);
                let r = std::panic::catch_unwind(|| body(&input));
                assert!(
                    r.is_ok(),
                    "{name} panicked on mutation {m} of {origin}: {:02x?}",
                    &input[..input.len().min(64)]
                );
                runs += 1;
            }
        }
        summary.push(format!("{name}: {runs}"));
    }
    assert_eq!(summary.len(), 12, "{summary:?}");
    eprintln!("fuzz smoke, inputs per target: {}", summary.join(", "));
}
