//! Per-kernel timing report over many frames: medians of each pass label's GPU time per frame
//! (from timestamp queries) and of the wall time per frame.

use crate::gpu::FrameTimings;
use std::fmt::Write;
use std::time::Duration;

/// Collects frames and reports medians.
#[derive(Clone, Debug, Default)]
pub struct TimingReport {
    /// Labels in first-seen order.
    labels: Vec<&'static str>,
    /// Per label: GPU µs per frame, one entry per frame that ran it.
    samples: Vec<Vec<f64>>,
    /// Per label: dispatches per frame (they vary when the substeps or passes do).
    counts: Vec<Vec<f64>>,
    /// Per label: each dispatch's GPU µs, over every frame (`median_dispatch_micros`).
    dispatch_micros: Vec<Vec<f64>>,
    wall_ms: Vec<f64>,
    /// Per frame: its dispatches (with timestamps).
    dispatches: Vec<f64>,
    gpu_total: Vec<f64>,
    /// Per frame: first pass's start to last pass's end (µs), for frames that had timestamps.
    gpu_span: Vec<f64>,
    skipped: Vec<&'static str>,
}

/// Median of a sample (0 for none).
pub fn median(values: &[f64]) -> f64 {
    if values.is_empty() {
        return 0.0;
    }
    let mut v = values.to_vec();
    v.sort_by(f64::total_cmp);
    let mid = v.len() / 2;
    if v.len() % 2 == 1 { v[mid] } else { 0.5 * (v[mid - 1] + v[mid]) }
}

impl TimingReport {
    /// Adds one frame: its GPU pass timings and its wall-clock time (submit to results).
    pub fn add(&mut self, frame: &FrameTimings, wall: Duration) {
        let by_label = frame.by_label();
        if !by_label.is_empty() {
            self.dispatches.push(by_label.iter().map(|(_, count, _)| f64::from(*count)).sum());
        }
        for (label, count, micros) in by_label {
            let slot = match self.labels.iter().position(|l| *l == label) {
                Some(i) => i,
                None => {
                    self.labels.push(label);
                    self.samples.push(Vec::new());
                    self.counts.push(Vec::new());
                    self.dispatch_micros.push(Vec::new());
                    self.labels.len() - 1
                }
            };
            self.samples[slot].push(micros);
            self.counts[slot].push(f64::from(count));
        }
        for pass in &frame.passes {
            if let (Some(micros), Some(slot)) = (pass.micros, self.labels.iter().position(|l| *l == pass.label)) {
                self.dispatch_micros[slot].push(micros);
            }
        }
        for s in &frame.skipped {
            if !self.skipped.contains(s) {
                self.skipped.push(s);
            }
        }
        self.gpu_total.push(frame.total_micros());
        self.gpu_span.extend(frame.span_micros);
        self.wall_ms.push(wall.as_secs_f64() * 1e3);
    }

