//! Plots of the per-frame statistics in `steps.csv`: Newton iterations, CG iterations, the
//! final residual (log axis) and the energies, one PNG each.
//!
//! plotters draws into an RGB buffer with its `ab_glyph` text backend and the embedded DejaVu
//! Sans, so no system font (and no fontconfig) is needed; the PNG is encoded by
//! [`Image::write_png`] (atomic), so plotters' `image`-crate encoder is not built either.

use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::sync::Once;

use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::FontStyle;

use super::image::Image;
use super::text::FONT_BYTES;
use crate::error::{Error, Result};

/// Size of each plot in pixels.
const SIZE: (u32, u32) = (900, 500);
/// plotters' font family name for the embedded font.
const FAMILY: &str = "sans-serif";

const BLUE: RGBColor = RGBColor(45, 105, 175);
const ORANGE: RGBColor = RGBColor(225, 120, 30);
const RED: RGBColor = RGBColor(215, 45, 40);
const GREY: RGBColor = RGBColor(90, 94, 102);

/// The columns read from `steps.csv` (by header name, so extra columns are fine).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct StepsTable {
    /// Frame numbers.
    pub frame: Vec<f64>,
    /// Newton iterations per frame.
    pub newton_iterations: Vec<f64>,
    /// CG iterations per frame (summed over its Newton iterations).
    pub cg_iterations: Vec<f64>,
    /// Final residual norm per frame.
    pub residual: Vec<f64>,
    /// Whether the frame's solve converged.
    pub converged: Vec<bool>,
    /// Elastic energy per frame (J).
    pub elastic_energy: Vec<f64>,
    /// Kinetic energy per frame (J).
    pub kinetic_energy: Vec<f64>,
    /// Gravitational potential energy per frame (J), when the file has the column (an
    /// extension column: older files and other writers may lack it).
    pub gravitational_energy: Option<Vec<f64>>,
}

impl StepsTable {
    /// Parse `steps.csv` text; `path` only names the file in errors. Columns are found by
    /// their header names; rows must have at least as many fields as the header.
    pub fn parse(path: &Path, text: &str) -> Result<StepsTable> {
        let mut lines = text
            .lines()
            .enumerate()
            .filter(|(_, l)| !l.trim().is_empty());
        let (_, header) = lines
            .next()
            .ok_or_else(|| Error::parse(path, Some(1), "empty file: expected a header line"))?;
        let names: HashMap<&str, usize> = header
            .split(',')
            .enumerate()
            .map(|(i, n)| (n.trim(), i))
            .collect();
        let column = |name: &str| {
            names.get(name).copied().ok_or_else(|| {
                Error::parse(
                    path,
                    Some(1),
                    format!("missing column {name:?} in the header"),
                )
            })
        };
        let cols = [
            column("frame")?,
            column("newton_iterations")?,
            column("cg_iterations")?,
            column("residual")?,
            column("converged")?,
            column("elastic_energy")?,
            column("kinetic_energy")?,
        ];
        let gravity_col = names.get("gravitational_energy").copied();
        let header_len = header.split(',').count();
        let mut table = StepsTable {
            gravitational_energy: gravity_col.map(|_| Vec::new()),
            ..StepsTable::default()
        };
        for (i, line) in lines {
            let fields: Vec<&str> = line.split(',').map(str::trim).collect();
            if fields.len() < header_len {
                return Err(Error::parse(
                    path,
                    Some(i + 1),
                    format!("{} fields, the header has {header_len}", fields.len()),
                ));
            }
            let number = |c: usize| {
                fields[c].parse::<f64>().map_err(|_| {
                    Error::parse(path, Some(i + 1), format!("not a number: {:?}", fields[c]))
                })
            };
            table.frame.push(number(cols[0])?);
            table.newton_iterations.push(number(cols[1])?);
            table.cg_iterations.push(number(cols[2])?);
            table.residual.push(number(cols[3])?);
            table.converged.push(match fields[cols[4]] {
                "true" | "1" | "True" | "TRUE" => true,
                "false" | "0" | "False" | "FALSE" => false,
                other => {
                    return Err(Error::parse(
                        path,
                        Some(i + 1),
                        format!("converged must be true or false, not {other:?}"),
                    ));
                }
            });
            table.elastic_energy.push(number(cols[5])?);
            table.kinetic_energy.push(number(cols[6])?);
            if let (Some(c), Some(v)) = (gravity_col, table.gravitational_energy.as_mut()) {
                v.push(number(c)?);
            }
        }
        Ok(table)
    }
}

