//! Pictures: the renderer draws what the geometry says (silhouette area, colours where the
//! field's extremes are, cut-away faces, fixed-vertex markers), the same bytes every time, and
//! GIFs and plots that decode.

use std::path::{Path, PathBuf};
use std::time::Instant;

use tetsim::mesh::generate::box_mesh;
use tetsim::render::{
    self, Bounds, FieldKind, Image, Plane, RenderMesh, RenderParams, RunFrame, RunPictureParams,
    SceneView, Shading,
};
use tetsim::{ElasticBody, Lame, Model, ModelKind, TetMesh, Vec3};

/// A beam [0, 4] × [0, 1] × [0, 1] of `cells`, and its fixed end (x = 0).
fn beam(cells: [usize; 3]) -> (TetMesh, Vec<bool>) {
    let mesh = box_mesh(Vec3::zeros(), Vec3::new(4.0, 1.0, 1.0), cells);
    let fixed = mesh.positions.iter().map(|p| p.x < 1e-9).collect();
    (mesh, fixed)
}

/// The beam bent downwards about the z axis by `angle` radians in total, clamped at x = 0:
/// the neutral line y = 0.5 becomes a circular arc of length 4.
fn bend(rest: &[Vec3], angle: f64) -> Vec<Vec3> {
    if angle.abs() < 1e-12 {
        return rest.to_vec();
    }
    let radius = 4.0 / angle;
    rest.iter()
        .map(|p| {
            let theta = p.x / radius;
            let rho = radius + (p.y - 0.5);
            Vec3::new(rho * theta.sin(), 0.5 - radius + rho * theta.cos(), p.z)
        })
        .collect()
}

fn body(mesh: &TetMesh) -> ElasticBody {
    let model = Model::new(ModelKind::NeoHookean, Lame::from_young_poisson(1e5, 0.3));
    ElasticBody::new(mesh.clone(), model, 1000.0).unwrap()
}

/// Parameters for exact-colour checks: no lighting, no floor, a small picture.
fn plain_params(width: u32, height: u32) -> RenderParams {
    RenderParams {
        width,
        height,
        shading: Shading::Unlit,
        show_floor: false,
        ..RenderParams::default()
    }
}

fn render_one(
    rm: &RenderMesh,
    x: &[Vec3],
    field: &[f64],
    fixed: &[bool],
    params: &RenderParams,
    range: (f64, f64),
) -> Image {
    let camera = render::fit_camera(&Bounds::of(x), params);
    let view = SceneView {
        mesh: rm,
        positions: x,
        field,
        fixed,
        time: 0.5,
        frame: 3,
    };
    render::render(&view, &camera, params, range).unwrap()
}

fn pixel_at(img: &Image, p: [f64; 2]) -> [u8; 3] {
    img.pixel(p[0].floor() as u32, p[1].floor() as u32)
}

fn close(a: [u8; 3], b: [u8; 3], tolerance: i32) -> bool {
    (0..3).all(|i| (a[i] as i32 - b[i] as i32).abs() <= tolerance)
}

/// Shoelace area of a polygon.
fn polygon_area(p: &[[f64; 2]]) -> f64 {
    let n = p.len();
    0.5 * (0..n)
        .map(|i| p[i][0] * p[(i + 1) % n][1] - p[(i + 1) % n][0] * p[i][1])
        .sum::<f64>()
        .abs()
}

/// A cube seen head-on along −z: its silhouette is the projection of its front face, and the
/// rendered coverage (anti-aliased edges counted fractionally) matches that square's area.
#[test]
fn silhouette_covers_the_projected_square() {
    let mesh = box_mesh(Vec3::zeros(), Vec3::repeat(1.0), [2, 2, 2]);
    let rm = RenderMesh::new(&mesh);
    let params = RenderParams {
        field: None,
        azimuth_deg: 0.0,
        elevation_deg: 0.0,
        show_caption: false,
        ..plain_params(320, 240)
    };
    let img = render_one(&rm, &mesh.positions, &[], &[], &params, (0.0, 1.0));
    let camera = render::fit_camera(&Bounds::of(&mesh.positions), &params);
    let front: Vec<[f64; 2]> = [[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]]
        .iter()
        .map(|c| {
            camera
                .project_to_pixel(&params, &Vec3::new(c[0], c[1], 1.0))
                .unwrap()
        })
        .collect();
    let expected = polygon_area(&front);
    // Unlit: the object is one flat colour over the background gradient, so each pixel's
    // coverage is where its red channel lies between the two.
    let object = img.pixel(160, 120);
    let mut covered = 0.0;
    for y in 0..img.height {
        let background = img.pixel(0, y)[0] as f64;
        for x in 0..img.width {
            let c = img.pixel(x, y)[0] as f64;
            covered += ((background - c) / (background - object[0] as f64)).clamp(0.0, 1.0);
        }
    }
    let fraction = covered / (img.width * img.height) as f64;
    let expected_fraction = expected / (img.width * img.height) as f64;
    assert!(
        (fraction / expected_fraction - 1.0).abs() < 0.01,
        "silhouette covers {fraction:.4} of the frame, the projected square {expected_fraction:.4}"
    );
    // And it is a sizeable part of the frame: the camera fit does not leave the cube tiny.
    assert!(expected_fraction > 0.2, "{expected_fraction}");
}

