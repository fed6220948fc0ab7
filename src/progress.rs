//! The run display: a progress bar while frames are computed (frame count, frames per second,
//! ETA and the current Newton/CG counts), plain lines when stderr is not a terminal (logs, CI),
//! nothing in quiet mode, and a one-screen summary at the end.
//!
//! The run loop maps its solver statistics onto [`FrameReport`] and calls
//! [`RunDisplay::frame_done`] once per frame, then [`RunDisplay::finish`] for the summary.

use std::fmt::Write as _;
use std::io::IsTerminal;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use indicatif::{ProgressBar, ProgressDrawTarget, ProgressState, ProgressStyle};

/// What one frame's solve reported (plain numbers, so the display depends on no solver type).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FrameReport {
    /// Frame number.
    pub frame: usize,
    /// Simulated time at the end of the frame (s).
    pub time: f64,
    /// Newton iterations of the frame (summed over substeps).
    pub newton_iterations: usize,
    /// CG iterations of the frame (summed over its Newton iterations).
    pub cg_iterations: usize,
    /// Final residual relative to the step's first (steps.csv's `relative_residual`; the
    /// absolute one, in N, is its `residual`).
    pub residual: f64,
    /// Final residual in N (steps.csv's `residual`).
    pub absolute_residual: f64,
    /// Whether every solve of the frame converged.
    pub converged: bool,
    /// Converged with a relative residual above the tolerance, on an absolute criterion (a
    /// residual below what rounding resolves, or contact's step-size rule): said so in the
    /// summary, which would otherwise read as a contradiction.
    pub within_floor: bool,
    /// Smallest J = det F over the tets at the end of the frame.
    pub min_j: f64,
    /// Wall-clock time spent on the frame (s).
    pub wall_seconds: f64,
}

/// How the run shows its progress.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum DisplayMode {
    /// A progress bar when stderr is a terminal, plain lines otherwise.
    #[default]
    Auto,
    /// Always the progress bar (indicatif hides it by itself when stderr is not a terminal).
    Bar,
    /// Plain lines on stderr, about twenty per run plus every frame that did not converge.
    Plain,
    /// Nothing while running; the summary is still returned by [`RunDisplay::finish`].
    Quiet,
}

/// Totals over the frames reported so far.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct RunTotals {
    /// Frames reported.
    pub frames: usize,
    /// Newton iterations over all frames.
    pub newton_iterations: usize,
    /// CG iterations over all frames.
    pub cg_iterations: usize,
    /// The most Newton iterations of one frame, and that frame.
    pub max_newton: Option<(usize, usize)>,
    /// The largest final relative residual, and its frame (non-finite residuals count as
    /// largest).
    pub worst_residual: Option<(f64, usize)>,
    /// The worst frame's absolute residual (N), when it converged on an absolute criterion.
    pub worst_within_floor: Option<f64>,
    /// The smallest min J, and its frame.
    pub min_j: Option<(f64, usize)>,
    /// Frames that did not converge, in the order reported.
    pub not_converged: Vec<usize>,
    /// Wall-clock seconds summed over the frames.
    pub solve_seconds: f64,
}

impl RunTotals {
    /// Add one frame.
    pub fn add(&mut self, r: &FrameReport) {
        self.frames += 1;
        self.newton_iterations += r.newton_iterations;
        self.cg_iterations += r.cg_iterations;
        self.solve_seconds += r.wall_seconds;
        if self.max_newton.is_none_or(|(n, _)| r.newton_iterations > n) {
            self.max_newton = Some((r.newton_iterations, r.frame));
        }
        let worse = |old: f64| !r.residual.is_finite() && old.is_finite() || r.residual > old;
        if self.worst_residual.is_none_or(|(old, _)| worse(old)) {
            self.worst_residual = Some((r.residual, r.frame));
            self.worst_within_floor = r.within_floor.then_some(r.absolute_residual);
        }
        let lower = |old: f64| r.min_j.is_nan() && !old.is_nan() || r.min_j < old;
        if self.min_j.is_none_or(|(old, _)| lower(old)) {
            self.min_j = Some((r.min_j, r.frame));
        }
        if !r.converged {
            self.not_converged.push(r.frame);
        }
    }
}