/// Read `csv_path` (the SPEC §10 `steps.csv`) and write `steps_newton.png`, `steps_cg.png`,
/// `steps_residual.png` and `steps_energy.png` into `out_dir`. Returns the paths written.
pub fn plot_steps(csv_path: &Path, out_dir: &Path) -> Result<Vec<PathBuf>> {
    let text = crate::io::read_text(csv_path)?;
    let table = StepsTable::parse(csv_path, &text)?;
    register_font();
    let mut written = Vec::new();
    let plots: [(&str, PlotFn); 4] = [
        ("steps_newton.png", newton_plot),
        ("steps_cg.png", cg_plot),
        ("steps_residual.png", residual_plot),
        ("steps_energy.png", energy_plot),
    ];
    for (name, draw) in plots {
        let path = out_dir.join(name);
        let img = draw_to_image(&table, draw).map_err(|e| {
            Error::io(
                &path,
                std::io::Error::other(format!("plotting failed: {e}")),
            )
        })?;
        img.write_png(&path)?;
        written.push(path);
    }
    Ok(written)
}

/// A per-frame table whose columns after `frame,time` are all numbers (probes.csv,
/// reactions.csv, SPEC §13).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct SeriesTable {
    /// The `time` column (s; quasistatic: the load factor).
    pub time: Vec<f64>,
    /// Every other column after `frame,time`: (name, values).
    pub columns: Vec<(String, Vec<f64>)>,
}

impl SeriesTable {
    /// Parse the text of a `frame,time,...` CSV; `path` only names the file in errors.
    pub fn parse(path: &Path, text: &str) -> Result<SeriesTable> {
        let mut lines = text
            .lines()
            .enumerate()
            .filter(|(_, l)| !l.trim().is_empty());
        let (_, header) = lines
            .next()
            .ok_or_else(|| Error::parse(path, Some(1), "empty file: expected a header line"))?;
        let names: Vec<&str> = header.split(',').map(str::trim).collect();
        if names.len() < 2 || names[0] != "frame" || names[1] != "time" {
            return Err(Error::parse(
                path,
                Some(1),
                "the header must start with frame,time",
            ));
        }
        let mut table = SeriesTable {
            time: Vec::new(),
            columns: names[2..]
                .iter()
                .map(|n| (n.to_string(), Vec::new()))
                .collect(),
        };
        for (i, line) in lines {
            let fields: Vec<&str> = line.split(',').map(str::trim).collect();
            if fields.len() != names.len() {
                return Err(Error::parse(
                    path,
                    Some(i + 1),
                    format!("{} fields, the header has {}", fields.len(), names.len()),
                ));
            }
            let number = |s: &str| {
                s.parse::<f64>()
                    .map_err(|_| Error::parse(path, Some(i + 1), format!("not a number: {s:?}")))
            };
            table.time.push(number(fields[1])?);
            for (column, field) in table.columns.iter_mut().zip(&fields[2..]) {
                column.1.push(number(field)?);
            }
        }
        Ok(table)
    }
}

/// Plot every column of a `frame,time,...` CSV against time into `png` (probes.csv as
/// probes.png, reactions.csv as reactions.png). Returns the path written.
pub fn plot_series(csv_path: &Path, png: &Path, title: &str, y_label: &str) -> Result<PathBuf> {
    let text = crate::io::read_text(csv_path)?;
    let table = SeriesTable::parse(csv_path, &text)?;
    register_font();
    let mut buf = vec![255u8; 3 * (SIZE.0 * SIZE.1) as usize];
    {
        let area = BitMapBackend::with_buffer(&mut buf, SIZE).into_drawing_area();
        let drawn: DrawResult = (|| {
            area.fill(&WHITE)?;
            series_plot(&table, &area, title, y_label)?;
            area.present()?;
            Ok(())
        })();
        drawn
            .map_err(|e| Error::io(png, std::io::Error::other(format!("plotting failed: {e}"))))?;
    }
    Image {
        width: SIZE.0,
        height: SIZE.1,
        pixels: buf,
    }
    .write_png(png)?;
    Ok(png.to_path_buf())
}

