//! timings.csv: wall-clock seconds per frame, split by phase. Never deterministic, never hashed
//! in the manifest, never in the checkpoint (a resumed run keeps the rows up to its frame).
//!
//! With contact, three more columns say where contact's own time went in the frame (broad phase,
//! barrier pairs, CCD), so the cost of a frame where bodies touch can be read per frame rather
//! than as a run's average that the frames before the touch dilute.

use std::fmt::Write as _;

use crate::contact::term::ContactCosts;
use crate::integrator::Timings;

/// The header of timings.csv: wall-clock seconds per frame, split by phase.
pub const TIMINGS_HEADER: &str =
    "frame,wall_seconds,evaluate_seconds,preconditioner_seconds,cg_seconds";

/// The columns appended with contact: seconds in the broad phase (BVH builds and queries), the
/// barrier's pairs (distances, derivatives, projection, scatter) and CCD, over the frame. They
/// overlap the evaluate and preconditioner columns (contact runs inside those phases).
pub const CONTACT_TIMING_COLUMNS: &str = "broad_phase_seconds,barrier_seconds,ccd_seconds";

/// The text of timings.csv as it grows.
pub(super) struct TimingsCsv {
    text: String,
    /// The contact term's running totals at the last row (they count from the process's start,
    /// so a resumed run starts from zero too).
    last: Option<ContactCosts>,
}

impl TimingsCsv {
    /// The header, with the contact columns when `contact`.
    pub fn new(contact: bool) -> Self {
        let text = if contact {
            format!("{TIMINGS_HEADER},{CONTACT_TIMING_COLUMNS}\n")
        } else {
            format!("{TIMINGS_HEADER}\n")
        };
        TimingsCsv {
            text,
            last: contact.then(ContactCosts::default),
        }
    }

    /// Keep the rows of an earlier file up to frame `last` (a resumed run).
    pub fn keep_rows(&mut self, earlier: &str, last: usize) {
        for row in earlier.lines().skip(1) {
            let frame = row.split(',').next().and_then(|f| f.parse::<usize>().ok());
            if frame.is_some_and(|f| f <= last) {
                self.text.push_str(row);
                self.text.push('\n');
            }
        }
    }

    /// A frame's row; `contact` is the contact term's running totals now.
    pub fn push(&mut self, frame: usize, wall: f64, t: &Timings, contact: Option<ContactCosts>) {
        let _ = write!(
            self.text,
            "{frame},{},{},{},{}",
            super::num(wall),
            super::num(t.evaluate),
            super::num(t.preconditioner),
            super::num(t.cg)
        );
        if let (Some(last), Some(now)) = (&mut self.last, contact) {
            let _ = write!(
                self.text,
                ",{},{},{}",
                super::num(now.broad_seconds - last.broad_seconds),
                super::num(now.barrier_seconds - last.barrier_seconds),
                super::num(now.ccd_seconds - last.ccd_seconds)
            );
            *last = now;
        }
        self.text.push('\n');
    }

    /// The file's text.
    pub fn text(&self) -> &str {
        &self.text
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn contact_columns_hold_each_frames_share_of_the_running_totals() {
        let mut csv = TimingsCsv::new(true);
        let t = Timings::default();
        let at = |s: f64| ContactCosts {
            broad_seconds: s,
            barrier_seconds: 2.0 * s,
            ccd_seconds: 3.0 * s,
            ..Default::default()
        };
        csv.push(1, 1.0, &t, Some(at(0.5)));
        csv.push(2, 1.0, &t, Some(at(1.25)));
        let rows: Vec<&str> = csv.text().lines().collect();
        assert_eq!(
            rows[0],
            format!("{TIMINGS_HEADER},{CONTACT_TIMING_COLUMNS}")
        );
        assert_eq!(rows[1], "1,1,0,0,0,0.5,1,1.5");
        assert_eq!(rows[2], "2,1,0,0,0,0.75,1.5,2.25");
    }

    #[test]
    fn without_contact_the_header_and_rows_are_as_they_always_were() {
        let mut csv = TimingsCsv::new(false);
        csv.push(3, 0.25, &Timings::default(), None);
        csv.keep_rows("header\n1,9,9,9,9\n5,9,9,9,9\n", 1);
        assert_eq!(
            csv.text(),
            format!("{TIMINGS_HEADER}\n3,0.25,0,0,0\n1,9,9,9,9\n")
        );
    }
}