enum Output {
    Bar(ProgressBar),
    Plain,
    Quiet,
}

/// The progress display of one run.
pub struct RunDisplay {
    output: Output,
    /// The run's last frame.
    total: usize,
    /// The frame the display starts after (a resumed run's checkpoint; 0 for a new run).
    first: usize,
    totals: RunTotals,
    start: Instant,
    /// Time spent drawing pictures and plots, reported apart from the simulation's.
    pictures: Duration,
}

impl RunDisplay {
    /// A display for a run of `total_frames` frames (the frames to compute, not counting the
    /// initial state).
    pub fn new(total_frames: usize, mode: DisplayMode) -> Self {
        Self::resumed(0, total_frames, mode)
    }

    /// A display for a run that goes on from frame `first` to frame `last`: the bar and the
    /// lines count frames of the whole run (`frame 560/3000`), the rate and ETA those computed
    /// now.
    pub fn resumed(first: usize, last: usize, mode: DisplayMode) -> Self {
        let terminal = std::io::stderr().is_terminal();
        let output = match mode {
            DisplayMode::Quiet => Output::Quiet,
            DisplayMode::Plain => Output::Plain,
            DisplayMode::Auto if !terminal => Output::Plain,
            DisplayMode::Auto | DisplayMode::Bar => {
                let bar = progress_bar(last);
                bar.set_position(first.min(last) as u64);
                bar.reset_eta();
                Output::Bar(bar)
            }
        };
        RunDisplay {
            output,
            total: last,
            first: first.min(last),
            totals: RunTotals::default(),
            start: Instant::now(),
            pictures: Duration::ZERO,
        }
    }

    /// Record a finished frame and update the display.
    pub fn frame_done(&mut self, report: &FrameReport) {
        self.totals.add(report);
        let done = self.totals.frames;
        match &self.output {
            Output::Bar(bar) => {
                let mut msg = format!(
                    "t={:.3} s  Newton {}  CG {}  relative residual {:.1e}",
                    report.time, report.newton_iterations, report.cg_iterations, report.residual
                );
                if !self.totals.not_converged.is_empty() {
                    let _ = write!(msg, "  {} not converged", self.totals.not_converged.len());
                }
                bar.set_message(msg);
                bar.set_position((self.first + done) as u64);
            }
            Output::Plain => {
                let stride = ((self.total - self.first) / 20).max(1);
                if done == 1
                    || done.is_multiple_of(stride)
                    || self.first + done >= self.total
                    || !report.converged
                {
                    eprintln!("{}", self.plain_line(report));
                }
            }
            Output::Quiet => {}
        }
    }

    /// Print a line without breaking the bar (above it), or plainly; nothing when quiet.
    pub fn println(&self, line: &str) {
        match &self.output {
            Output::Bar(bar) => bar.println(line),
            Output::Plain => eprintln!("{line}"),
            Output::Quiet => {}
        }
    }

    /// The totals so far.
    pub fn totals(&self) -> &RunTotals {
        &self.totals
    }

    /// Remove the bar and return the end-of-run summary (see [`summary`]); printing it is up
    /// to the caller.
    pub fn finish(self, out_dir: &Path, files: &[PathBuf]) -> String {
        if let Output::Bar(bar) = &self.output {
            bar.finish_and_clear();
        }
        let wall = self.start.elapsed().saturating_sub(self.pictures);
        summary(&self.totals, wall, self.pictures, out_dir, files)
    }

    /// Count `took` as drawing pictures and plots: the summary's frames/s leaves it out and
    /// says it apart.
    pub fn add_pictures(&mut self, took: Duration) {
        self.pictures += took;
    }