/// Colours of [`series_plot`]'s lines, in column order (then again).
const PALETTE: [RGBColor; 9] = [
    BLUE,
    ORANGE,
    RGBColor(60, 160, 80),
    RED,
    RGBColor(140, 90, 180),
    RGBColor(140, 95, 75),
    RGBColor(220, 110, 180),
    GREY,
    RGBColor(30, 170, 190),
];

fn series_plot(t: &SeriesTable, area: &Area, title: &str, y_label: &str) -> DrawResult {
    let finite = |v: &&f64| v.is_finite();
    let lo_t = t
        .time
        .iter()
        .filter(finite)
        .copied()
        .fold(f64::INFINITY, f64::min);
    let hi_t = t
        .time
        .iter()
        .filter(finite)
        .copied()
        .fold(f64::NEG_INFINITY, f64::max);
    let (x0, x1) = if !(lo_t.is_finite() && hi_t.is_finite()) {
        (0.0, 1.0)
    } else if hi_t - lo_t <= 0.0 {
        (lo_t - 0.5, hi_t + 0.5)
    } else {
        (lo_t, hi_t)
    };
    let values = t.columns.iter().flat_map(|c| c.1.iter()).filter(finite);
    let lo = values.clone().copied().fold(0.0, f64::min);
    let hi = values.copied().fold(0.0, f64::max);
    // Room above for the legend; a flat zero line still gets an axis.
    let span = if hi > lo { hi - lo } else { 1.0 };
    let (y0, y1) = (lo - 0.05 * span, hi + 0.35 * span);
    let mut chart = ChartBuilder::on(area)
        .caption(title, title_font(24.0))
        .margin(16)
        .x_label_area_size(44)
        .y_label_area_size(80)
        .build_cartesian_2d(x0..x1, y0..y1)?;
    chart
        .configure_mesh()
        .light_line_style(RGBColor(236, 237, 240))
        .bold_line_style(RGBColor(214, 217, 222))
        .max_light_lines(4)
        .x_desc("time [s] (quasistatic: load factor)")
        .y_desc(y_label)
        // A tick at zero may come out as ±1e-16 of the range: show it as 0.
        .x_label_formatter(&|v| format_energy(snap(*v, x1 - x0)))
        .y_label_formatter(&|v| format_energy(snap(*v, y1 - y0)))
        .label_style(title_font(15.0))
        .axis_desc_style(title_font(17.0))
        .draw()?;
    for (k, (name, values)) in t.columns.iter().enumerate() {
        let colour = PALETTE[k % PALETTE.len()];
        let points: Vec<(f64, f64)> = t
            .time
            .iter()
            .copied()
            .zip(values.iter().copied())
            .filter(|(x, y)| x.is_finite() && y.is_finite())
            .collect();
        chart
            .draw_series(LineSeries::new(points, colour.stroke_width(2)))?
            .label(name.as_str())
            .legend(move |(x, y)| PathElement::new([(x, y), (x + 18, y)], colour.stroke_width(2)));
    }
    finish_legend(&mut chart)
}

/// `v`, or 0 when it is rounding next to an axis range of `span`.
fn snap(v: f64, span: f64) -> f64 {
    if v.abs() < 1e-9 * span.abs() { 0.0 } else { v }
}

type Area<'a> = DrawingArea<BitMapBackend<'a>, Shift>;
type DrawResult = std::result::Result<(), Box<dyn std::error::Error>>;
type PlotFn = fn(&StepsTable, &Area) -> DrawResult;

fn register_font() {
    static ONCE: Once = Once::new();
    ONCE.call_once(|| {
        // The embedded font is valid; a failure here would be a broken build.
        if plotters::style::register_font(FAMILY, FontStyle::Normal, FONT_BYTES).is_err() {
            panic!("the embedded DejaVu Sans was rejected by plotters");
        }
    });
}

fn draw_to_image(table: &StepsTable, draw: PlotFn) -> ImageResult {
    let mut buf = vec![255u8; 3 * (SIZE.0 * SIZE.1) as usize];
    {
        let area = BitMapBackend::with_buffer(&mut buf, SIZE).into_drawing_area();
        area.fill(&WHITE)?;
        draw(table, &area)?;
        area.present()?;
    }
    Ok(Image {
        width: SIZE.0,
        height: SIZE.1,
        pixels: buf,
    })
}

