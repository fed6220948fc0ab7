//! The bench's roofline figures: the STREAM triad it measures, and the modelled bytes of each
//! phase (CG's vector passes, the evaluation, the assembly) its times are set against.

use std::time::Instant;

use rayon::prelude::*;

/// CG's own vector traffic per iteration, bytes per vertex: the product's input and output
/// (2 passes), the mass term and projection of the product (3), pᵀAp (2), the x and r updates
/// (5), ‖r‖ (1), the preconditioner (3), rᵀz (2) and the p update (3): 21 passes of 24 bytes,
/// plus the 0/1 mask read twice.
pub fn cg_vector_bytes_per_vertex() -> f64 {
    21.0 * 24.0 + 2.0 * 24.0
}

/// The memory inventory's parts [`phase_bytes_per_tet`] reads, by the start of their names
/// (each must name a part of the bench workload's inventory: a test checks it, so a renamed
/// part cannot silently drop out of the model).
#[cfg(test)]
pub(super) const PHASE_PARTS: [&str; 10] = [
    MESH,
    REST,
    STATE,
    FORCE_SLOTS,
    DAMPING_SLOTS,
    TANGENTS,
    ALTERNATE,
    ASSEMBLY,
    A,
    A_PATTERN,
];
const MESH: &str = "mesh: rest positions and tets";
const REST: &str = "rest data:";
const STATE: &str = "state and frame vectors";
const FORCE_SLOTS: &str = "per-tet force slots";
const DAMPING_SLOTS: &str = "per-tet damping";
const TANGENTS: &str = "per-tet tangents";
const ALTERNATE: &str = "per-tet alternate";
const ASSEMBLY: &str = "assembly:";
const A: &str = "assembled A (";
const A_PATTERN: &str = "assembled A's pattern";

/// Modelled bytes per tet per Newton iteration of the evaluation and the assembly, from the
/// sizes of the arrays they pass over (the memory inventory's parts), each counted once per
/// pass (a traffic model like CG's `B/tet/it`: gathers of vertex data that hit the cache are
/// not counted again). Evaluation: `force_passes` force passes per Newton iteration (each
/// frame's first evaluation and each line-search trial), each reading the tets, their rest
/// data and the vertex state and writing the force and K·v slots that a gather then reads;
/// plus one tangent pass that reads the same and writes every tangent (and `adaptive`'s
/// pieces). Assembly: reads every tangent, the rest data and its tet lists, and reads and
/// writes every block of A once, with its pattern.
pub fn phase_bytes_per_tet(
    memory: &crate::memory::Inventory,
    force_passes: f64,
    tets: usize,
) -> (f64, f64) {
    let part = |prefix: &str| -> f64 {
        memory
            .parts
            .iter()
            .filter(|p| p.name.starts_with(prefix))
            .map(|p| p.bytes as f64)
            .sum()
    };
    let read = part(MESH) + part(REST) + part(STATE);
    let slots = part(FORCE_SLOTS) + part(DAMPING_SLOTS);
    let tangents = part(TANGENTS) + part(ALTERNATE);
    let evaluate = force_passes * (read + 2.0 * slots) + read + tangents;
    let assembly = part(TANGENTS) + part(REST) + part(ASSEMBLY) + 2.0 * part(A) + part(A_PATTERN);
    let tets = tets.max(1) as f64;
    (evaluate / tets, assembly / tets)
}

/// STREAM triad a = b + s·c on three arrays of 2²⁵ f64 (768 MB), best of 5, in GB/s
/// (24 bytes per element, the STREAM convention).
pub fn stream_triad() -> f64 {
    let n = 1 << 25;
    let b = vec![1.0f64; n];
    let c = vec![2.0f64; n];
    let mut a = vec![0.0f64; n];
    let s = 3.0;
    let mut best = f64::INFINITY;
    for _ in 0..5 {
        let started = Instant::now();
        a.par_chunks_mut(1 << 16)
            .zip(b.par_chunks(1 << 16).zip(c.par_chunks(1 << 16)))
            .for_each(|(a, (b, c))| {
                for i in 0..a.len() {
                    a[i] = b[i] + s * c[i];
                }
            });
        best = best.min(started.elapsed().as_secs_f64());
    }
    std::hint::black_box(&a);
    24.0 * n as f64 / best / 1e9
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn phase_bytes_count_each_array_once_per_pass() {
        let mut memory = crate::memory::Inventory::default();
        for (name, bytes) in [
            ("mesh: rest positions and tets", 10),
            ("rest data: Bm, W", 20),
            ("state and frame vectors (x, v)", 30),
            ("per-tet force slots", 40),
            ("per-tet damping K·v slots", 50),
            ("per-tet tangents (U, V)", 60),
            ("per-tet alternate pieces (adaptive)", 70),
            ("assembly: the tets of each chunk of rows", 80),
            ("assembled A (f32 blocks, both triangles)", 90),
            ("assembled A's pattern", 100),
            ("CG vectors", 1000),
        ] {
            memory.add(name, bytes);
        }
        let (evaluate, assembly) = phase_bytes_per_tet(&memory, 1.5, 10);
        // Reads 60, slots 90 written and gathered, tangents 130 written.
        assert_eq!(evaluate, (1.5 * (60.0 + 180.0) + 60.0 + 130.0) / 10.0);
        // Tangents read, rest data, tet lists, A read and written, its pattern.
        assert_eq!(assembly, (60.0 + 20.0 + 80.0 + 180.0 + 100.0) / 10.0);
    }
}