    pub fn frames(&self) -> usize {
        self.wall_ms.len()
    }
    /// Median wall time per frame (ms).
    pub fn median_wall_ms(&self) -> f64 {
        median(&self.wall_ms)
    }
    /// Each frame's wall time (ms), in the order they were added.
    pub fn wall_ms_per_frame(&self) -> &[f64] {
        &self.wall_ms
    }
    /// Each frame's GPU span (µs, `median_span_micros`), in order; empty without timestamps.
    pub fn span_micros_per_frame(&self) -> &[f64] {
        &self.gpu_span
    }
    /// Fastest frame (ms): on a noisy (shared, virtual) machine the least disturbed measurement.
    pub fn min_wall_ms(&self) -> f64 {
        self.wall_ms.iter().copied().fold(f64::INFINITY, f64::min)
    }
    /// Median summed GPU time per frame (µs).
    pub fn median_gpu_micros(&self) -> f64 {
        median(&self.gpu_total)
    }
    /// Fastest summed GPU time of a frame (µs).
    pub fn min_gpu_micros(&self) -> f64 {
        self.gpu_total.iter().copied().fold(f64::INFINITY, f64::min)
    }
    /// Median GPU time per frame from its first pass's start to its last pass's end (µs): the
    /// passes plus the barriers and gaps between them (0 without timestamps).
    pub fn median_span_micros(&self) -> f64 {
        median(&self.gpu_span)
    }
    /// Shortest such span of a frame (µs; 0 without timestamps).
    pub fn min_span_micros(&self) -> f64 {
        self.gpu_span.iter().copied().reduce(f64::min).unwrap_or(0.0)
    }
    /// Frames that ran pass `label` (a tree's rebuild runs in some frames only).
    pub fn frames_running(&self, label: &str) -> usize {
        self.labels.iter().position(|l| *l == label).map_or(0, |i| self.samples[i].len())
    }
    /// Median dispatches per frame.
    pub fn median_dispatches(&self) -> f64 {
        median(&self.dispatches)
    }
    /// (label, median dispatches per frame, median µs per frame) for each pass label, over the
    /// frames that ran it (`frames_running`).
    pub fn rows(&self) -> Vec<(&'static str, u32, f64)> {
        self.labels
            .iter()
            .zip(&self.samples)
            .zip(&self.counts)
            .map(|((&l, s), n)| (l, median(n).round() as u32, median(s)))
            .collect()
    }
    /// Median GPU µs of one dispatch of pass `label`, over every dispatch of every frame (0 when
    /// it never ran with timestamps). Not the median frame's time over the median count: there a
    /// frame that ran more dispatches (substeps raised for contact, more self-collision passes)
    /// or one stalled dispatch (another tenant of a shared CPU driver's cores) raises the figure
    /// of every dispatch. A pass whose dispatches are mostly empty (the fail-safe's rounds after
    /// the first, which run only when the one before put a particle back) shows the empty
    /// dispatch's cost here and its whole cost in the frame's column.
    pub fn median_dispatch_micros(&self, label: &str) -> f64 {
        self.labels.iter().position(|l| *l == label).map_or(0.0, |i| median(&self.dispatch_micros[i]))
    }
    pub fn skipped(&self) -> &[&'static str] {
        &self.skipped
    }

    /// A text table: one row per pass label, then totals.
    pub fn table(&self) -> String {
        let mut out = String::new();
        let _ = writeln!(out, "{:<34} {:>10} {:>14} {:>14}", "pass", "dispatches", "GPU µs/frame", "median µs/disp.");
        for (label, n, micros) in self.rows() {
            let _ = write!(out, "{label:<34} {n:>10} {micros:>14.1} {:>14.1}", self.median_dispatch_micros(label));
            let ran = self.frames_running(label);
            if ran < self.frames() {
                let _ = write!(out, "   in {ran} of {} frames", self.frames());
            }
            let _ = writeln!(out);
        }
        for label in &self.skipped {
            let _ = writeln!(out, "{label:<34} {:>10} {:>14} {:>14}", 0, "skipped", "-");
        }
        let _ = writeln!(
            out,
            "{:<34} {:>10.0} {:>14.1}\n{:<34} {:>10} {:>14.1}\nwall time per frame over {} frames: median {:.3} ms, min {:.3} ms",
            "total GPU (sum of passes)",
            self.median_dispatches(),
            self.median_gpu_micros(),
            "GPU frame, first start to last end",
            "",
            self.median_span_micros(),
            self.frames(),
            self.median_wall_ms(),
            self.min_wall_ms()
        );
        out
    }
}

#[cfg(test)]
mod tests {
    use super::TimingReport;
    use crate::gpu::{FrameTimings, PassTiming};
    use std::time::Duration;

    fn frame(stages: &[f64]) -> FrameTimings {
        let passes = stages.iter().map(|&t| PassTiming { label: "rk4: k1", micros: Some(t) }).collect();
        FrameTimings { passes, skipped: Vec::new(), span_micros: Some(stages.iter().sum()) }
    }

    /// Frames of 10 and 20 dispatches of 200 µs, a few with one stalled dispatch: a dispatch's
    /// median is 200 µs, where the median frame's sum over the median count is not.
    #[test]
    fn a_dispatch_s_median_is_taken_over_dispatches_not_frame_sums() {
        let mut report = TimingReport::default();
        let wall = Duration::from_millis(1);
        for f in 0..9 {
            let mut stages = vec![200.0; if f % 3 == 0 { 20 } else { 10 }];
            if f % 2 == 0 {
                stages[0] = 1200.0;
            }
            report.add(&frame(&stages), wall);
        }
        assert_eq!(report.median_dispatch_micros("rk4: k1"), 200.0);
        let (_, count, per_frame) = report.rows()[0];
        assert_eq!(count, 10);
        assert!(per_frame / f64::from(count) > 250.0, "the old figure, {per_frame} / {count}, is raised by the stalls");
        assert!(report.table().contains("200.0"), "{}", report.table());
        assert_eq!(report.median_dispatch_micros("a pass that never ran"), 0.0);
    }
}
