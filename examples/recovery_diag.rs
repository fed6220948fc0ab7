//! Diagnosis of inversion recovery from tangled starts: one run frame by frame, or a
//! sweep over starts, seeds and meshes that counts the runs left folded.
//!
//! One run, printing energy, inverted tets, smallest stretch and distance from rest:
//! `cargo run --release --example recovery_diag -- model=nhc mesh=beam start=line jitter=1`
//! A sweep (every start; seeds other than 7 only for the jittered and scrambled starts):
//! `cargo run --release --example recovery_diag -- model=nhc start=all meshes=beam,beam4,beam8,beam632 seeds=7,1,2,3,4,5,6,8`
//!
//! Keys (`key=value`): model nh|nhc|co|mr (nh: `neo-hookean`, nhc: `neo-hookean-clamped`), mesh beam|beam4|beam8|beam632|ball|ball4|ball5|tetgen (cells=N
//! for ball; tetgen: the TetGen ball fixture), start plane|line|point|scrambled|all, jitter 0|1, seed, frames, E, nu, rec (the
//! recovery threshold of tangled elements, 0: off; model=rec is the recovery form alone), eps (the
//! Neo-Hookean inversion threshold), gamma, def (definiteness), pc amg|jacobi|none, every,
//! first, dump=FILE, dumpat=N dumpstate=FILE, loadstate=FILE, switch=N model2=co (change the
//! material at frame N). Runs end early once settled; "recovered" means < 0.05 mean edges
//! from rest after rigid alignment, as in tests/simulate.rs.
#[path = "../tests/common/mod.rs"]
mod common;

use common::{Collapse, carved_ball, rigid_distance};
use tetsim::boundary::Boundary;
use tetsim::integrator::SolverParams;
use tetsim::material::{Corotated, Invertible, NeoHookean};
use tetsim::math::svd_rv;
use tetsim::{Definiteness, ElasticBody, Lame, Mat3, Model, Simulation, State, Vec3};

fn inside(p: &Vec3, t: &[Vec3; 4]) -> bool {
    let ds = Mat3::from_columns(&[t[1] - t[0], t[2] - t[0], t[3] - t[0]]);
    match ds.try_inverse() {
        Some(inv) => {
            let b = inv * (p - t[0]);
            b.iter().all(|&c| c > 1e-6) && b.sum() < 1.0 - 1e-6
        }
        None => false,
    }
}

fn main() {
    env_logger::init();
    let mut opts = std::collections::HashMap::new();
    for a in std::env::args().skip(1) {
        let (k, v) = a.split_once('=').unwrap();
        opts.insert(k.to_string(), v.to_string());
    }
    if opts.get("start").map(|s| s == "all").unwrap_or(false) {
        let mut worst: f64 = 0.0;
        let mut fails = 0;
        let mut total = 0;
        let mut line = String::new();
        let seeds = opts.get("seeds").cloned().unwrap_or("7".into());
        let meshes = opts
            .get("meshes")
            .cloned()
            .unwrap_or(opts.get("mesh").cloned().unwrap_or("beam".into()));
        for mesh in meshes.split(',') {
            for seed in seeds.split(',') {
                for start in Collapse::ALL.map(Collapse::name) {
                    for jitter in ["0", "1"] {
                        if jitter == "0" && seed != "7" && start != "scrambled" {
                            continue;
                        }
                        let mut o = opts.clone();
                        o.insert("seed".into(), seed.into());
                        o.insert("mesh".into(), mesh.into());
                        o.insert("start".into(), start.into());
                        o.insert("jitter".into(), jitter.into());
                        o.insert("every".into(), "100000".into());
                        o.insert("first".into(), "0".into());
                        o.insert("quiet".into(), "1".into());
                        let t = std::time::Instant::now();
                        let d = run(o);
                        worst = worst.max(d);
                        total += 1;
                        if d.is_nan() || d >= 0.05 {
                            fails += 1;
                            line += &format!(" {mesh}/{start}/{jitter}/{seed}={d:.2}");
                        }
                        if opts.contains_key("verbose") {
                            println!(
                                "{mesh} {seed} {start:9} jitter {jitter}: {d:.4} edges {:.1} s",
                                t.elapsed().as_secs_f64()
                            );
                        }
                    }
                }
            }
        }
        println!("fails {fails}/{total} worst {worst:.3}:{line}");
        return;
    }
    run(opts);
}