/// Per-tet values rising along the beam (by column of cells): unlit, the colour at the last
/// column equals the top of the colour bar and the colour at the first column its bottom; lit,
/// they are still nearer in hue to their own end of the bar than to the other.
#[test]
fn colour_bar_extremes_sit_where_the_field_extremes_are() {
    let (mesh, _) = beam([8, 2, 2]);
    let rm = RenderMesh::new(&mesh);
    let column: Vec<f64> = mesh
        .tets
        .iter()
        .map(|t| {
            let cx = t.iter().map(|&v| mesh.positions[v].x).sum::<f64>() / 4.0;
            (cx / 0.5).floor()
        })
        .collect();
    let range = render::field_range([column.as_slice()]);
    assert_eq!(range, (0.0, 7.0));
    let base = RenderParams {
        field: Some(FieldKind::J),
        ..plain_params(400, 300)
    };
    for shading in [Shading::Unlit, Shading::Smooth] {
        let params = RenderParams {
            shading,
            ..base.clone()
        };
        let img = render_one(&rm, &mesh.positions, &column, &[], &params, range);
        let camera = render::fit_camera(&Bounds::of(&mesh.positions), &params);
        // The colour bar: the right-most column of pixels whose colours run from yellow down
        // to purple. Find its top and bottom rows by the colour map's end colours.
        let top_colour = render::viridis(1.0);
        let bottom_colour = render::viridis(0.0);
        let (mut top, mut bottom) = (None, None);
        for y in 0..img.height {
            for x in (img.width * 3 / 4)..img.width {
                if top.is_none() && close(img.pixel(x, y), top_colour, 4) {
                    top = Some(img.pixel(x, y));
                }
                if close(img.pixel(x, y), bottom_colour, 4) {
                    bottom = Some(img.pixel(x, y));
                }
            }
        }
        let (top, bottom) = (top.expect("bar top"), bottom.expect("bar bottom"));
        let at_max = pixel_at(
            &img,
            camera
                .project_to_pixel(&params, &Vec3::new(3.75, 0.5, 1.0))
                .unwrap(),
        );
        let at_min = pixel_at(
            &img,
            camera
                .project_to_pixel(&params, &Vec3::new(0.25, 0.5, 1.0))
                .unwrap(),
        );
        if shading == Shading::Unlit {
            assert!(close(at_max, top, 3), "{at_max:?} vs bar top {top:?}");
            assert!(
                close(at_min, bottom, 3),
                "{at_min:?} vs bar bottom {bottom:?}"
            );
        } else {
            let hue = |c: [u8; 3]| {
                let s = (c[0] as f64 + c[1] as f64 + c[2] as f64).max(1.0);
                [c[0] as f64 / s, c[1] as f64 / s, c[2] as f64 / s]
            };
            let d = |a: [u8; 3], b: [u8; 3]| {
                let (a, b) = (hue(a), hue(b));
                (0..3).map(|i| (a[i] - b[i]).powi(2)).sum::<f64>()
            };
            assert!(d(at_max, top) < d(at_max, bottom), "{at_max:?}");
            assert!(d(at_min, bottom) < d(at_min, top), "{at_min:?}");
        }
    }
}

/// Same input, same bytes: twice in a row and on a one-thread pool.
#[test]
fn renders_are_deterministic() {
    let (mesh, fixed) = beam([8, 2, 2]);
    let body = body(&mesh);
    let rm = RenderMesh::new(&mesh);
    let x = bend(&mesh.positions, 0.8);
    let values = render::field_values(FieldKind::VonMises, &body, &x).unwrap();
    let range = render::field_range([values.as_slice()]);
    let params = RenderParams {
        width: 200,
        height: 150,
        field: Some(FieldKind::VonMises),
        wireframe: true,
        ..RenderParams::default()
    };
    let first = render_one(&rm, &x, &values, &fixed, &params, range).encode_png();
    let second = render_one(&rm, &x, &values, &fixed, &params, range).encode_png();
    assert!(first == second, "two renders differ");
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .unwrap();
    let serial = pool.install(|| render_one(&rm, &x, &values, &fixed, &params, range).encode_png());
    assert!(first == serial, "one thread and many differ");
}