    fn plain_line(&self, r: &FrameReport) -> String {
        let done = self.totals.frames;
        let elapsed = self.start.elapsed().as_secs_f64();
        let rate = if elapsed > 0.0 {
            done as f64 / elapsed
        } else {
            0.0
        };
        let eta = if rate > 0.0 {
            self.total.saturating_sub(self.first + done) as f64 / rate
        } else {
            0.0
        };
        format!(
            "frame {}/{}  t={:.3} s  Newton {}  CG {}  relative residual {:.1e}{}  min J {:.3}  ({:.1} frames/s, ETA {})",
            r.frame,
            self.total,
            r.time,
            r.newton_iterations,
            r.cg_iterations,
            r.residual,
            if r.converged { "" } else { " NOT CONVERGED" },
            r.min_j,
            rate,
            format_duration(Duration::from_secs_f64(eta)),
        )
    }
}

fn progress_bar(total: usize) -> ProgressBar {
    let style = ProgressStyle::with_template(
        "{spinner:.green} [{elapsed_precise}] {bar:30.cyan/blue} {pos:>4}/{len} frames  {fps}  ETA {eta}  {msg}",
    )
    .expect("the progress template is valid")
    .with_key("fps", |s: &ProgressState, w: &mut dyn std::fmt::Write| {
        let _ = write!(w, "{:.1} frames/s", s.per_sec());
    })
    .progress_chars("█▉▊▋▌▍▎▏ ");
    let bar = ProgressBar::with_draw_target(Some(total as u64), ProgressDrawTarget::stderr());
    bar.set_style(style);
    bar.enable_steady_tick(Duration::from_millis(200));
    bar
}

/// The one-screen end-of-run summary: frames and wall time, Newton and CG totals, the worst
/// residual, the smallest J, the frames that did not converge, and where the files are
/// (numbered series such as `frame_0000.vtu … frame_0060.vtu` collapsed to one line).
/// `wall` is the simulation's time (frames and their files), `pictures` the drawing's, said apart
/// (zero: not said).
pub fn summary(
    totals: &RunTotals,
    wall: Duration,
    pictures: Duration,
    out_dir: &Path,
    files: &[PathBuf],
) -> String {
    let mut s = String::new();
    let secs = wall.as_secs_f64();
    let rate = if secs > 0.0 {
        format!(" ({:.1} frames/s)", totals.frames as f64 / secs)
    } else {
        String::new()
    };
    let drawing = if pictures > Duration::ZERO {
        format!("; pictures and plots {}", format_duration(pictures))
    } else {
        String::new()
    };
    let _ = writeln!(
        s,
        "tetsim: {} frame{} in {}{rate}{drawing}",
        totals.frames,
        if totals.frames == 1 { "" } else { "s" },
        format_duration(wall)
    );
    let per = |n: usize, d: usize| if d > 0 { n as f64 / d as f64 } else { 0.0 };
    let mut newton = format!(
        "{} ({:.2} per frame",
        totals.newton_iterations,
        per(totals.newton_iterations, totals.frames)
    );
    if let Some((n, f)) = totals.max_newton {
        let _ = write!(newton, ", at most {n} in frame {f}");
    }
    newton.push(')');
    let row = |s: &mut String, key: &str, value: &str| {
        let _ = writeln!(s, "  {key:<24}{value}");
    };
    row(&mut s, "Newton iterations", &newton);
    row(
        &mut s,
        "CG iterations",
        &format!(
            "{} ({:.1} per Newton iteration)",
            totals.cg_iterations,
            per(totals.cg_iterations, totals.newton_iterations)
        ),
    );
    if let Some((r, f)) = totals.worst_residual {
        let floor = match totals.worst_within_floor {
            Some(abs) => format!("; converged on an absolute criterion: residual {abs:.2e} N"),
            None => String::new(),
        };
        row(
            &mut s,
            "worst relative residual",
            &format!("{r:.2e} (frame {f}{floor})"),
        );
    }
    if let Some((j, f)) = totals.min_j {
        let note = if j <= 0.0 { ": inverted elements" } else { "" };
        row(&mut s, "min J", &format!("{j:.4} (frame {f}){note}"));
    }
    let nc = &totals.not_converged;
    let not_converged = if nc.is_empty() {
        "none".to_string()
    } else {
        let shown: Vec<String> = nc.iter().take(12).map(usize::to_string).collect();
        let more = if nc.len() > 12 {
            format!(" and {} more", nc.len() - 12)
        } else {
            String::new()
        };
        format!(
            "{} frame{}: {}{more}",
            nc.len(),
            if nc.len() == 1 { "" } else { "s" },
            shown.join(", ")
        )
    };
    row(&mut s, "not converged", &not_converged);
    let mut dir = out_dir.display().to_string();
    if !dir.ends_with(std::path::MAIN_SEPARATOR) {
        dir.push(std::path::MAIN_SEPARATOR);
    }
    row(&mut s, "output", &dir);
    for line in file_lines(out_dir, files) {
        row(&mut s, "", &line);
    }
    s
}

