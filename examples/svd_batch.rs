//! ns per SVD: the scalar `svd_rv` against `svd_rv_lanes` (four in lock-step), on the F of every
//! tet of the bench beam (4n×n×n Kuhn cubes) bent and twisted, and on random F in [−1, 1]⁹.
//!
//! `cargo run --release --example svd_batch -- 12 9` (n = 12, 9 rounds; each round times every
//! variant over all the F, the order rotating from round to round). Prints the median and the
//! fastest round of each; also checks that all give the scalar bits. One thread.
//!
//! Variants: `scalar` (`svd_rv` one F at a time), `lanes` (`svd_rv_lanes`: eigen-solves and QRs
//! four at a time).

use std::hint::black_box;
use std::time::Instant;

use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use tetsim::math::{LANES, Mat3, Svd, svd_rv, svd_rv_lanes};
use tetsim::mesh::generate::box_mesh;
use tetsim::{ElasticBody, Lame, Model, ModelKind, Vec3};

/// The beam's F under a smooth bend and twist (as in `benches/kernels.rs`).
fn beam_gradients(n: usize) -> Vec<Mat3> {
    let mesh = box_mesh(Vec3::zeros(), Vec3::new(4.0, 1.0, 1.0), [4 * n, n, n]);
    let x: Vec<Vec3> = mesh
        .positions
        .iter()
        .map(|p| {
            let a = 0.2 * p.x;
            Vec3::new(
                p.x,
                p.y * a.cos() - p.z * a.sin() - 0.05 * p.x * p.x,
                p.y * a.sin() + p.z * a.cos(),
            )
        })
        .collect();
    let model = Model::new(ModelKind::NeoHookean, Lame::from_young_poisson(1e6, 0.3));
    let body = ElasticBody::new(mesh, model, 1000.0).expect("beam");
    (0..body.tet_count())
        .map(|t| body.deformation_gradient(&x, t))
        .collect()
}

fn random_gradients(count: usize) -> Vec<Mat3> {
    let mut rng = ChaCha8Rng::seed_from_u64(99);
    (0..count)
        .map(|_| Mat3::from_fn(|_, _| rng.random_range(-1.0..1.0)))
        .collect()
}

fn scalar(fs: &[Mat3], out: &mut [Svd]) {
    for (f, o) in fs.iter().zip(out) {
        *o = svd_rv(black_box(f));
    }
}

fn batched_with(fs: &[Mat3], out: &mut [Svd], svd: fn(&[Mat3; LANES]) -> [Svd; LANES]) {
    for (f, o) in fs.chunks_exact(LANES).zip(out.chunks_exact_mut(LANES)) {
        let f: &[Mat3; LANES] = f.try_into().expect("group");
        o.copy_from_slice(&svd(black_box(f)));
    }
}

/// A variant timed: its name and the function over all F.
type Variant = (&'static str, fn(&[Mat3], &mut [Svd]));

const VARIANTS: [Variant; 2] = [
    ("scalar", scalar),
    ("lanes", |fs, out| batched_with(fs, out, svd_rv_lanes)),
];

/// ns per SVD of each variant, per round; the order of the variants rotates from round to round.
fn time(fs: &[Mat3], rounds: usize) -> Vec<Vec<f64>> {
    let mut out = vec![svd_rv(&Mat3::identity()); fs.len()];
    let mut ns = vec![Vec::new(); VARIANTS.len()];
    for round in 0..rounds {
        for i in 0..VARIANTS.len() {
            let which = (round + i) % VARIANTS.len();
            let start = Instant::now();
            (VARIANTS[which].1)(fs, &mut out);
            ns[which].push(start.elapsed().as_secs_f64() * 1e9 / fs.len() as f64);
            black_box(&out);
        }
    }
    ns
}

fn summary(label: &str, mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    let median = v[v.len() / 2];
    println!(
        "  {label:<8} median {median:7.1} ns/SVD, fastest {:7.1}",
        v[0]
    );
    median
}

fn main() {
    let mut args = std::env::args().skip(1);
    let n: usize = args.next().map_or(12, |s| s.parse().expect("n"));
    let rounds: usize = args.next().map_or(9, |s| s.parse().expect("rounds"));
    for (name, mut fs) in [
        (format!("beam n={n}"), beam_gradients(n)),
        ("random".to_string(), random_gradients(200_000)),
    ] {
        fs.truncate(fs.len() / LANES * LANES);
        let mut one = vec![svd_rv(&Mat3::identity()); fs.len()];
        let mut other = one.clone();
        scalar(&fs, &mut one);
        let bits = |s: &Svd| {
            s.u.iter()
                .chain(s.sigma.iter())
                .chain(s.v.iter())
                .map(|x| x.to_bits())
                .collect::<Vec<_>>()
        };
        let mut same = true;
        for (_, variant) in &VARIANTS[1..] {
            variant(&fs, &mut other);
            same &= one.iter().zip(&other).all(|(a, b)| bits(a) == bits(b));
        }
        println!("{name}: {} F, same bits as scalar: {same}", fs.len());
        let ns = time(&fs, rounds);
        let base = summary(VARIANTS[0].0, ns[0].clone());
        for (i, v) in ns.into_iter().enumerate().skip(1) {
            let m = summary(VARIANTS[i].0, v);
            println!("    {}/scalar {:.3}", VARIANTS[i].0, m / base);
        }
    }
}
