//! Every input checked, every alarm true, through the real binary: each bad input a hurried or
//! hostile user would type is refused before the first frame with file:line:key and exit 1 (no
//! panic, abort, hang, or NaN with exit 0), and the alarms stay silent where nothing is wrong.

use std::path::Path;
use std::process::Output;

use super::{stderr, tetsim};

const BEAM: &str = "[mesh]\ngenerator = { box = { min = [0,0,0], max = [2,0.5,0.5], cells = [8,2,2] } }\n\
                    [[fixed]]\nregion = { physical = \"xmin\" }\n";

/// Run the scene `text` as `s.toml` in a temp dir; the output and the dir.
fn run(text: &str, extra: &[&str]) -> (Output, tempfile::TempDir) {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("s.toml"), text).unwrap();
    let mut args = vec!["run", "s.toml", "--out", "out", "--no-pictures"];
    args.extend(extra);
    (tetsim(dir.path(), &args), dir)
}

/// The scene is refused with exit 1 and a message starting `s.toml:LINE:` that names `key`
/// and contains `word`.
fn refused(text: &str, line: usize, key: &str, word: &str) {
    refused_with(&[], text, line, key, word);
}

#[test]
fn absurd_values_are_refused_at_their_key_before_the_first_frame() {
    let cases: &[(String, usize, &str, &str)] = &[
        (format!("gravity = [0, -1e308, 0]\n{BEAM}"), 1, "gravity", "beyond any physical value"),
        (format!("{BEAM}[material]\nyoungs_modulus = 1e308\n"), 6, "material.youngs_modulus", "1e15"),
        (format!("{BEAM}[material]\ndensity = 1e308\n"), 6, "material.density", "kg/m³"),
        (format!("{BEAM}[initial]\nvelocity = [1e308, 0, 0]\n"), 6, "initial.velocity", "m/s"),
        (
            format!("{BEAM}[[load]]\nregion = {{ physical = \"xmax\" }}\ntraction = [0, 1e308, 0]\n"),
            7,
            "[[load]] #1 traction",
            "Pa",
        ),
        (
            format!("{BEAM}[[load]]\nregion = {{ physical = \"xmax\" }}\ntraction = [0, -1, 0]\nduration = -1\n"),
            8,
            "[[load]] #1 duration",
            "got -1",
        ),
        (
            format!("{BEAM}[[fixed]]\nregion = {{ physical = \"xmax\" }}\nmotion = {{ translate = [1e308, 0, 0] }}\n"),
            7,
            "motion.translate",
            "beyond",
        ),
        (
            format!("{BEAM}[[fixed]]\nregion = {{ physical = \"xmax\" }}\nmotion = {{ translate = [nan, 0, 0] }}\n"),
            7,
            "motion.translate",
            "finite",
        ),
        (
            format!("{BEAM}[[fixed]]\nregion = {{ physical = \"xmax\" }}\nmotion = {{ rotate_degrees = 90, axis = [0, 0, 0] }}\n"),
            7,
            "motion.axis",
            "non-zero axis",
        ),
        (format!("gravity = [0, -9.81, 0, 500]\n{BEAM}"), 1, "gravity", "exactly 3 entries"),
        (
            "[mesh]\ngenerator = { box = { min = [0,0,0], max = [1,1,1], cells = [2, 2, 2, 99] } }\n".into(),
            2,
            "mesh.generator.box.cells",
            "exactly 3 entries",
        ),
        (format!("{BEAM}[solver]\nsubsteps = 1000000000\n"), 6, "solver.substeps", "at most"),
        (
            format!("{BEAM}[solver]\nnewton_max_iterations = 9223372036854775807\n"),
            6,
            "solver.newton_max_iterations",
            "at most",
        ),
        (format!("{BEAM}[solver]\nnewton_tolerance = 1\n"), 6, "solver.newton_tolerance", "below 1"),
        (
            format!("{BEAM}[material]\npoisson_ratio = 0.4999999999\n"),
            6,
            "material.poisson_ratio",
            "double precision",
        ),
        (
            "[mesh]\ngenerator = { box = { min = [0,0,0], max = [1,1,1], cells = [1000000, 1000000, 1000000] } }\n".into(),
            2,
            "mesh.generator.box.cells",
            "of memory",
        ),
        (
            "[mesh]\ngenerator = { box = { min = [0,0,0], max = [1,1,1], cells = [600, 600, 600] } }\n".into(),
            2,
            "mesh.generator.box.cells",
            "of memory",
        ),
    ];
    for (text, line, key, word) in cases {
        refused(text, *line, key, word);
    }
}