/// File names relative to `out_dir`, numbered series collapsed, packed into lines of about
/// 60 characters.
fn file_lines(out_dir: &Path, files: &[PathBuf]) -> Vec<String> {
    // (prefix, digits, suffix) → names, in order of first appearance.
    let mut groups: Vec<((String, usize, String), Vec<String>)> = Vec::new();
    for f in files {
        let name = f.strip_prefix(out_dir).unwrap_or(f).display().to_string();
        let key = series_key(&name);
        match groups.iter_mut().find(|(k, _)| *k == key && k.1 > 0) {
            Some((_, names)) => names.push(name),
            None => groups.push((key, vec![name])),
        }
    }
    let items: Vec<String> = groups
        .into_iter()
        .map(|(_, names)| {
            if names.len() >= 3 {
                format!(
                    "{} … {} ({} files)",
                    names[0],
                    names[names.len() - 1],
                    names.len()
                )
            } else {
                names.join(", ")
            }
        })
        .collect();
    let mut lines: Vec<String> = Vec::new();
    for item in items {
        match lines.last_mut() {
            Some(line) if line.chars().count() + item.chars().count() < 60 => {
                line.push_str(", ");
                line.push_str(&item);
            }
            _ => lines.push(item),
        }
    }
    lines
}

/// `frame_0012.vtu` → ("frame_", 4, ".vtu"); names without a number get 0 digits.
fn series_key(name: &str) -> (String, usize, String) {
    let stem_end = name.rfind('.').unwrap_or(name.len());
    let (stem, suffix) = name.split_at(stem_end);
    let digits = stem.chars().rev().take_while(char::is_ascii_digit).count();
    let prefix = &stem[..stem.len() - digits];
    if digits == 0 {
        (name.to_string(), 0, String::new())
    } else {
        (prefix.to_string(), digits, suffix.to_string())
    }
}

