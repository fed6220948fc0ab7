//! Contact that never lies, through the real binary and checked from outside: every frame read
//! back from its VTU file and measured against the obstacles' own geometry, not against tetsim's
//! `min_distance`. A frame may say it did not converge; it may not say `converged` with a vertex
//! inside anything.

use std::path::Path;

use super::{stderr, tetsim};

/// Run `text` as `s.toml` in `dir` into `out`; the output (exit code checked by the caller).
fn run(dir: &Path, text: &str) -> std::process::Output {
    std::fs::write(dir.join("s.toml"), text).unwrap();
    tetsim(
        dir,
        &["run", "s.toml", "--out", "out", "-q", "--no-pictures"],
    )
}

/// Every frame's points and body index, read back from the files.
fn frames(out: &Path) -> Vec<(Vec<tetsim::Vec3>, Vec<f64>)> {
    let mut frames = Vec::new();
    for k in 0.. {
        let path = out.join(format!("frame_{k:04}.vtu"));
        if !path.exists() {
            break;
        }
        let frame = tetsim::io::read_vtu_frame(&path).unwrap();
        let body = match frame.point_field("body") {
            Some(tetsim::io::FieldData::Scalar(b)) => b.clone(),
            _ => vec![0.0; frame.points.len()],
        };
        frames.push((frame.points, body));
    }
    frames
}

/// steps.csv's `converged` column, frame by frame (frame 0 first).
fn converged(out: &Path) -> Vec<bool> {
    let csv = std::fs::read_to_string(out.join("steps.csv")).unwrap();
    let mut lines = csv.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let k = header.iter().position(|&h| h == "converged").unwrap();
    lines
        .map(|l| l.split(',').nth(k).unwrap() == "true")
        .collect()
}

#[test]
fn cubes_thrown_at_each_other_with_a_large_step_bounce_back() {
    // 3.5 m/s each with dt = 0.1 s: the step's predictor passes them through each other, and
    // the incremental potential's minimum had them go around each other within the step and
    // land on the far sides (contacts = 0, "converged"). The straight way between frames is now
    // checked: the step is cut until they meet and part on their own sides.
    let dir = tempfile::tempdir().unwrap();
    let scene = "gravity = [0, 0, 0]\n\
        [mesh]\nname = \"left\"\n\
        generator = { box = { min = [-0.5, -0.1, -0.1], max = [-0.3, 0.1, 0.1], cells = [3, 3, 3] } }\n\
        [initial]\nvelocity = [3.5, 0, 0]\n\
        [[body]]\nname = \"right\"\n\
        mesh = { generator = { box = { min = [0.3, -0.1, -0.1], max = [0.5, 0.1, 0.1], cells = [3, 3, 3] } } }\n\
        velocity = [-3.5, 0, 0]\n\
        [solver]\ndt = 0.1\nframes = 3\n";
    let out = run(dir.path(), scene);
    assert!(out.status.success(), "{}", stderr(&out));
    let frames = frames(&dir.path().join("out"));
    for (k, (x, body)) in frames.iter().enumerate() {
        let mean = |which: f64| {
            let (sum, n) = x
                .iter()
                .zip(body)
                .filter(|(_, b)| **b == which)
                .fold((0.0, 0.0), |(s, n), (p, _)| (s + p.x, n + 1.0));
            sum / n
        };
        let (left, right) = (mean(0.0), mean(1.0));
        assert!(
            left < right,
            "frame {k}: left's centre at x = {left}, right's at {right}"
        );
    }
    // They met and parted: closer at the end of frame 1 than at the start, apart after.
    let mean_gap = |k: usize| {
        let (x, body) = &frames[k];
        let left = x
            .iter()
            .zip(body)
            .filter(|(_, b)| **b == 0.0)
            .map(|(p, _)| p.x);
        let right = x
            .iter()
            .zip(body)
            .filter(|(_, b)| **b == 1.0)
            .map(|(p, _)| p.x);
        right.fold(f64::MAX, f64::min) - left.fold(f64::MIN, f64::max)
    };
    assert!(mean_gap(3) > mean_gap(1), "they do not part");
}