fn run(opts: std::collections::HashMap<String, String>) -> f64 {
    let get = |k: &str, d: &str| opts.get(k).cloned().unwrap_or(d.to_string());
    let mesh = match get("mesh", "beam").as_str() {
        "beam" => {
            tetsim::mesh::generate::box_mesh(Vec3::zeros(), Vec3::new(3.0, 1.0, 1.0), [6, 2, 2])
        }
        "ball" => carved_ball(1.0, get("cells", "6").parse().unwrap()),
        "beam4" => {
            tetsim::mesh::generate::box_mesh(Vec3::zeros(), Vec3::new(2.0, 1.0, 1.0), [4, 2, 2])
        }
        "beam8" => {
            tetsim::mesh::generate::box_mesh(Vec3::zeros(), Vec3::new(4.0, 1.0, 1.0), [8, 2, 2])
        }
        "beam632" => {
            tetsim::mesh::generate::box_mesh(Vec3::zeros(), Vec3::new(3.0, 1.5, 1.0), [6, 3, 2])
        }
        "ball5" => carved_ball(1.0, 5),
        "ball4" => carved_ball(1.0, 4),
        "tetgen" => {
            let fixture =
                std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures/ball.node");
            tetsim::io::read_mesh(&fixture).unwrap().mesh
        }
        other => panic!("{other}"),
    };
    let lame = Lame::from_young_poisson(
        get("E", "1e5").parse().unwrap(),
        get("nu", "0.3").parse().unwrap(),
    );
    let default_eps = tetsim::material::DEFAULT_INVERSION_THRESHOLD.to_string();
    let eps: f64 = get("eps", &default_eps).parse().unwrap();
    let eps2: f64 = get("eps2", &get("eps", &default_eps)).parse().unwrap();
    let default_rec = tetsim::material::DEFAULT_RECOVERY_THRESHOLD.to_string();
    let rec: f64 = get("rec", &default_rec).parse().unwrap();
    let make = |name: &str| match name {
        "nh" => Model::NeoHookean(Invertible::new(NeoHookean::with_threshold(lame, eps))),
        "nhc" => Model::NeoHookeanClamped(Invertible::new(NeoHookean::clamped_with_threshold(
            lame, eps,
        ))),
        "nhc2" => Model::NeoHookeanClamped(Invertible::new(NeoHookean::clamped_with_threshold(
            lame, eps2,
        ))),
        "rec" => Model::NeoHookeanClamped(Invertible::new(NeoHookean::recovery(lame, rec))),
        "co" => Model::Corotated(Invertible::new(Corotated::new(lame))),
        "mr" => Model::with_threshold(tetsim::material::ModelKind::MooneyRivlin, lame, eps),
        other => panic!("{other}"),
    };
    let with_recovery = |mut body: ElasticBody| {
        body.set_recovery_threshold(0, rec);
        body
    };
    let model = make(&get("model", "nh"));
    let switch: usize = get("switch", "0").parse().unwrap();
    let edge = mesh.mean_edge_length();
    let jitter = if get("jitter", "1") == "1" {
        1e-3 * edge
    } else {
        0.0
    };
    let start = get("start", "line");
    let collapse = Collapse::ALL
        .into_iter()
        .find(|c| c.name() == start)
        .unwrap_or_else(|| panic!("start={start}: plane, line, point or scrambled"));
    let x0 = collapse.apply(&mesh.positions, jitter, get("seed", "7").parse().unwrap());
    let body = with_recovery(ElasticBody::new(mesh.clone(), model, 1000.0).unwrap());
    let n = x0.len();
    let mut initial = State {
        v: vec![Vec3::zeros(); n],
        x: x0,
        t: 0.0,
    };
    if let Some(path) = opts.get("loadstate") {
        let text = std::fs::read_to_string(path).unwrap();
        let nums: Vec<f64> = text
            .split_whitespace()
            .map(|w| w.parse().unwrap())
            .collect();
        for i in 0..n {
            initial.x[i] = Vec3::new(nums[6 * i], nums[6 * i + 1], nums[6 * i + 2]);
            initial.v[i] = Vec3::new(nums[6 * i + 3], nums[6 * i + 4], nums[6 * i + 5]);
        }
    }
    let frames: usize = get("frames", "300").parse().unwrap();
    let mut params = SolverParams {
        frames,
        rayleigh_stiffness: get("gamma", "0.02").parse().unwrap(),
        substeps: get("substeps", "1").parse().unwrap(),
        line_search: get("ls", "1") == "1",
        definiteness: Definiteness::from_name(&get("def", "adaptive")).unwrap(),
        preconditioner: match get("pc", "amg").as_str() {
            "amg" => tetsim::integrator::PreconditionerKind::Amg,
            "jacobi" => tetsim::integrator::PreconditionerKind::Jacobi,
            _ => tetsim::integrator::PreconditionerKind::Identity,
        },
        ..Default::default()
    };
    let every: usize = get("every", "10").parse().unwrap();
    let mut sim = Simulation::new(body, Boundary::default(), params.clone(), initial).unwrap();
    let mut base = 0;
    let mut last_d = f64::INFINITY;
    while !sim.is_finished() {
        if switch > 0 && sim.frame() == switch && base == 0 {
            base = switch;
            params.frames = frames - switch;
            let body = with_recovery(
                ElasticBody::new(mesh.clone(), make(&get("model2", "co")), 1000.0).unwrap(),
            );
            let state = sim.state.clone();
            sim = Simulation::new(body, Boundary::default(), params.clone(), state).unwrap();
            if sim.is_finished() {
                break;
            }
        }
        if let Some(k) = opts.get("dumpat")
            && sim.frame() == k.parse::<usize>().unwrap()
        {
            let text: String = sim
                .state
                .x
                .iter()
                .zip(&sim.state.v)
                .map(|(x, v)| format!("{} {} {} {} {} {}\n", x.x, x.y, x.z, v.x, v.y, v.z))
                .collect();
            std::fs::write(opts.get("dumpstate").unwrap(), text).unwrap();
        }
        let mut s = sim.step().unwrap();
        s.frame += base;
        if opts.contains_key("quiet") && s.frame.is_multiple_of(25) {
            let d = rigid_distance(&mesh.positions, &sim.state.x) / edge;
            if s.frame >= 100
                && (d - last_d).abs() < 1e-3
                && s.inverted_elements == 0
                && (d < 0.02 || s.frame >= 200)
            {
                break;
            }
            last_d = d;
        }
        if s.frame.is_multiple_of(every) || s.frame <= get("first", "10").parse().unwrap() {
            let x = &sim.state.x;
            let mut min_s = f64::INFINITY;
            let mut below = 0;
            for t in 0..sim.body.tet_count() {
                let f = sim.body.deformation_gradient(x, t);
                let sv = svd_rv(&f).sigma;
                min_s = min_s.min(sv[2]);
                if sv[2] < eps {
                    below += 1;
                }
            }
            println!(
                "f {:4} E {:10.4e} KE {:10.3e} inv {:3} minJ {:8.4} minσ {:7.4} below {:3} newton {:2} cg {:4} conv {} cuts {} dist {:.3}",
                s.frame,
                s.elastic_energy,
                s.kinetic_energy,
                s.inverted_elements,
                s.min_j,
                min_s,
                below,
                s.newton_iterations,
                s.cg_iterations,
                s.converged,
                s.line_search_cuts,
                rigid_distance(&mesh.positions, x) / edge
            );
        }
    }
    let x = &sim.state.x;
    // overlap: vertices inside non-incident tets
    let mut overlaps = 0;
    for (t, tet) in mesh.tets.iter().enumerate() {
        let p = [x[tet[0]], x[tet[1]], x[tet[2]], x[tet[3]]];
        for (v, q) in x.iter().enumerate() {
            if !tet.contains(&v) && inside(q, &p) {
                overlaps += 1;
                let _ = t;
            }
        }
    }
    let mut sig: Vec<(f64, usize)> = (0..sim.body.tet_count())
        .map(|t| (svd_rv(&sim.body.deformation_gradient(x, t)).sigma[2], t))
        .collect();
    for t in 0..sim.body.tet_count() {
        let sv = svd_rv(&sim.body.deformation_gradient(x, t)).sigma;
        if sv[2] < 0.6 && !opts.contains_key("quiet") {
            println!("tet {t:3} σ {:.3} {:.3} {:.3}", sv[0], sv[1], sv[2]);
        }
    }
    sig.sort_by(|a, b| a.0.partial_cmp(&b.0).unwrap());
    let dist = rigid_distance(&mesh.positions, x) / edge;
    if opts.contains_key("quiet") {
        return dist;
    }
    println!(
        "final dist {:.4} energy {:.4e} overlaps(vertex-in-tet) {} smallest σ3: {:?}",
        rigid_distance(&mesh.positions, x) / edge,
        sim.body.energy(x),
        overlaps,
        &sig[..8.min(sig.len())]
            .iter()
            .map(|s| (format!("{:.3}", s.0), s.1))
            .collect::<Vec<_>>()
    );
    if let Some(path) = opts.get("dump") {
        let s: String = x
            .iter()
            .map(|p| format!("{} {} {}\n", p.x, p.y, p.z))
            .collect();
        std::fs::write(path, s).unwrap();
    }
    dist
}