/// A GIF of five frames decodes to five frames of the right size, the last of which looks
/// like the last image (up to palette and dither).
#[test]
fn gif_has_every_frame_at_the_right_size() {
    let (mesh, fixed) = beam([8, 2, 2]);
    let rm = RenderMesh::new(&mesh);
    let params = RenderParams {
        width: 96,
        height: 72,
        supersample: 2,
        ..RenderParams::default()
    };
    let frames: Vec<Vec<Vec3>> = (0..5)
        .map(|k| bend(&mesh.positions, 0.3 * k as f64))
        .collect();
    let mut bounds = Bounds::empty();
    frames.iter().for_each(|f| bounds.include(f));
    let camera = render::fit_camera(&bounds, &params);
    let values: Vec<Vec<f64>> = frames
        .iter()
        .map(|x| render::displacement_magnitudes(&mesh.positions, x))
        .collect();
    let range = render::field_range(values.iter().map(|v| v.as_slice()));
    let images: Vec<Image> = frames
        .iter()
        .zip(&values)
        .enumerate()
        .map(|(k, (x, v))| {
            let view = SceneView {
                mesh: &rm,
                positions: x,
                field: v,
                fixed: &fixed,
                time: 0.1 * k as f64,
                frame: k,
            };
            render::render(&view, &camera, &params, range).unwrap()
        })
        .collect();
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("animation.gif");
    render::write_gif(&path, &images, 4).unwrap();
    let bytes = std::fs::read(&path).unwrap();
    let decoded = decode_gif_frames(&bytes);
    assert_eq!(decoded.len(), 5);
    for f in &decoded {
        assert_eq!((f.width, f.height), (96, 72));
    }
    let last = decoded.last().unwrap();
    let diff: f64 = last
        .pixels
        .iter()
        .zip(&images[4].pixels)
        .map(|(a, b)| (*a as f64 - *b as f64).abs())
        .sum::<f64>()
        / last.pixels.len() as f64;
    assert!(diff < 6.0, "mean difference {diff} levels");
    assert_eq!(
        render::encode_gif(&images, 4).unwrap(),
        bytes,
        "GIF not deterministic"
    );
    let leftovers: Vec<_> = std::fs::read_dir(dir.path()).unwrap().collect();
    assert_eq!(leftovers.len(), 1, "temporary files left behind");
}

/// A run's pictures: the preview at its size and a GIF with every frame at the GIF size.
#[test]
fn run_writes_preview_and_animation() {
    let (mesh, fixed) = beam([8, 2, 2]);
    let body = body(&mesh);
    let rm = RenderMesh::new(&mesh);
    let positions: Vec<Vec<Vec3>> = (0..4)
        .map(|k| bend(&mesh.positions, 0.4 * k as f64))
        .collect();
    let fields: Vec<Vec<f64>> = positions
        .iter()
        .map(|x| render::field_values(FieldKind::J, &body, x).unwrap())
        .collect();
    let frames: Vec<RunFrame> = positions
        .iter()
        .zip(&fields)
        .enumerate()
        .map(|(k, (x, v))| RunFrame {
            frame: 2 * k,
            time: 0.1 * k as f64,
            positions: x,
            field: v,
            obstacles: &[],
            ground: None,
        })
        .collect();
    let params = RunPictureParams {
        preview: RenderParams {
            width: 160,
            height: 120,
            field: Some(FieldKind::J),
            ..RenderParams::default()
        },
        gif_width: 80,
        gif_height: 60,
        gif_delay_cs: 5,
    };
    let dir = tempfile::tempdir().unwrap();
    let written = render::render_run(&rm, &fixed, &frames, &params, dir.path()).unwrap();
    assert_eq!(
        written,
        vec![
            dir.path().join("preview.png"),
            dir.path().join("animation.gif")
        ]
    );
    let preview = Image::decode_png(&std::fs::read(&written[0]).unwrap()).unwrap();
    assert_eq!((preview.width, preview.height), (160, 120));
    let gif = decode_gif_frames(&std::fs::read(&written[1]).unwrap());
    assert_eq!(gif.len(), 4);
    assert!(gif.iter().all(|f| (f.width, f.height) == (80, 60)));
    // The wrong number of values is an error naming the frame.
    let short = [RunFrame {
        field: &[1.0],
        ..frames[0]
    }];
    let err = render::render_run(&rm, &fixed, &short, &params, dir.path()).unwrap_err();
    assert!(err.to_string().contains("frame 0"), "{err}");
}