/// "850 ms", "12.4 s", "3 min 05 s", "1 h 02 min".
fn format_duration(d: Duration) -> String {
    let s = d.as_secs_f64();
    if s < 1.0 {
        format!("{:.0} ms", s * 1e3)
    } else if s < 60.0 {
        format!("{s:.1} s")
    } else if s < 3600.0 {
        let m = (s / 60.0).floor();
        format!("{m:.0} min {:02.0} s", (s - 60.0 * m).floor())
    } else {
        let h = (s / 3600.0).floor();
        format!("{h:.0} h {:02.0} min", ((s - 3600.0 * h) / 60.0).floor())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn report(
        frame: usize,
        newton: usize,
        residual: f64,
        converged: bool,
        min_j: f64,
    ) -> FrameReport {
        FrameReport {
            frame,
            time: frame as f64 / 30.0,
            newton_iterations: newton,
            cg_iterations: 10 * newton,
            residual,
            absolute_residual: residual * 1e3,
            converged,
            within_floor: false,
            min_j,
            wall_seconds: 0.01,
        }
    }

    #[test]
    fn totals_track_extremes_and_failures() {
        let mut t = RunTotals::default();
        t.add(&report(1, 3, 1e-8, true, 0.99));
        t.add(&report(2, 5, 1e-5, false, 0.7));
        t.add(&report(3, 2, 1e-9, true, 0.8));
        assert_eq!(t.frames, 3);
        assert_eq!(t.newton_iterations, 10);
        assert_eq!(t.cg_iterations, 100);
        assert_eq!(t.max_newton, Some((5, 2)));
        assert_eq!(t.worst_residual, Some((1e-5, 2)));
        assert_eq!(t.min_j, Some((0.7, 2)));
        assert_eq!(t.not_converged, vec![2]);
        t.add(&report(4, 1, f64::NAN, false, f64::NAN));
        assert_eq!(t.worst_residual.unwrap().1, 4);
        assert_eq!(t.min_j.unwrap().1, 4);
    }

    #[test]
    fn summary_fits_one_screen_and_names_everything() {
        let mut t = RunTotals::default();
        for f in 1..=60 {
            t.add(&report(f, 3, 1e-8, f != 12, 0.9));
        }
        let out = Path::new("out");
        let mut files: Vec<PathBuf> = (0..=60)
            .map(|f| out.join(format!("frame_{f:04}.vtu")))
            .collect();
        for name in ["frames.pvd", "steps.csv", "preview.png", "animation.gif"] {
            files.push(out.join(name));
        }
        let s = summary(
            &t,
            Duration::from_secs_f64(12.5),
            Duration::ZERO,
            out,
            &files,
        );
        assert!(s.lines().count() <= 20, "{s}");
        assert!(s.contains("60 frames in 12.5 s"), "{s}");
        assert!(s.contains("Newton iterations       180"), "{s}");
        assert!(s.contains("CG iterations           1800"), "{s}");
        assert!(s.contains("1 frame: 12"), "{s}");
        assert!(
            s.contains("frame_0000.vtu … frame_0060.vtu (61 files)"),
            "{s}"
        );
        assert!(s.contains("animation.gif"), "{s}");
        assert!(s.contains("min J"), "{s}");
    }

    #[test]
    fn resumed_display_counts_the_whole_run() {
        let mut d = RunDisplay::resumed(560, 2441, DisplayMode::Plain);
        d.frame_done(&report(561, 2, 1e-9, true, 1.0));
        let line = d.plain_line(&report(561, 2, 1e-9, true, 1.0));
        assert!(line.starts_with("frame 561/2441 "), "{line}");
    }

    #[test]
    fn a_frame_converged_on_the_floor_says_so_beside_its_residual() {
        let mut totals = RunTotals::default();
        totals.add(&FrameReport {
            within_floor: true,
            absolute_residual: 3.1e-9,
            ..report(12, 1, 9.98e-2, true, 1.0)
        });
        let s = summary(
            &totals,
            Duration::from_secs(1),
            Duration::ZERO,
            Path::new("o"),
            &[],
        );
        assert!(
            s.contains(
                "9.98e-2 (frame 12; converged on an absolute criterion: residual 3.10e-9 N)"
            ),
            "{s}"
        );
        assert!(s.contains("not converged           none"), "{s}");
    }

    #[test]
    fn quiet_display_counts_without_printing() {
        let mut d = RunDisplay::new(2, DisplayMode::Quiet);
        d.frame_done(&report(1, 2, 1e-9, true, 1.0));
        d.frame_done(&report(2, 2, 1e-9, true, 1.0));
        assert_eq!(d.totals().frames, 2);
        let s = d.finish(Path::new("o"), &[]);
        assert!(s.starts_with("tetsim: 2 frames"), "{s}");
    }

    #[test]
    fn durations_read_naturally() {
        assert_eq!(format_duration(Duration::from_millis(850)), "850 ms");
        assert_eq!(format_duration(Duration::from_secs(185)), "3 min 05 s");
        assert_eq!(format_duration(Duration::from_secs(3720)), "1 h 02 min");
    }
}