#[test]
fn a_turning_plane_never_has_a_vertex_behind_it() {
    // A plane turning 30° in 1 s about an axis through a block resting on the ground: CCD treated
    // the turn as a translation and left vertices 0.16 m behind the plane from frame 12 on.
    let dir = tempfile::tempdir().unwrap();
    let scene = "gravity = [0, -9.81, 0]\n\
        [mesh]\ngenerator = { box = { min = [-0.5, 0.01, -0.5], max = [0.5, 0.51, 0.5], cells = [4, 2, 4] } }\n\
        [[obstacle]]\nplane = { point = [0, 0, 0], normal = [0, 1, 0] }\n\
        [[obstacle]]\nplane = { point = [0, 0.6, 0], normal = [0, -1, 0] }\n\
        motion = { rotate_degrees = -30, axis = [0, 0, 1], center = [0, 0.25, 0] }\nduration = 1.0\n\
        [solver]\ndt = 0.05\nframes = 20\n";
    let out = run(dir.path(), scene);
    assert!(out.status.success(), "{}", stderr(&out));
    let frames = frames(&dir.path().join("out"));
    assert_eq!(frames.len(), 21);
    for (k, (x, _)) in frames.iter().enumerate() {
        let theta = (-30.0_f64 * (k as f64 * 0.05).min(1.0)).to_radians();
        let (c, s) = (theta.cos(), theta.sin());
        // The turning plane: point (0, 0.6, 0) and normal (0, −1, 0) rotated about z through
        // (0, 0.25, 0).
        let origin = tetsim::Vec3::new(-0.35 * s, 0.25 + 0.35 * c, 0.0);
        let normal = tetsim::Vec3::new(s, -c, 0.0);
        for p in x {
            assert!(
                p.y > 0.0,
                "frame {k}: a vertex at y = {} below the ground",
                p.y
            );
            let gap = (p - origin).dot(&normal);
            assert!(
                gap > 0.0,
                "frame {k}: a vertex {gap} m behind the turning plane"
            );
        }
    }
}

#[test]
fn a_drop_at_100_m_per_s_never_converges_with_a_vertex_under_the_ground() {
    // A soft cube dropped at 100 m/s with dt = 0.01 s: its surface stayed above the ground while
    // interior vertices went 0.61 m under it, 25 tets inverted, frame "converged". Every vertex
    // counts now: a frame either keeps all of them above the ground, or says it did not converge.
    let dir = tempfile::tempdir().unwrap();
    let scene = "gravity = [0, -9.81, 0]\n\
        [mesh]\ngenerator = { box = { min = [-0.5, 0.5, -0.5], max = [0.5, 1.5, 0.5], cells = [2, 2, 2] } }\n\
        [initial]\nvelocity = [0, -100, 0]\n\
        [[obstacle]]\nplane = { point = [0, 0, 0], normal = [0, 1, 0] }\n\
        [solver]\ndt = 0.01\nframes = 2\nmax_step_cuts = 2\n";
    let out = run(dir.path(), scene);
    assert!(out.status.success(), "{}", stderr(&out));
    let out = dir.path().join("out");
    let converged = converged(&out);
    for (k, (x, _)) in frames(&out).iter().enumerate() {
        let lowest = x.iter().map(|p| p.y).fold(f64::MAX, f64::min);
        assert!(
            lowest > 0.0 || !converged[k],
            "frame {k} says converged with a vertex at y = {lowest}"
        );
    }
}

#[test]
fn a_start_inside_an_obstacle_is_refused_at_the_obstacle() {
    let dir = tempfile::tempdir().unwrap();
    // A closed box-shaped mesh obstacle (outward faces) as an OBJ file.
    let obj = "v -1 -1 -1\nv 1 -1 -1\nv 1 1 -1\nv -1 1 -1\nv -1 -1 1\nv 1 -1 1\nv 1 1 1\nv -1 1 1\n\
               f 1 3 2\nf 1 4 3\nf 5 6 7\nf 5 7 8\nf 1 2 6\nf 1 6 5\nf 4 8 7\nf 4 7 3\n\
               f 1 5 8\nf 1 8 4\nf 2 3 7\nf 2 7 6\n";
    std::fs::write(dir.path().join("block.obj"), obj).unwrap();
    let cube = "[mesh]\ngenerator = { box = { min = [-0.5, 0.5, -0.5], max = [0.5, 1.5, 0.5], cells = [3, 3, 3] } }\n\
                [solver]\nframes = 1\n";
    let cases = [
        // A box that holds only interior vertices of the body.
        "[[obstacle]]\nbox = { min = [-0.2, 0.8, -0.2], max = [0.2, 1.2, 0.2] }\n",
        // A plane moved 10 m up at once (duration 0): the body starts behind it.
        "[[obstacle]]\nplane = { point = [0, 0, 0], normal = [0, 1, 0] }\n\
         motion = { translate = [0, 10, 0] }\nduration = 0\n",
        // A sphere moved into the body at once.
        "[[obstacle]]\nsphere = { center = [0, 5, 0], radius = 0.2 }\n\
         motion = { translate = [0, -4, 0] }\nduration = 0\n",
        // A closed mesh the body straddles.
        "[[obstacle]]\nmesh = \"block.obj\"\nmotion = { translate = [1.3, 1, 0] }\nduration = 0\n",
        // A closed mesh that holds the whole body.
        "[[obstacle]]\nmesh = \"block.obj\"\nmotion = { translate = [0, 1, 0] }\nduration = 0\n",
    ];
    for case in cases {
        let out = run(dir.path(), &format!("{cube}{case}"));
        let err = stderr(&out);
        assert_eq!(out.status.code(), Some(1), "{case}\n{err}");
        assert!(err.starts_with("error: s.toml:5:"), "{case}\n{err}");
        assert!(
            err.contains("[[obstacle]] #1") && err.contains("passes through"),
            "{err}"
        );
        assert!(!err.contains("panicked"), "{err}");
    }
}