type ImageResult = std::result::Result<Image, Box<dyn std::error::Error>>;

/// (lo, hi) of the frames, widened when there is only one.
fn frame_range(t: &StepsTable) -> (f64, f64) {
    let lo = t.frame.iter().copied().fold(f64::INFINITY, f64::min);
    let hi = t.frame.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    if !(lo.is_finite() && hi.is_finite()) {
        (0.0, 1.0)
    } else if hi - lo < 1.0 {
        (lo - 0.5, hi + 0.5)
    } else {
        (lo, hi)
    }
}

/// (0, max·1.3), at least (0, 1): the headroom keeps the legend off the data.
fn up_to_max(values: &[f64]) -> (f64, f64) {
    let max = values
        .iter()
        .copied()
        .filter(|v| v.is_finite())
        .fold(0.0, f64::max);
    (0.0, if max > 0.0 { 1.3 * max } else { 1.0 })
}

fn title_font(size: f64) -> FontDesc<'static> {
    FontDesc::new(FontFamily::Name(FAMILY), size, FontStyle::Normal)
}

/// A per-frame count as a line with dots, frames that did not converge as red dots.
fn count_plot(
    t: &StepsTable,
    area: &Area,
    values: &[f64],
    title: &str,
    y_label: &str,
) -> DrawResult {
    let (x0, x1) = frame_range(t);
    let (y0, y1) = up_to_max(values);
    let mut chart = ChartBuilder::on(area)
        .caption(title, title_font(24.0))
        .margin(16)
        .x_label_area_size(44)
        .y_label_area_size(64)
        .build_cartesian_2d(x0..x1, y0..y1)?;
    chart
        .configure_mesh()
        .light_line_style(RGBColor(236, 237, 240))
        .bold_line_style(RGBColor(214, 217, 222))
        .max_light_lines(4)
        .x_desc("frame")
        .y_desc(y_label)
        .x_label_formatter(&|v| format_tick(*v))
        .y_label_formatter(&|v| format_tick(*v))
        .label_style(title_font(15.0))
        .axis_desc_style(title_font(17.0))
        .draw()?;
    let points: Vec<(f64, f64)> = t
        .frame
        .iter()
        .copied()
        .zip(values.iter().copied())
        .collect();
    chart
        .draw_series(LineSeries::new(points.clone(), BLUE.stroke_width(2)))?
        .label(y_label)
        .legend(|(x, y)| PathElement::new([(x, y), (x + 18, y)], BLUE.stroke_width(2)));
    draw_dots(&mut chart, t, &points)?;
    finish_legend(&mut chart)
}

/// Blue dots, red for frames that did not converge.
fn draw_dots<'a, X, Y>(
    chart: &mut ChartContext<'a, BitMapBackend<'a>, Cartesian2d<X, Y>>,
    t: &StepsTable,
    points: &[(f64, f64)],
) -> DrawResult
where
    X: Ranged<ValueType = f64>,
    Y: Ranged<ValueType = f64>,
{
    let small = points.len() <= 200;
    chart.draw_series(
        points
            .iter()
            .zip(&t.converged)
            .filter(|(_, ok)| small && **ok)
            .map(|(&p, _)| Circle::new(p, 3, BLUE.filled())),
    )?;
    let failed: Vec<(f64, f64)> = points
        .iter()
        .zip(&t.converged)
        .filter(|(_, ok)| !**ok)
        .map(|(&p, _)| p)
        .collect();
    if !failed.is_empty() {
        chart
            .draw_series(failed.into_iter().map(|p| Circle::new(p, 5, RED.filled())))?
            .label("did not converge")
            .legend(|(x, y)| Circle::new((x + 9, y), 5, RED.filled()));
    }
    Ok(())
}

fn finish_legend<'a, X, Y>(
    chart: &mut ChartContext<'a, BitMapBackend<'a>, Cartesian2d<X, Y>>,
) -> DrawResult
where
    X: Ranged<ValueType = f64>,
    Y: Ranged<ValueType = f64>,
{
    chart
        .configure_series_labels()
        .position(SeriesLabelPosition::UpperRight)
        .background_style(WHITE.mix(0.85))
        .border_style(RGBColor(200, 203, 210))
        .label_font(title_font(15.0))
        .draw()?;
    Ok(())
}