#[test]
fn files_that_are_not_regular_are_refused_without_reading_them() {
    // A FIFO would block the open, /dev/zero would be read until memory runs out.
    let dir = tempfile::tempdir().unwrap();
    let fifo = dir.path().join("fifo.msh");
    let made = std::process::Command::new("mkfifo").arg(&fifo).status();
    let mut cases = vec![
        (
            "[mesh]\nfile = \"/dev/zero\"\n".to_string(),
            "mesh.file",
            "not a regular file",
        ),
        (
            "[mesh]\nfile = \"/dev/urandom\"\n".to_string(),
            "mesh.file",
            "not a regular file",
        ),
        (
            "[mesh]\nfile = \"/tmp\"\n".to_string(),
            "mesh.file",
            "is a directory",
        ),
        (
            format!("{BEAM}[initial]\npositions = \"/dev/urandom\"\n"),
            "initial.positions",
            "not a regular file",
        ),
    ];
    if made.is_ok_and(|s| s.success()) {
        cases.push((
            format!("[mesh]\nfile = \"{}\"\n", fifo.display()),
            "mesh.file",
            "not a regular file",
        ));
    }
    for (text, key, word) in cases {
        let line = text
            .lines()
            .position(|l| l.contains("file") || l.contains("positions"))
            .unwrap()
            + 1;
        refused(&text, line, key, word);
    }
}

#[test]
fn long_names_are_cut_and_io_errors_said_once() {
    let name = "a".repeat(5000);
    let (out, _dir) = run(
        &format!(
            "[mesh]\ngenerator = {{ box = {{ min = [0,0,0], max = [1,1,1], cells = [1,1,1] }} }}\n[[fixed]]\nregion = {{ physical = \"{name}\" }}\n"
        ),
        &["-q"],
    );
    let err = stderr(&out);
    assert_eq!(out.status.code(), Some(1));
    assert!(
        err.contains("(5000 characters)") && err.len() < 400,
        "{err}"
    );
    let (out, _dir) = run("[mesh]\nfile = \"missing.msh\"\n", &["-q"]);
    let err = stderr(&out);
    assert_eq!(err.matches("No such file").count(), 1, "{err}");
}

#[test]
fn a_closed_pipe_ends_the_run_quietly() {
    use std::io::Read;
    use std::process::{Command, Stdio};
    let dir = tempfile::tempdir().unwrap();
    // stderr into a pipe that is closed after the first bytes: what `2>&1 | head -1` does.
    let mut child = Command::new(env!("CARGO_BIN_EXE_tetsim"))
        .args(["run", "--frames", "3", "--out", "out", "--no-pictures"])
        .current_dir(dir.path())
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let mut first = [0u8; 16];
    let _ = child.stderr.as_mut().unwrap().read(&mut first);
    drop(child.stderr.take());
    let status = child.wait().unwrap();
    // Either it finished before noticing, or it left with SIGPIPE's status; never a panic (101).
    assert!(matches!(status.code(), Some(0) | Some(141)), "{status:?}");
}

#[test]
fn threads_beyond_the_cores_are_capped_with_a_word() {
    let (out, _dir) = run(&format!("{BEAM}[solver]\nframes = 1\n"), &[]);
    assert!(out.status.success());
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(
        dir.path().join("s.toml"),
        format!("{BEAM}[solver]\nframes = 1\n"),
    )
    .unwrap();
    let out = tetsim(
        dir.path(),
        &[
            "--threads",
            "1000",
            "run",
            "s.toml",
            "--out",
            "out",
            "--no-pictures",
        ],
    );
    let err = stderr(&out);
    assert!(out.status.success(), "{err}");
    assert!(err.contains("--threads 1000: only"), "{err}");
}

/// steps.csv's rows as (newton_iterations, converged, relative_residual, kinetic_energy).
fn steps(dir: &Path) -> Vec<(usize, bool, f64, f64)> {
    let text = std::fs::read_to_string(dir.join("out/steps.csv")).unwrap();
    text.lines()
        .skip(2)
        .map(|l| {
            let c: Vec<&str> = l.split(',').collect();
            (
                c[2].parse().unwrap(),
                c[5] == "true",
                c[11].parse().unwrap(),
                c[7].parse().unwrap(),
            )
        })
        .collect()
}

#[test]
fn a_nearly_incompressible_beam_moves_and_is_warned_about() {
    // ν = 0.4999: λ/μ ≈ 5000. The old floor (1e-12 of (λ + 2μ)·ℓ²·√n) grew with λ; here the beam
    // must iterate (never "converged" at iteration 0 under its weight) and the user is warned.
    let (out, dir) = run(
        &format!("{BEAM}[material]\npoisson_ratio = 0.4999\n[solver]\nframes = 2\n"),
        &[],
    );
    let err = stderr(&out);
    assert!(out.status.success(), "{err}");
    assert!(
        err.contains("nearly incompressible") && err.contains("lock"),
        "{err}"
    );
    for (newton, _, _, _) in steps(dir.path()) {
        assert!(newton > 0, "{err}");
    }
}