/// Tets that touch the surface carry 1, interior tets 0: from outside only 1 (yellow) shows;
/// cut open, the cap shows the interior's 0 (purple) where the cut is.
#[test]
fn cut_away_shows_the_inside() {
    let (mesh, _) = beam([8, 4, 4]);
    let rm = RenderMesh::new(&mesh);
    let surface = rm.on_surface();
    let values: Vec<f64> = mesh
        .tets
        .iter()
        .map(|t| {
            if t.iter().any(|&v| surface[v]) {
                1.0
            } else {
                0.0
            }
        })
        .collect();
    let mut params = RenderParams {
        field: Some(FieldKind::J),
        azimuth_deg: -10.0,
        ..plain_params(320, 240)
    };
    let purple = render::viridis(0.0);
    let count = |img: &Image, c: [u8; 3]| {
        (0..img.height)
            .flat_map(|y| (0..img.width * 3 / 4).map(move |x| (x, y)))
            .filter(|&(x, y)| close(img.pixel(x, y), c, 3))
            .count()
    };
    let whole = render_one(&rm, &mesh.positions, &values, &[], &params, (0.0, 1.0));
    assert_eq!(count(&whole, purple), 0, "interior visible without a cut");
    params.clip = Some(Plane::new(Vec3::new(0.0, 0.0, 0.55), Vec3::z()));
    let cut = render_one(&rm, &mesh.positions, &values, &[], &params, (0.0, 1.0));
    assert!(
        count(&cut, purple) > 500,
        "{} purple pixels",
        count(&cut, purple)
    );
    let camera = render::fit_camera(&Bounds::of(&mesh.positions), &params);
    let centre = camera
        .project_to_pixel(&params, &Vec3::new(2.0, 0.5, 0.55))
        .unwrap();
    assert!(close(pixel_at(&cut, centre), purple, 3));
    // Nothing in front of the plane is drawn: the front face's colour (yellow) at a point of
    // the removed half would otherwise cover the cap.
    let front = camera
        .project_to_pixel(&params, &Vec3::new(2.0, 0.5, 1.0))
        .unwrap();
    assert!(!close(pixel_at(&cut, front), render::viridis(1.0), 3));
}

/// Fixed vertices get red markers where they are visible, and none appear without them.
#[test]
fn fixed_vertices_are_marked() {
    let (mesh, fixed) = beam([8, 2, 2]);
    let rm = RenderMesh::new(&mesh);
    let params = RenderParams {
        field: None,
        ..plain_params(320, 240)
    };
    let red = |c: [u8; 3]| c[0] > 180 && c[1] < 90 && c[2] < 90;
    let count = |img: &Image| {
        (0..img.height)
            .flat_map(|y| (0..img.width).map(move |x| (x, y)))
            .filter(|&(x, y)| red(img.pixel(x, y)))
            .count()
    };
    let none = render_one(&rm, &mesh.positions, &[], &[], &params, (0.0, 1.0));
    assert_eq!(count(&none), 0);
    let marked = render_one(&rm, &mesh.positions, &[], &fixed, &params, (0.0, 1.0));
    assert!(count(&marked) > 9 * 4, "{} red pixels", count(&marked));
    // The fixed end faces the camera (azimuth −35°): its centre vertex carries a marker.
    let camera = render::fit_camera(&Bounds::of(&mesh.positions), &params);
    let centre = camera
        .project_to_pixel(&params, &Vec3::new(0.0, 0.5, 0.5))
        .unwrap();
    assert!(
        red(pixel_at(&marked, centre)),
        "{:?}",
        pixel_at(&marked, centre)
    );
    // A vertex of the far end is not fixed and shows no marker.
    let tip = camera
        .project_to_pixel(&params, &Vec3::new(4.0, 0.5, 1.0))
        .unwrap();
    assert!(!red(pixel_at(&marked, tip)));
}

/// Every vertex of every frame lands inside the picture when the camera is fitted to the
/// whole run's bounds.
#[test]
fn camera_fits_every_frame() {
    let (mesh, _) = beam([8, 2, 2]);
    let frames: Vec<Vec<Vec3>> = (0..=4)
        .map(|k| bend(&mesh.positions, 0.5 * k as f64))
        .collect();
    let mut bounds = Bounds::empty();
    frames.iter().for_each(|f| bounds.include(f));
    for (az, el) in [(-35.0, 22.0), (90.0, 0.0), (200.0, 60.0), (0.0, -30.0)] {
        let params = RenderParams {
            width: 320,
            height: 240,
            azimuth_deg: az,
            elevation_deg: el,
            ..RenderParams::default()
        };
        let camera = render::fit_camera(&bounds, &params);
        for p in frames.iter().flatten() {
            let [x, y] = camera.project_to_pixel(&params, p).unwrap();
            assert!(
                (0.0..320.0).contains(&x) && (0.0..240.0).contains(&y),
                "({x}, {y}) outside at azimuth {az}, elevation {el}"
            );
        }
    }
}

/// The four plots of steps.csv are PNGs with text on them, drawn with the embedded font (no
/// system font needed).
#[test]
fn plots_of_steps_are_written() {
    let dir = tempfile::tempdir().unwrap();
    let csv = dir.path().join("steps.csv");
    write_sample_steps_csv(&csv);
    let written = render::plot_steps(&csv, dir.path()).unwrap();
    assert_eq!(written.len(), 4);
    for path in &written {
        let img = Image::decode_png(&std::fs::read(path).unwrap()).unwrap();
        assert_eq!((img.width, img.height), (900, 500));
        let dark = img
            .pixels
            .chunks(3)
            .filter(|c| c.iter().all(|&v| v < 90))
            .count();
        assert!(
            dark > 500,
            "{}: {dark} dark pixels (no text?)",
            path.display()
        );
    }
    let missing = render::plot_steps(&dir.path().join("nope.csv"), dir.path()).unwrap_err();
    assert!(missing.to_string().contains("nope.csv"), "{missing}");
}

