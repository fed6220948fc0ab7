//! The red dots on fixed vertices: which may show, which the surface hides (band by band), and their size.

use super::*;

/// The fixed vertices that may get a red dot: on the surface, on the kept side of the cut and in
/// front of the camera. Whether the surface hides one is decided band by band, from the depth
/// of the 3×3 samples around it ([`MarkerCandidates::seen_in_band`]).
#[derive(Default)]
pub(super) struct MarkerCandidates {
    /// Where each projects, in supersampled screen coordinates, and its depth.
    at: Vec<[f64; 3]>,
    /// How much farther than the surface seen there it may be and still count as visible.
    slack: Vec<f64>,
    ss: usize,
    size: (usize, usize),
}

impl MarkerCandidates {
    pub(super) fn new(
        view: &SceneView<'_>,
        params: &RenderParams,
        proj: &Projection,
        ss: usize,
    ) -> MarkerCandidates {
        let mut candidates = MarkerCandidates {
            ss,
            size: (params.width as usize * ss, params.height as usize * ss),
            ..MarkerCandidates::default()
        };
        if view.fixed.is_empty() {
            return candidates;
        }
        let x = view.positions;
        let surface = view.mesh.on_surface();
        let kept = |p: &Vec3| {
            params
                .clip
                .is_none_or(|c| (p - c.point).dot(&c.normal) <= 0.0)
        };
        let tolerance = 3e-3 * proj.scale;
        for v in 0..x.len() {
            if !(view.fixed[v] && surface[v] && kept(&x[v])) {
                continue;
            }
            let Some(at) = proj.project(&x[v]) else {
                continue;
            };
            candidates.at.push(at);
            candidates.slack.push(tolerance + 3.0 * at[2] / proj.focal);
        }
        candidates
    }

    /// The sample rows around candidate `i` (clipped to the frame; may be empty).
    fn rows(&self, i: usize) -> std::ops::Range<i64> {
        let cy = self.at[i][1].floor() as i64;
        cy.saturating_sub(1).max(0)..cy.saturating_add(2).min(self.size.1 as i64)
    }

    /// For each band of `band_h` sample rows (of `h`), the candidates whose neighbourhood reaches
    /// into it.
    pub(super) fn bin(&self, band_h: usize, h: usize) -> Vec<Vec<u32>> {
        let mut bins: Vec<Vec<u32>> = vec![Vec::new(); h.div_ceil(band_h)];
        for i in 0..self.at.len() {
            let rows = self.rows(i);
            if rows.is_empty() {
                continue;
            }
            let (first, last) = (
                rows.start as usize / band_h,
                (rows.end - 1) as usize / band_h,
            );
            for bin in &mut bins[first..=last] {
                bin.push(i as u32);
            }
        }
        bins
    }

    /// Which of the candidates in `bin` the band (sample rows from `row0`, `w` samples wide) shows:
    /// a sample next to the vertex sees the background or a surface no nearer than the vertex
    /// (less the slack).
    pub(super) fn seen_in_band(
        &self,
        bin: &[u32],
        row0: usize,
        w: usize,
        band: &BandBuffers,
    ) -> Vec<u32> {
        let rows = band.ids.len() / w;
        let band_rows = row0 as i64..(row0 + rows) as i64;
        bin.iter()
            .copied()
            .filter(|&i| {
                let [sx, _, z] = self.at[i as usize];
                let cx = sx.floor() as i64;
                let slack = self.slack[i as usize];
                self.rows(i as usize)
                    .filter(|qy| band_rows.contains(qy))
                    .any(|qy| {
                        (cx.saturating_sub(1)..=cx.saturating_add(1))
                            .filter(|&qx| qx >= 0 && qx < w as i64)
                            .any(|qx| {
                                let k = (qy as usize - row0) * w + qx as usize;
                                band.ids[k] == u32::MAX || band.depth[k] as f64 >= z - slack
                            })
                    })
            })
            .collect()
    }

    /// Red dots on the candidates some band saw (`seen`: per band); returns how many.
    pub(super) fn draw(&self, img: &mut Image, seen: &[Vec<u32>], font_px: f32) -> usize {
        let mut visible = vec![false; self.at.len()];
        for &i in seen.iter().flatten() {
            visible[i as usize] = true;
        }
        let ss = self.ss as f64;
        let centres: Vec<(f64, f64)> = (0..self.at.len())
            .filter(|&i| visible[i])
            .map(|i| (self.at[i][0] / ss, self.at[i][1] / ss))
            .collect();
        // Marker size: about a third of the typical distance between neighbouring markers on
        // screen, so that dense clamps (or clamps seen edge-on) do not become a red smear; and
        // where they crowd, one marker per patch of a few radii, so that a held region reads
        // as dotted rather than painted over.
        let max_r = 0.22 * font_px as f64;
        let r = match typical_spacing(&centres) {
            Some(spacing) => (0.3 * spacing).clamp(1.5, max_r),
            None => max_r,
        };
        let kept = thin(&centres, (5.0 * r).max(1.5 * font_px as f64));
        for &c in &kept {
            text::draw_disc(img, c, r, MARKER_FILL, MARKER_EDGE);
        }
        centres.len()
    }
}

/// The points, thinned so that at most one is kept in every `gap` × `gap` square of a grid
/// (the first in order: deterministic).
fn thin(points: &[(f64, f64)], gap: f64) -> Vec<(f64, f64)> {
    let mut taken = std::collections::BTreeSet::new();
    points
        .iter()
        .copied()
        .filter(|p| taken.insert(((p.0 / gap).floor() as i64, (p.1 / gap).floor() as i64)))
        .collect()
}

/// The median distance from a point to its nearest neighbour (None for fewer than 2 points).
/// Large sets are thinned to 2000 evenly spaced points first (the median barely moves).
fn typical_spacing(points: &[(f64, f64)]) -> Option<f64> {
    if points.len() < 2 {
        return None;
    }
    let step = points.len().div_ceil(2000);
    let sample: Vec<(f64, f64)> = points.iter().copied().step_by(step).collect();
    let mut nearest: Vec<f64> = sample
        .iter()
        .enumerate()
        .map(|(i, a)| {
            sample
                .iter()
                .enumerate()
                .filter(|(j, _)| *j != i)
                .map(|(_, b)| (a.0 - b.0).hypot(a.1 - b.1))
                .fold(f64::INFINITY, f64::min)
        })
        .collect();
    nearest.sort_by(f64::total_cmp);
    Some(nearest[nearest.len() / 2])
}