#[test]
fn uniform_and_fast_rigid_motion_raise_no_alarm() {
    // A free cube gliding at 1 m/s and at 1e4 m/s: exact rigid motion. No energy alarm, no
    // clamping note, every frame converged without retries.
    for speed in ["1", "10000"] {
        let (out, dir) = run(
            &format!(
                "gravity = [0, 0, 0]\n[mesh]\ngenerator = {{ box = {{ min = [0,0,0], max = [1,1,1], cells = [3,3,3] }} }}\n\
                 [initial]\nvelocity = [{speed}, 0.5, 0]\n[solver]\nframes = 30\n"
            ),
            &[],
        );
        let err = stderr(&out);
        assert!(out.status.success(), "{err}");
        for word in [
            "ENERGY INJECTED",
            "clamped",
            "did not converge",
            "retried",
            "moved a vertex",
        ] {
            assert!(!err.contains(word), "{speed} m/s: {word} in {err}");
        }
        assert!(steps(dir.path()).iter().all(|s| s.1), "{err}");
    }
}

#[test]
fn shipped_squash_release_raises_no_energy_alarm() {
    let scene = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/squash_release.toml");
    let dir = tempfile::tempdir().unwrap();
    let out = tetsim(
        dir.path(),
        &[
            "run",
            scene.to_str().unwrap(),
            "--out",
            "out",
            "--no-pictures",
            "--frames",
            "20",
        ],
    );
    let err = stderr(&out);
    assert!(out.status.success(), "{err}");
    assert!(!err.contains("ENERGY INJECTED"), "{err}");
}

#[test]
fn console_names_the_relative_residual_and_times_pictures_apart() {
    let dir = tempfile::tempdir().unwrap();
    let out = tetsim(dir.path(), &["run", "--frames", "2", "--out", "out"]);
    let err = stderr(&out);
    assert!(out.status.success(), "{err}");
    assert!(err.contains("relative residual"), "{err}");
    assert!(err.contains("pictures and plots"), "{err}");
    // -v itself, not RUST_LOG (which the `tetsim` helper sets and which overrides -v).
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_tetsim"))
        .args([
            "-v",
            "run",
            "--frames",
            "2",
            "--out",
            "out",
            "--no-pictures",
        ])
        .current_dir(dir.path())
        .env_remove("RUST_LOG")
        .output()
        .unwrap();
    let err = stderr(&out);
    assert_eq!(err.matches("frame 1/2").count(), 1, "{err}");
    assert!(err.contains("frame 2/2") && err.contains(" N "), "{err}");
}

#[test]
fn convert_says_which_groups_a_format_drops() {
    let dir = super::staged(&["beam_v41.msh"]);
    let out = tetsim(dir.path(), &["mesh", "convert", "beam_v41.msh", "a.vtu"]);
    assert!(out.status.success(), "{}", stderr(&out));
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(stdout.contains("3 of 3 groups"), "{stdout}");
    assert!(!stderr(&out).contains("dropped"), "{}", stderr(&out));
    let out = tetsim(dir.path(), &["mesh", "convert", "beam_v41.msh", "a.vtk"]);
    assert!(out.status.success(), "{}", stderr(&out));
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(stdout.contains("0 of 3 groups"), "{stdout}");
    assert!(
        stderr(&out).contains("3 groups dropped"),
        "{}",
        stderr(&out)
    );
    let out = tetsim(dir.path(), &["mesh", "convert", "beam_v41.msh", "b.msh"]);
    assert!(String::from_utf8_lossy(&out.stdout).contains("3 of 3 groups"));
    assert!(!stderr(&out).contains("dropped"));
}

/// Like [`refused`], with `files` (name, text) written beside s.toml.
fn refused_with(files: &[(&str, String)], text: &str, line: usize, key: &str, word: &str) {
    let dir = tempfile::tempdir().unwrap();
    for (name, body) in files {
        std::fs::write(dir.path().join(name), body).unwrap();
    }
    std::fs::write(dir.path().join("s.toml"), text).unwrap();
    let out = tetsim(
        dir.path(),
        &["run", "s.toml", "--out", "out", "--no-pictures", "-q"],
    );
    let err = stderr(&out);
    assert_eq!(out.status.code(), Some(1), "{text}\n{err}");
    let at = format!("error: s.toml:{line}:");
    assert!(err.starts_with(&at), "expected {at} in\n{err}");
    assert!(err.contains(key), "{key} not in {err}");
    assert!(err.contains(word), "{word} not in {err}");
    assert!(!dir.path().join("out/frame_0001.vtu").exists(), "{err}");
}