fn newton_plot(t: &StepsTable, area: &Area) -> DrawResult {
    count_plot(
        t,
        area,
        &t.newton_iterations,
        "Newton iterations per frame",
        "Newton iterations [count]",
    )
}

fn cg_plot(t: &StepsTable, area: &Area) -> DrawResult {
    count_plot(
        t,
        area,
        &t.cg_iterations,
        "CG iterations per frame",
        "CG iterations [count]",
    )
}

/// The final residual on a log axis; zero residuals (a body at rest) are left out.
fn residual_plot(t: &StepsTable, area: &Area) -> DrawResult {
    let points: Vec<(f64, f64)> = t
        .frame
        .iter()
        .copied()
        .zip(t.residual.iter().copied())
        .filter(|(_, r)| *r > 0.0 && r.is_finite())
        .collect();
    let (x0, x1) = frame_range(t);
    let lo = points.iter().map(|p| p.1).fold(f64::INFINITY, f64::min);
    let hi = points.iter().map(|p| p.1).fold(f64::NEG_INFINITY, f64::max);
    let (lo, hi) = if lo.is_finite() {
        (lo / 3.0, hi * 30.0)
    } else {
        (1e-12, 1.0)
    };
    let mut chart = ChartBuilder::on(area)
        .caption("final Newton residual ‖rhs‖ per frame", title_font(24.0))
        .margin(16)
        .x_label_area_size(44)
        .y_label_area_size(80)
        .build_cartesian_2d(x0..x1, (lo..hi).log_scale())?;
    chart
        .configure_mesh()
        .light_line_style(RGBColor(236, 237, 240))
        .bold_line_style(RGBColor(214, 217, 222))
        .max_light_lines(4)
        .x_desc("frame")
        .y_desc("residual [N] (log scale)")
        .x_label_formatter(&|v| format_tick(*v))
        .y_label_formatter(&|v| format!("{v:.0e}"))
        .label_style(title_font(15.0))
        .axis_desc_style(title_font(17.0))
        .draw()?;
    chart
        .draw_series(LineSeries::new(points.clone(), GREY.stroke_width(2)))?
        .label("residual [N]")
        .legend(|(x, y)| PathElement::new([(x, y), (x + 18, y)], GREY.stroke_width(2)));
    let kept = StepsTable {
        converged: t
            .frame
            .iter()
            .zip(&t.residual)
            .zip(&t.converged)
            .filter(|((_, r), _)| **r > 0.0 && r.is_finite())
            .map(|(_, c)| *c)
            .collect(),
        ..StepsTable::default()
    };
    draw_dots(&mut chart, &kept, &points)?;
    finish_legend(&mut chart)
}

/// Elastic, kinetic and total energy; the total includes the change of gravitational energy
/// since the first frame when the file has it (so a falling body's total stays level but for
/// damping and backward Euler's dissipation, and may go below zero).
fn energy_plot(t: &StepsTable, area: &Area) -> DrawResult {
    let gravity = |i: usize| {
        t.gravitational_energy
            .as_ref()
            .map_or(0.0, |g| g[i] - g.first().copied().unwrap_or(0.0))
    };
    let total: Vec<f64> = (0..t.frame.len())
        .map(|i| t.elastic_energy[i] + t.kinetic_energy[i] + gravity(i))
        .collect();
    let (x0, x1) = frame_range(t);
    let all: Vec<f64> = [&t.elastic_energy[..], &t.kinetic_energy[..], &total[..]].concat();
    let (_, y1) = up_to_max(&all);
    let low = all
        .iter()
        .copied()
        .filter(|v| v.is_finite())
        .fold(0.0, f64::min);
    let y0 = if low < 0.0 { 1.3 * low } else { 0.0 };
    let mut chart = ChartBuilder::on(area)
        .caption("energy per frame", title_font(24.0))
        .margin(16)
        .x_label_area_size(44)
        .y_label_area_size(80)
        .build_cartesian_2d(x0..x1, y0..y1)?;
    chart
        .configure_mesh()
        .light_line_style(RGBColor(236, 237, 240))
        .bold_line_style(RGBColor(214, 217, 222))
        .max_light_lines(4)
        .x_desc("frame")
        .y_desc("energy [J]")
        .x_label_formatter(&|v| format_tick(*v))
        .y_label_formatter(&|v| format_energy(*v))
        .label_style(title_font(15.0))
        .axis_desc_style(title_font(17.0))
        .draw()?;
    let total_label = match t.gravitational_energy {
        Some(_) => "total (with gravity)",
        None => "total",
    };
    for (values, colour, label) in [
        (&total, GREY, total_label),
        (&t.elastic_energy, BLUE, "elastic"),
        (&t.kinetic_energy, ORANGE, "kinetic"),
    ] {
        let pts: Vec<(f64, f64)> = t
            .frame
            .iter()
            .copied()
            .zip(values.iter().copied())
            .collect();
        chart
            .draw_series(LineSeries::new(pts, colour.stroke_width(2)))?
            .label(label)
            .legend(move |(x, y)| PathElement::new([(x, y), (x + 18, y)], colour.stroke_width(2)));
    }
    finish_legend(&mut chart)
}

