use super::*;

/// The tip figure is the far face's mean displacement: zero at rest, downward once the
/// beam has drooped for a few frames, and the same whatever the vertex order.
#[test]
fn tip_is_the_far_face_mean_displacement() {
    let tip_after = |frames: usize, reorder: VertexOrder| {
        let scene = workload_scene(2, frames.max(1), "", reorder, 1).unwrap();
        let mut sim = Simulation::from_scene(&scene).unwrap();
        for _ in 0..frames {
            sim.step().unwrap();
        }
        tip_displacement(&sim)
    };
    assert_eq!(tip_after(0, VertexOrder::default()), [0.0; 3]);
    // Every part the phase byte model reads is in the workload's inventory.
    let scene = workload_scene(2, 1, "", VertexOrder::default(), 1).unwrap();
    let mut sim = Simulation::from_scene(&scene).unwrap();
    sim.step().unwrap();
    let memory = sim.memory_inventory();
    for prefix in roofline::PHASE_PARTS {
        assert!(
            memory.parts.iter().any(|p| p.name.starts_with(prefix)),
            "no part {prefix:?} in {:?}",
            memory.parts.iter().map(|p| &p.name).collect::<Vec<_>>()
        );
    }
    let tip = tip_after(3, VertexOrder::default());
    assert!(tip[1] < -1e-3, "the tip should fall: {tip:?}");
    let shuffled = tip_after(3, VertexOrder::Random);
    for k in 0..3 {
        assert!(
            (tip[k] - shuffled[k]).abs() <= 1e-3 * tip[1].abs(),
            "{tip:?} {shuffled:?}"
        );
    }
}