#[test]
fn values_that_arrive_by_files_units_defaults_or_derivation_are_refused_at_their_place() {
    const CUBE: &str = "generator = { box = { min = [0,0,0], max = [1,1,1], cells = [1,1,1] } }";
    let node = "4 3 0 0\n1 0 0 0\n2 1 0 0\n3 0 1 0\n4 0 0 1\n".to_string();
    let ele = "1 4 0\n1 1 2 3 4\n".to_string();
    let tet = [("t.node", node), ("t.ele", ele)];
    // A mesh file's coordinates after its unit, against the cap of every length.
    refused_with(
        &tet,
        "[mesh]\nfile = \"t.node\"\nunit = \"Tm\"\n",
        3,
        "mesh.unit",
        "t.node: vertex 2 is at [1e12",
    );
    // Initial positions far beyond any scene.
    let far = "1e300 0 0\n".to_string() + &"0 0 0\n".repeat(7);
    refused_with(
        &[("p.txt", far)],
        &format!("[mesh]\n{CUBE}\n[initial]\npositions = \"p.txt\"\n"),
        4,
        "initial.positions",
        "p.txt: vertex 1 is at [1e300",
    );
    let cases: &[(String, usize, &str, &str)] = &[
        // A normal whose length overflows.
        (
            format!("[mesh]\n{CUBE}\n[[obstacle]]\nplane = {{ point = [0, -1, 0], normal = [0, 1e308, 1e308] }}\n"),
            4,
            "plane.normal",
            "[0, 1e308, 1e308]",
        ),
        // An axis whose length underflows to zero cannot turn anything.
        (
            format!("[mesh]\n{CUBE}\n[[fixed]]\nregion = {{ physical = \"xmin\" }}\nmotion = {{ rotate_degrees = 30, axis = [1e-320, 0, 0] }}\n"),
            5,
            "motion.axis",
            "non-zero axis",
        ),
        // Rayleigh coefficients derived from a ratio, against the caps of their own keys.
        (
            format!("[mesh]\n{CUBE}\n[solver]\ndamping_ratio = 0.05\ndamping_frequencies = [1e-300, 1e-299]\n"),
            5,
            "solver.damping_frequencies",
            "rayleigh_stiffness = 1.447e297 s",
        ),
        // Names unique once defaults are filled in.
        (
            format!("[mesh]\n{CUBE}\nname = \"body1\"\n[[body]]\nmesh = {{ generator = {{ box = {{ min = [2,0,0], max = [3,1,1], cells = [1,1,1] }} }} }}\n"),
            4,
            "[[body]] #1",
            "default name \"body1\" is taken",
        ),
        // Degenerate elements blamed on what made them.
        (
            "[mesh]\ngenerator = { box = { min = [0,0,0], max = [1,1,1e-300], cells = [1,1,1] } }\n".into(),
            2,
            "mesh.generator",
            "degenerate elements",
        ),
        (
            format!("[mesh]\n{CUBE}\n[[body]]\nmesh = {{ generator = {{ box = {{ min = [2,0,0], max = [3,1,1], cells = [1,1,1] }} }} }}\nscale = 1e-200\n"),
            5,
            "[[body]] #1 scale",
            "body \"body1\" once placed: degenerate elements",
        ),
        // Bodies passing through each other at the start: at [contact].
        (
            format!("[mesh]\n{CUBE}\n[[body]]\nmesh = {{ generator = {{ box = {{ min = [0.5,0,0], max = [1.5,1,1], cells = [1,1,1] }} }} }}\n[contact]\n"),
            5,
            "contact",
            "passing through body",
        ),
    ];
    for (text, line, key, word) in cases {
        refused(text, *line, key, word);
    }
}

#[test]
fn bodies_that_each_fit_in_memory_are_refused_when_together_they_do_not() {
    let Some(available) = std::fs::read_to_string("/proc/meminfo").ok().and_then(|t| {
        let line = t.lines().find(|l| l.starts_with("MemAvailable:"))?;
        line.split_whitespace().nth(1)?.parse::<f64>().ok()
    }) else {
        return; // no estimate where the memory is unknown
    };
    // Each box about 60 % of what is available (2,000 bytes a tet, 6 tets a cell).
    let cells = (0.6 * available * 1024.0 / 2000.0 / 6.0).cbrt().ceil() as usize;
    let bx = |x: f64| {
        format!(
            "{{ box = {{ min = [{x},0,0], max = [{},1,1], cells = [{cells},{cells},{cells}] }} }}",
            x + 1.0
        )
    };
    let text = format!(
        "[mesh]\ngenerator = {}\n[[body]]\nmesh = {{ generator = {} }}\n",
        bx(0.0),
        bx(2.0)
    );
    refused(&text, 4, "body", "generator boxes together");
}