/// Whole numbers without decimals, others with up to two.
fn format_tick(v: f64) -> String {
    if (v - v.round()).abs() < 1e-9 {
        format!("{v:.0}")
    } else {
        let s = format!("{v:.2}");
        s.trim_end_matches('0').trim_end_matches('.').to_string()
    }
}

/// Axis numbers: plain when moderate, scientific otherwise.
fn format_energy(v: f64) -> String {
    let a = v.abs();
    if v == 0.0 || (1e-2..1e5).contains(&a) {
        let s = format!("{v:.3}");
        let s = s.trim_end_matches('0').trim_end_matches('.');
        s.to_string()
    } else {
        format!("{v:.1e}")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const CSV: &str = "frame,time,newton_iterations,cg_iterations,residual,converged,\
elastic_energy,kinetic_energy,min_J,inverted_elements,wall_seconds,extra\n\
0,0,0,0,0,true,0,0,1,0,0,x\n1,0.03,3,40,1e-8,true,2.5,1.0,0.99,0,0.01,y\n";

    #[test]
    fn columns_are_found_by_name() {
        let t = StepsTable::parse(Path::new("steps.csv"), CSV).unwrap();
        assert_eq!(t.frame, vec![0.0, 1.0]);
        assert_eq!(t.cg_iterations, vec![0.0, 40.0]);
        assert_eq!(t.converged, vec![true, true]);
        assert_eq!(t.kinetic_energy, vec![0.0, 1.0]);
        assert_eq!(t.gravitational_energy, None);
        let with_gravity = CSV
            .replace(",extra\n", ",gravitational_energy\n")
            .replace(",x\n", ",5\n")
            .replace(",y\n", ",1.5\n");
        let t = StepsTable::parse(Path::new("steps.csv"), &with_gravity).unwrap();
        assert_eq!(t.gravitational_energy, Some(vec![5.0, 1.5]));
    }

    #[test]
    fn bad_rows_are_located() {
        let bad = CSV.replace("1e-8,true", "1e-8,maybe");
        let err = StepsTable::parse(Path::new("steps.csv"), &bad).unwrap_err();
        assert!(err.to_string().starts_with("steps.csv:3:"), "{err}");
        let missing = "frame,time\n0,0\n";
        let err = StepsTable::parse(Path::new("s.csv"), missing).unwrap_err();
        assert!(err.to_string().contains("newton_iterations"), "{err}");
    }

    #[test]
    fn series_tables_read_every_column_after_frame_and_time() {
        let text = "frame,time,tip_x,tip_y\n0,0,0,0\n1,0.5,1e-3,-2\n";
        let t = SeriesTable::parse(Path::new("p.csv"), text).unwrap();
        assert_eq!(t.time, vec![0.0, 0.5]);
        assert_eq!(t.columns[1], ("tip_y".to_string(), vec![0.0, -2.0]));
        let short = SeriesTable::parse(Path::new("p.csv"), "frame,time,a\n0,0\n").unwrap_err();
        assert!(short.to_string().starts_with("p.csv:2:"), "{short}");
        assert!(SeriesTable::parse(Path::new("p.csv"), "time,frame\n").is_err());
    }

    #[test]
    fn energy_labels_are_short() {
        assert_eq!(format_energy(2.5), "2.5");
        assert_eq!(format_energy(0.0), "0");
        assert_eq!(format_energy(2.5e7), "2.5e7");
    }
}