/// probes.csv and reactions.csv (SPEC §13) are plotted against time, one coloured line per
/// column, with text; a malformed file is an error naming it and the line.
#[test]
fn plots_of_probes_and_reactions_are_written() {
    let dir = tempfile::tempdir().unwrap();
    let csv = dir.path().join("probes.csv");
    std::fs::write(
        &csv,
        "frame,time,tip_x,tip_y,tip_z\n0,0,0,0,0\n1,0.5,0.01,-0.2,0\n2,1,0.02,-0.35,0.001\n",
    )
    .unwrap();
    let png = dir.path().join("probes.png");
    let written =
        render::plot_series(&csv, &png, "probe displacements", "displacement [m]").unwrap();
    assert_eq!(written, png);
    let img = Image::decode_png(&std::fs::read(&png).unwrap()).unwrap();
    assert_eq!((img.width, img.height), (900, 500));
    let count = |want: [u8; 3]| {
        img.pixels
            .chunks(3)
            .filter(|c| (0..3).all(|k| c[k].abs_diff(want[k]) < 8))
            .count()
    };
    // The first two columns' colours (blue, orange) are drawn, and there is text.
    assert!(count([45, 105, 175]) > 100 && count([225, 120, 30]) > 100);
    let dark = img
        .pixels
        .chunks(3)
        .filter(|c| c.iter().all(|&v| v < 90))
        .count();
    assert!(dark > 500, "{dark} dark pixels (no text?)");
    std::fs::write(&csv, "frame,time,tip_x\n0,0,0\n1,0.5\n").unwrap();
    let err = render::plot_series(&csv, &png, "t", "y").unwrap_err();
    assert!(err.to_string().contains("probes.csv:3:"), "{err}");
}

/// Bad input is an error, not a panic: wrong lengths, zero size.
#[test]
fn mismatched_input_is_an_error() {
    let (mesh, _) = beam([2, 1, 1]);
    let rm = RenderMesh::new(&mesh);
    let params = RenderParams::default();
    let camera = render::fit_camera(&Bounds::of(&mesh.positions), &params);
    let view = SceneView {
        mesh: &rm,
        positions: &mesh.positions,
        field: &[1.0, 2.0],
        fixed: &[],
        time: 0.0,
        frame: 0,
    };
    let err = render::render(&view, &camera, &params, (0.0, 1.0)).unwrap_err();
    assert!(err.to_string().contains("displacement"), "{err}");
    let tiny = RenderParams {
        width: 4,
        ..RenderParams::default()
    };
    let view = SceneView {
        field: &vec![0.0; mesh.positions.len()],
        ..view
    };
    assert!(render::render(&view, &camera, &tiny, (0.0, 1.0)).is_err());
}