#[test]
fn a_block_crushed_by_a_plate_stops_the_run_naming_the_plate() {
    // A plate driven down onto a block resting on the ground: once the block is squeezed as far
    // as it goes, the plate's prescribed motion would take it through the block. It used to say
    // it "could not push the body out of its way" and go on, `converged`, with vertices inside
    // the plate; now the run stops there, naming it, every frame written still outside it.
    let dir = tempfile::tempdir().unwrap();
    let scene = "gravity = [0, -9.81, 0]\n\
        [mesh]\ngenerator = { box = { min = [-0.25, 0.001, -0.25], max = [0.25, 0.201, 0.25], cells = [2, 1, 2] } }\n\
        [material]\nyoungs_modulus = 1e5\npoisson_ratio = 0.3\n\
        [[obstacle]]\nplane = { point = [0, 0, 0], normal = [0, 1, 0] }\n\
        [[obstacle]]\nname = \"plate\"\nbox = { min = [-0.5, 0.21, -0.5], max = [0.5, 0.3, 0.5] }\n\
        motion = { translate = [0, -0.25, 0] }\nduration = 0.5\n\
        [solver]\ndt = 0.05\nframes = 12\nmax_step_cuts = 1\n";
    let out = run(dir.path(), scene);
    let err = stderr(&out);
    assert_eq!(out.status.code(), Some(1), "{err}");
    assert!(
        err.contains("plate could not push the body out of its way") && err.contains("frame "),
        "{err}"
    );
    let out = dir.path().join("out");
    let written = frames(&out);
    assert!(written.len() > 3, "{} frames", written.len());
    for (k, (x, _)) in written.iter().enumerate() {
        // The plate's underside at frame k (a linear ramp over 0.5 s, dt = 0.05 s).
        let underside = 0.21 - 0.25 * (k as f64 * 0.05 / 0.5).min(1.0);
        for p in x {
            assert!(
                p.y < underside && p.y > 0.0,
                "frame {k}: vertex at y = {} (plate at {underside})",
                p.y
            );
        }
    }
    let manifest = std::fs::read_to_string(out.join("manifest.json")).unwrap();
    assert!(
        manifest.contains("\"status\": \"stopped: frame"),
        "{manifest}"
    );
}

#[test]
fn a_contact_distance_wider_than_the_body_s_own_gaps_is_refused() {
    // 0.5 m on a 0.2 m cube of 3 × 3 × 3 cells: parts of its surface 0.038 m apart at rest were
    // pushed apart by self-contact, inflating the resting cube with 17 kJ from nothing.
    let dir = tempfile::tempdir().unwrap();
    let cube = "gravity = [0, -9.81, 0]\n\
        [mesh]\ngenerator = { box = { min = [-0.1, 0, -0.1], max = [0.1, 0.2, 0.1], cells = [3, 3, 3] } }\n\
        [[obstacle]]\nplane = { point = [0, -0.001, 0], normal = [0, 1, 0] }\n\
        [solver]\nframes = 1\n";
    let out = run(dir.path(), &format!("{cube}[contact]\ndistance = 0.5\n"));
    let err = stderr(&out);
    assert_eq!(out.status.code(), Some(1), "{err}");
    assert!(err.starts_with("error: s.toml:9:"), "{err}");
    assert!(
        err.contains("contact.distance") && err.contains("3.849e-2 m"),
        "{err}"
    );
    // Below the gap, or without self-contact, it runs.
    for ok in ["distance = 0.03\n", "distance = 0.5\nself = false\n"] {
        let out = run(dir.path(), &format!("{cube}[contact]\n{ok}"));
        assert!(out.status.success(), "{ok}: {}", stderr(&out));
    }
}

#[test]
fn a_surface_touching_itself_at_rest_is_refused_not_given_a_zero_distance() {
    // A tet whose vertex lies on another tet's face (a Medit file, as a mesher could write it):
    // no contact distance fits, and shrinking the default to half the gap would make it 0.
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(
        dir.path().join("touch.mesh"),
        "MeshVersionFormatted 2\nDimension 3\nVertices\n8\n0 0 0 0\n1 0 0 0\n0 1 0 0\n0 0 1 0\n\
         0.3333333333333333 0.3333333333333333 0.3333333333333334 0\n1 1 1 0\n1.5 1 1 0\n\
         1 1.5 1 0\nTetrahedra\n2\n1 2 3 4 1\n5 6 7 8 1\nEnd\n",
    )
    .unwrap();
    let scene = "[mesh]\nfile = \"touch.mesh\"\n\
        [[obstacle]]\nplane = { point = [0, -0.01, 0], normal = [0, 1, 0] }\n\
        [solver]\nframes = 1\n";
    let out = run(dir.path(), scene);
    let err = stderr(&out);
    assert_eq!(out.status.code(), Some(1), "{err}");
    assert!(
        err.contains("touch at rest") && !err.contains("panicked"),
        "{err}"
    );
    let out = run(dir.path(), &format!("{scene}[contact]\nself = false\n"));
    assert!(out.status.success(), "{}", stderr(&out));
}
