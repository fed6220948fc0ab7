//! `tetsim render` on a saved run: every field of the frames, the automatic choice said in
//! words, and an unknown field refused with the list of known ones.

use super::{stderr, tetsim};

/// A soft cube dropped onto a plane under gravity tilted by 30° (a slope), three frames.
const SLOPE: &str = "gravity = [4.905, -8.496, 0.0]\n\
[mesh]\ngenerator = { box = { min = [0, 0.01, 0], max = [0.2, 0.21, 0.2], cells = [2, 2, 2] } }\n\
[material]\nyoungs_modulus = 1e4\n\
[[obstacle]]\nplane = { point = [0, 0, 0], normal = [0, 1, 0] }\n\
[solver]\ndt = 0.02\nframes = 3\n";

#[test]
fn render_draws_every_field_of_a_saved_run() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("s.toml"), SLOPE).unwrap();
    let out = tetsim(
        dir.path(),
        &["run", "s.toml", "--out", "out", "-q", "--no-pictures"],
    );
    assert!(out.status.success(), "{}", stderr(&out));
    for field in [
        "auto",
        "displacement",
        "relative-displacement",
        "velocity",
        "contact-force",
        "J",
        "von-mises",
        "energy-density",
        "none",
    ] {
        let target = format!("p_{field}");
        let out = tetsim(
            dir.path(),
            &[
                "render",
                "out",
                "--field",
                field,
                "--out",
                &target,
                "--width",
                "160",
                "--height",
                "120",
                "--gif-width",
                "64",
                "--gif-height",
                "48",
            ],
        );
        assert!(out.status.success(), "--field {field}: {}", stderr(&out));
        let said = stderr(&out);
        let png = std::fs::read(dir.path().join(&target).join("preview.png")).unwrap();
        assert_eq!(&png[1..4], b"PNG", "--field {field}");
        if field == "auto" {
            // The field chosen, and why, is said.
            assert!(
                said.contains("colour: ") && said.contains("(auto: "),
                "{said}"
            );
        } else {
            assert!(said.contains(&format!("colour: {field}\n")), "{said}");
        }
    }
    let out = tetsim(dir.path(), &["render", "out", "--field", "stress"]);
    assert!(!out.status.success());
    let said = stderr(&out);
    assert!(
        said.contains("\"stress\"") && said.contains("relative-displacement"),
        "{said}"
    );
}