/// Where pictures for people go: `$TETSIM_GALLERY` or a folder in the temp dir.
fn gallery_dir() -> PathBuf {
    let dir = std::env::var_os("TETSIM_GALLERY")
        .map(PathBuf::from)
        .unwrap_or_else(|| std::env::temp_dir().join("tetsim-gallery"));
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// Render the bent beam in several looks and time 800×600 frames; writes PNGs and a GIF to
/// the gallery folder for a person to look at. Run in release for the timings:
/// `cargo test --release --test render -- --ignored --nocapture gallery`.
#[test]
#[ignore]
fn gallery_for_people() {
    let dir = gallery_dir();
    for cells in [[16, 4, 4], [48, 12, 12]] {
        let (mesh, fixed) = beam(cells);
        let body = body(&mesh);
        let rm = RenderMesh::new(&mesh);
        let frames: Vec<Vec<Vec3>> = (0..=20)
            .map(|k| bend(&mesh.positions, 1.2 * k as f64 / 20.0))
            .collect();
        let mut bounds = Bounds::empty();
        for f in &frames {
            bounds.include(f);
        }
        let last = frames.last().unwrap();
        let tag = format!("{}x{}x{}", cells[0], cells[1], cells[2]);
        let looks: Vec<(&str, RenderParams)> = vec![
            ("displacement", RenderParams::default()),
            (
                "von-mises-wire",
                RenderParams {
                    field: Some(FieldKind::VonMises),
                    wireframe: true,
                    ..RenderParams::default()
                },
            ),
            (
                "J-cut",
                RenderParams {
                    field: Some(FieldKind::J),
                    clip: Some(Plane::new(Vec3::new(0.0, 0.0, 0.5), Vec3::z())),
                    azimuth_deg: -20.0,
                    ..RenderParams::default()
                },
            ),
            (
                "plain-flat",
                RenderParams {
                    field: None,
                    shading: Shading::Flat,
                    wireframe: true,
                    azimuth_deg: 30.0,
                    elevation_deg: 35.0,
                    ..RenderParams::default()
                },
            ),
        ];
        for (name, params) in looks {
            let camera = render::fit_camera(&bounds, &params);
            let values: Vec<Vec<f64>> = frames
                .iter()
                .map(|x| {
                    render::field_values(params.field.unwrap_or(FieldKind::J), &body, x).unwrap()
                })
                .collect();
            let range = render::field_range(values.iter().map(|v| v.as_slice()));
            let view = SceneView {
                mesh: &rm,
                positions: last,
                field: values.last().unwrap(),
                fixed: &fixed,
                time: 0.667,
                frame: 20,
            };
            // Warm up once, then time ten renders: wall time, and CPU time over all threads
            // (which neighbours on a shared machine disturb less).
            let img = render::render(&view, &camera, &params, range).unwrap();
            let (start, cpu) = (Instant::now(), cpu_seconds());
            for _ in 0..10 {
                render::render(&view, &camera, &params, range).unwrap();
            }
            let ms = start.elapsed().as_secs_f64() * 1e3 / 10.0;
            let cpu_ms = (cpu_seconds() - cpu) * 1e3 / 10.0;
            println!(
                "{tag} {} tets, {} boundary triangles, {name}: {ms:.1} ms wall, {cpu_ms:.1} ms CPU \
                 per 800x600 frame ({} threads)",
                mesh.tets.len(),
                rm.faces().len(),
                rayon::current_num_threads()
            );
            img.write_png(dir.join(format!("beam_{tag}_{name}.png")))
                .unwrap();
        }
        if cells[0] == 16 {
            let params = RenderParams {
                width: 480,
                height: 360,
                ..RenderParams::default()
            };
            let camera = render::fit_camera(&bounds, &params);
            let values: Vec<Vec<f64>> = frames
                .iter()
                .map(|x| render::displacement_magnitudes(&mesh.positions, x))
                .collect();
            let range = render::field_range(values.iter().map(|v| v.as_slice()));
            let start = Instant::now();
            let images: Vec<Image> = frames
                .iter()
                .zip(&values)
                .enumerate()
                .map(|(k, (x, v))| {
                    let view = SceneView {
                        mesh: &rm,
                        positions: x,
                        field: v,
                        fixed: &fixed,
                        time: k as f64 / 30.0,
                        frame: k,
                    };
                    render::render(&view, &camera, &params, range).unwrap()
                })
                .collect();
            let rendered = start.elapsed();
            let path = dir.join("beam_animation.gif");
            render::write_gif(&path, &images, 5).unwrap();
            println!(
                "GIF: {} frames 480x360 rendered in {:.0} ms, encoded in {:.0} ms, {} kB",
                images.len(),
                rendered.as_secs_f64() * 1e3,
                (start.elapsed() - rendered).as_secs_f64() * 1e3,
                std::fs::metadata(&path).unwrap().len() / 1024
            );
            let last = decode_gif_frames(&std::fs::read(&path).unwrap())
                .pop()
                .unwrap();
            last.write_png(dir.join("beam_animation_last_frame.png"))
                .unwrap();
        }
    }
    // A twisted beam at rest-frame bounds plus the twist, and the rest frame itself.
    let (mesh, fixed) = beam([24, 6, 6]);
    let rm = RenderMesh::new(&mesh);
    let twisted: Vec<Vec3> = mesh
        .positions
        .iter()
        .map(|p| {
            let a = 0.5 * std::f64::consts::PI * p.x / 4.0;
            let (y, z) = (p.y - 0.5, p.z - 0.5);
            Vec3::new(
                p.x,
                0.5 + y * a.cos() - z * a.sin(),
                0.5 + y * a.sin() + z * a.cos(),
            )
        })
        .collect();
    let mut bounds = Bounds::of(&mesh.positions);
    bounds.include(&twisted);
    for (name, x, frame) in [("rest", &mesh.positions, 0), ("twist", &twisted, 30)] {
        let params = RenderParams {
            title: "twist.toml".into(),
            ..RenderParams::default()
        };
        let values = render::displacement_magnitudes(&mesh.positions, x);
        let range =
            render::field_range([
                render::displacement_magnitudes(&mesh.positions, &twisted).as_slice()
            ]);
        let view = SceneView {
            mesh: &rm,
            positions: x,
            field: &values,
            fixed: &fixed,
            time: frame as f64 / 30.0,
            frame,
        };
        let camera = render::fit_camera(&bounds, &params);
        render::render(&view, &camera, &params, range)
            .unwrap()
            .write_png(dir.join(format!("beam_{name}.png")))
            .unwrap();
    }
    write_sample_steps_csv(&dir.join("steps.csv"));
    let plots = render::plot_steps(&dir.join("steps.csv"), &dir).unwrap();
    println!("plots: {plots:?}");
    println!("pictures in {}", dir.display());
}

/// CPU time of this process so far (user + system, all threads), from /proc on Linux; 0
/// elsewhere.
fn cpu_seconds() -> f64 {
    let Ok(stat) = std::fs::read_to_string("/proc/self/stat") else {
        return 0.0;
    };
    // Fields after the parenthesised command name; utime and stime are the 12th and 13th.
    let rest = &stat[stat.rfind(')').map_or(0, |i| i + 2)..];
    let fields: Vec<f64> = rest
        .split_whitespace()
        .skip(11)
        .take(2)
        .filter_map(|f| f.parse().ok())
        .collect();
    // Clock ticks are 100 per second on Linux.
    fields.iter().sum::<f64>() / 100.0
}

/// A plausible steps.csv: 60 frames, Newton 2–5, one frame that did not converge.
fn write_sample_steps_csv(path: &Path) {
    let mut s = String::from(
        "frame,time,newton_iterations,cg_iterations,residual,converged,elastic_energy,\
kinetic_energy,min_J,inverted_elements,wall_seconds\n",
    );
    s.push_str("0,0,0,0,0,true,0,0,1,0,0\n");
    for f in 1..=60 {
        let t = f as f64 / 30.0;
        let newton = 2 + (f * 7 % 4);
        let converged = f != 23;
        let residual = if converged {
            1e-7 / (1 + f % 5) as f64
        } else {
            3e-3
        };
        let elastic = 40.0 * (1.0 - (-(t * 3.0)).exp() * (t * 9.0).cos());
        let kinetic = 25.0 * (-(t * 2.0)).exp() * (t * 9.0).sin().powi(2);
        s.push_str(&format!(
            "{f},{t},{newton},{},{residual},{converged},{elastic},{kinetic},0.95,0,0.02\n",
            newton * 37 + f % 11
        ));
    }
    std::fs::write(path, s).unwrap();
}

/// Every frame of a GIF, composited onto the logical screen as a viewer shows it.
fn decode_gif_frames(bytes: &[u8]) -> Vec<Image> {
    let mut options = gif::DecodeOptions::new();
    options.set_color_output(gif::ColorOutput::RGBA);
    let mut decoder = options.read_info(bytes).unwrap();
    let (w, h) = (decoder.width() as u32, decoder.height() as u32);
    let mut screen = Image::new(w, h, [0, 0, 0]);
    let mut frames = Vec::new();
    while let Some(frame) = decoder.read_next_frame().unwrap() {
        for y in 0..frame.height as u32 {
            for x in 0..frame.width as u32 {
                let i = 4 * (y * frame.width as u32 + x) as usize;
                let px = &frame.buffer[i..i + 4];
                if px[3] > 0 {
                    screen.set_pixel(
                        frame.left as u32 + x,
                        frame.top as u32 + y,
                        [px[0], px[1], px[2]],
                    );
                }
            }
        }
        frames.push(screen.clone());
    }
    frames
}

/// The run display as a person sees it: a progress bar on a terminal (plain lines when
/// piped), then the summary. Watch it with
/// `cargo test --test render -- --ignored --nocapture progress_display_demo`.
#[cfg(feature = "cli")]
#[test]
#[ignore]
fn progress_display_demo() {
    use tetsim::progress::{DisplayMode, FrameReport, RunDisplay};
    let total = 40;
    let mut display = RunDisplay::new(total, DisplayMode::Auto);
    let out = Path::new("out");
    let mut files = Vec::new();
    for frame in 1..=total {
        std::thread::sleep(std::time::Duration::from_millis(60));
        let newton = 2 + frame % 3;
        display.frame_done(&FrameReport {
            frame,
            time: frame as f64 / 30.0,
            newton_iterations: newton,
            cg_iterations: 40 * newton + frame % 7,
            residual: 1e-7 / (1 + frame % 4) as f64,
            absolute_residual: 1e-9 / (1 + frame % 4) as f64,
            converged: frame != 17,
            within_floor: false,
            min_j: 1.0 - 0.004 * frame as f64,
            wall_seconds: 0.06,
        });
        files.push(out.join(format!("frame_{frame:04}.vtu")));
    }
    for name in ["frames.pvd", "steps.csv", "preview.png", "animation.gif"] {
        files.push(out.join(name));
    }
    println!("{}", display.finish(out, &files));
}

/// Obstacles (SPEC §11): a ground plane moves the floor to its own height, and an obstacle
/// triangle beside the body is drawn (in the obstacle colour, not the body's).
#[test]
fn obstacles_are_drawn_and_a_ground_plane_is_the_floor() {
    let mesh = box_mesh(Vec3::zeros(), Vec3::repeat(1.0), [1, 1, 1]);
    let rm = RenderMesh::new(&mesh);
    let params = RenderParams {
        width: 80,
        height: 60,
        field: None,
        ..RenderParams::default()
    };
    let camera = render::fit_camera(&Bounds::of(&mesh.positions), &params);
    let view = SceneView {
        mesh: &rm,
        positions: &mesh.positions,
        field: &[],
        fixed: &[],
        time: 0.0,
        frame: 0,
    };
    let draw = |obstacles: &[[Vec3; 3]], params: &RenderParams| {
        render::render_with_obstacles(&view, obstacles, &camera, params, (0.0, 1.0)).unwrap()
    };
    let plain = draw(&[], &params);
    let far_floor = draw(
        &[],
        &RenderParams {
            ground: Some(Plane::new(Vec3::new(0.0, -3.0, 0.0), Vec3::y())),
            ..params.clone()
        },
    );
    assert_ne!(plain.pixels, far_floor.pixels, "the ground moved nothing");
    let wall = [[
        Vec3::new(-3.0, -1.0, -1.0),
        Vec3::new(4.0, -1.0, -1.0),
        Vec3::new(0.5, 3.0, -1.0),
    ]];
    let with_wall = draw(&wall, &params);
    assert_ne!(plain.pixels, with_wall.pixels, "the obstacle was not drawn");
    assert!(render::ground_plane(&[Plane::new(Vec3::zeros(), Vec3::x())], Vec3::y()).is_none());
}

/// With gravity tilted by 30° (a scene set in a slope's frame), the picture's up is against
/// gravity: gravity points straight down the image, and the ground plane (normal +y), still
/// the ground, shows tilted across it.
#[test]
fn gravity_points_down_the_picture_and_a_slope_shows_tilted() {
    let gravity = Vec3::new(4.905, -8.496, 0.0);
    let up = render::up_from_gravity(gravity);
    assert!((up + gravity.normalize()).norm() < 1e-12);
    assert_eq!(render::up_from_gravity(Vec3::zeros()), Vec3::y());
    let params = RenderParams {
        up,
        ..RenderParams::default()
    };
    let block = Bounds::of(&[Vec3::zeros(), Vec3::new(0.2, 0.1, 0.2)]);
    let camera = render::fit_camera(&block, &params);
    let g = gravity.normalize();
    assert!(camera.right.dot(&g).abs() < 1e-12, "gravity leans sideways");
    assert!(camera.up.dot(&g) < -0.9, "gravity does not point down");
    let slope = Plane::new(Vec3::zeros(), Vec3::y());
    assert_eq!(render::ground_plane(&[slope], up), Some(0));
    // The slope's normal leans by its 30° across the screen: the ground is drawn tilted.
    let lean = slope.normal.dot(&camera.right).asin().to_degrees().abs();
    assert!(lean > 20.0 && lean < 31.0, "the slope leans {lean}°");
}

/// A body inside a closed box obstacle is hidden by it, unless the obstacle's near half is
/// cut away (the default), which shows the body.
#[test]
fn an_obstacle_around_the_body_is_cut_away() {
    let mesh = box_mesh(Vec3::zeros(), Vec3::repeat(1.0), [2, 2, 2]);
    let rm = RenderMesh::new(&mesh);
    // A closed box around the body, two triangles a face, normals outwards.
    let (lo, hi) = (Vec3::repeat(-1.0), Vec3::repeat(2.0));
    let corner = |i: usize| {
        Vec3::new(
            if i & 1 == 0 { lo.x } else { hi.x },
            if i & 2 == 0 { lo.y } else { hi.y },
            if i & 4 == 0 { lo.z } else { hi.z },
        )
    };
    let quads = [
        [0, 2, 3, 1],
        [4, 5, 7, 6],
        [0, 1, 5, 4],
        [2, 6, 7, 3],
        [0, 4, 6, 2],
        [1, 3, 7, 5],
    ];
    let walls: Vec<[Vec3; 3]> = quads
        .iter()
        .flat_map(|q| {
            [
                [corner(q[0]), corner(q[1]), corner(q[2])],
                [corner(q[0]), corner(q[2]), corner(q[3])],
            ]
        })
        .collect();
    // Unlit and without a field: the body in its one plain colour.
    let params = RenderParams {
        field: None,
        show_floor: false,
        ..plain_params(160, 120)
    };
    let view = SceneView {
        mesh: &rm,
        positions: &mesh.positions,
        field: &[],
        fixed: &[],
        time: 0.0,
        frame: 0,
    };
    let mut bounds = Bounds::of(&mesh.positions);
    walls.iter().for_each(|t| bounds.include(t));
    let camera = render::fit_camera(&bounds, &params);
    // The body's one plain colour marks its pixels.
    let body_pixels = |params: &RenderParams| {
        let img =
            render::render_with_obstacles(&view, &walls, &camera, params, (0.0, 1.0)).unwrap();
        (0..img.height)
            .flat_map(|y| (0..img.width).map(move |x| (x, y)))
            .filter(|&(x, y)| close(img.pixel(x, y), [142, 170, 204], 6))
            .count()
    };
    let hidden = body_pixels(&RenderParams {
        cut_obstacles: false,
        ..params.clone()
    });
    assert_eq!(hidden, 0, "the closed box should hide the body");
    let shown = body_pixels(&params);
    assert!(
        shown > 200,
        "only {shown} pixels of the body show through the cut"
    );
}
